"""slam_gmapping stand-in (run it as node name ``slam_gmapping``).

Subscribes ``scan`` (sensor_msgs/LaserScan) and reads odometry from TF (odom -> base_link and
base_link -> laser at the scan's stamp). Publishes ``map`` (latched nav_msgs/OccupancyGrid,
-1/0/100), ``map_metadata`` (latched), ``~entropy`` (std_msgs/Float64), TF map -> odom, and
serves ``dynamic_map`` (nav_msgs/GetMap). Parameters: gmapping's names (see
``ascc_navigation.mapper.SlamNodeParams`` and the package README). The scan callback only queues
the scan (the newest SCAN_BUFFER); a timer feeds them to the filter in order, another one
broadcasts map -> odom.
"""

import re
import threading
import time
from collections import deque

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import MapMetaData, OccupancyGrid
from nav_msgs.srv import GetMap, GetMapResponse
from rospy.numpy_msg import numpy_msg
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from ascc_common.grid import grid_to_msg_data
from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import quaternion_from_yaw, yaw_from_quaternion
from ascc_navigation import mapper as M
from ascc_navigation.climb import warm_up
from ascc_navigation.ros.laser_tf import mount_from_tf

WARN_PERIOD_S = 5.0  # each kind of warning at most once per this period (wall clock)
SCAN_BUFFER = 5  # scans waiting for the mapper, oldest dropped first (gmapping's filter: 5)
WAIT = "wait"  # lookup_poses: TF not there yet
DROP = "drop"  # lookup_poses: scan unusable (warned)


class SlamMapperNode:
    def __init__(self):
        p = from_params(M.SlamNodeParams, rospy.get_param, "~")
        self.mapper = M.SlamMapper(p.mapper, seed=p.seed)
        self.base_frame = p.base_frame
        self.odom_frame = p.odom_frame
        self.map_frame = p.map_frame
        self.map_update_interval = rospy.Duration(p.map_update_interval)
        tf_period = p.transform_publish_period
        self.last_tf_stamp = None
        self.tf_delay = rospy.Duration(p.tf_delay_s())
        self.tf_wait = rospy.Duration(p.tf_wait_s)
        self.lock = threading.Lock()
        self.scans = deque(maxlen=SCAN_BUFFER)  # unprocessed scans, oldest first
        self.received = 0            # scans received ...
        self.overflowed = 0          # ... and dropped unseen from a full queue
        self.overflow_reported = 0
        self.map_msg = None          # last published map (numpy_msg; for dynamic_map)
        self.map_dirty = False
        self.last_map_time = None
        self.map_to_odom = (0.0, 0.0, 0.0)
        self.warned = {}             # warning kind -> wall time it was last logged

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.tf_broadcaster = tf2_ros.TransformBroadcaster()
        # numpy_msg: the grid is serialized from its int8 array in one write; the plain
        # class packs a Python list of every cell (a million-cell map: tens of ms a time).
        # Same type and md5: subscribers see a nav_msgs/OccupancyGrid.
        self.map_pub = rospy.Publisher("map", numpy_msg(OccupancyGrid), queue_size=1,
                                       latch=True)
        self.meta_pub = rospy.Publisher("map_metadata", MapMetaData, queue_size=1, latch=True)
        self.entropy_pub = rospy.Publisher("~entropy", Float64, queue_size=5)
        self.service = rospy.Service("dynamic_map", GetMap, self.on_get_map)
        # the compiled scan matcher loaded (or compiled) before the first scan arrives
        rospy.loginfo("slam_mapper: compiled scan matcher ready (%.2f s of CPU)" % warm_up())
        # numpy_msg: the ranges arrive as one array, not a tuple of Python floats
        rospy.Subscriber("scan", numpy_msg(LaserScan), self.on_scan, queue_size=1)
        # PacedTimer, not rospy.Timer: under simulated time that wakes on every /clock
        # message (ascc_common.paced_timer)
        self.timers = [PacedTimer(p.process_period_s, self.on_process,
                                  rospy.get_time, rospy.core.is_shutdown_requested, name="process")]
        if tf_period > 0.0:
            self.timers.append(PacedTimer(tf_period, self.on_publish_tf,
                                          rospy.get_time, rospy.core.is_shutdown_requested,
                                          name="map_to_odom"))

    # -- callbacks -------------------------------------------------------------------
    def on_scan(self, msg):
        with self.lock:
            self.received += 1
            if len(self.scans) == SCAN_BUFFER:
                self.overflowed += 1
            self.scans.append(msg)

    def on_get_map(self, _req):
        with self.lock:
            msg = self.map_msg
        if msg is None:
            raise rospy.ServiceException("no map yet: no scan has been processed")
        # The service's serializer packs a sequence of ints: give it the list (only here,
        # not on every publication).
        out = OccupancyGrid(header=msg.header, info=msg.info,
                            data=grid_to_msg_data(msg.data))
        return GetMapResponse(map=out)

    def on_publish_tf(self):
        stamp = rospy.Time.now() + self.tf_delay
        if stamp == self.last_tf_stamp:
            # A timer catching up (process behind /clock) fires at the same time: one
            # transform per stamp, or tf2 warns TF_REPEATED_DATA.
            return
        self.last_tf_stamp = stamp
        x, y, yaw = self.map_to_odom
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = self.map_frame
        t.child_frame_id = self.odom_frame
        t.transform.translation.x = x
        t.transform.translation.y = y
        (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
         t.transform.rotation.w) = quaternion_from_yaw(yaw)
        self.tf_broadcaster.sendTransform(t)

    def on_process(self):
        """Feed the waiting scans to the mapper oldest first, as gmapping's message filter
        does: each scan's motion counts towards linearUpdate / angularUpdate, so the
        filter updates where they ask as long as it falls no more than SCAN_BUFFER scans
        behind (beyond that the oldest are dropped unseen). Stops at the first scan whose
        TF has not arrived yet."""
        with self.lock:
            waiting = list(self.scans)
            overflowed, received = self.overflowed, self.received
        if overflowed > self.overflow_reported:
            self.overflow_reported = overflowed
            self.warn("slam_mapper: the filter fell more than %d scans behind the laser (CPU "
                      "short, or TF late); %d of %d scans so far were dropped unseen"
                      % (SCAN_BUFFER, overflowed, received))
        for scan in waiting:
            poses = self.lookup_poses(scan)
            if poses is WAIT:
                return  # the later scans' TF has not come either
            with self.lock:  # this scan is done (unless the buffer has let it go already)
                if any(s is scan for s in self.scans):
                    while self.scans.popleft() is not scan:
                        pass
            if poses is not DROP:
                self.process(scan, *poses)

    def process(self, scan, odom_pose, mount):
        out = self.mapper.handle_scan(
            M.ScanInput(scan.header.stamp.to_sec(), scan.ranges, scan.angle_min,
                        scan.angle_increment, scan.range_min, scan.range_max),
            odom_pose, mount)
        if out.reason and out.status in (M.REJECTED, M.RESET):
            self.warn("slam_mapper: %s" % out.reason)
        self.report_loop(out.loop)
        if out.status == M.RESET:
            self.last_map_time = None
        if out.stats is not None:
            self.entropy_pub.publish(Float64(out.stats.entropy))
        self.map_to_odom = tuple(float(v) for v in self.mapper.map_to_odom())
        self.map_dirty = self.map_dirty or out.map_changed
        now = rospy.Time.now()
        if self.last_map_time is not None and now < self.last_map_time:
            self.last_map_time = None  # time jumped back
        if self.map_dirty and (self.last_map_time is None
                               or now - self.last_map_time >= self.map_update_interval):
            self.publish_map(now)

    # -- helpers ---------------------------------------------------------------------
    def report_loop(self, loop):
        """Log a loop closure (and publish its rebuilt map at once), a closure rejected by
        loop_max_correction_m, or two loop matches that disagree (``loop``: ``Outcome.loop``,
        None without a loop search)."""
        if loop is None:
            return
        if loop.status == "closed":
            rospy.loginfo("slam_mapper: %s; map rebuilt", loop.reason)
            self.map_dirty = True
            self.last_map_time = None
        elif loop.status == "rejected" and "loop_max_correction_m" in loop.reason:
            self.warn("slam_mapper: %s" % loop.reason)
        elif loop.status == "rejected" and "disagree" in loop.reason:  # loop_confirm
            rospy.loginfo("slam_mapper: %s", loop.reason)

    def warn(self, text):
        """Log a warning, each kind (the text without its numbers) once per WARN_PERIOD_S."""
        kind = re.sub(r"[-+]?\d[\d.e+-]*", "#", text)
        now = time.monotonic()
        if now - self.warned.get(kind, -WARN_PERIOD_S) >= WARN_PERIOD_S:
            self.warned[kind] = now
            rospy.logwarn(text)

    def lookup_poses(self, scan):
        """(odom pose of the base, laser mount) at the scan's stamp; WAIT if its TF has not
        arrived yet, DROP (warned) if it cannot be used."""
        frame = scan.header.frame_id
        if not frame:
            self.warn("slam_mapper: scan without frame_id dropped")
            return DROP
        try:
            odom = self.tf_buffer.lookup_transform(self.odom_frame, self.base_frame,
                                                   scan.header.stamp)
            mount = mount_from_tf(self.tf_buffer, self.base_frame, frame, 0.0,
                                  scan.header.stamp)
        except tf2_ros.ExtrapolationException as err:
            if rospy.Time.now() - scan.header.stamp < self.tf_wait:
                return WAIT  # TF for this stamp has not arrived yet: retry on the next tick
            self.warn("slam_mapper: no TF at the scan's stamp, scan dropped: %s" % err)
            return DROP
        except tf2_ros.TransformException as err:
            self.warn("slam_mapper: scan in frame '%s' dropped: no TF %s -> %s / %s -> '%s' "
                      "(%s)" % (frame, self.odom_frame, self.base_frame, self.base_frame,
                                frame, err))
            return DROP
        except ValueError as err:
            self.warn("slam_mapper: scan in frame '%s' dropped: %s" % (frame, err))
            return DROP
        tr, q = odom.transform.translation, odom.transform.rotation
        return (tr.x, tr.y, yaw_from_quaternion(q.x, q.y, q.z, q.w)), mount

    def publish_map(self, now):
        grid, info = self.mapper.occupancy()
        meta = MapMetaData()
        meta.map_load_time = now
        meta.resolution = info.resolution
        meta.width = info.width
        meta.height = info.height
        meta.origin.position.x = info.origin_x
        meta.origin.position.y = info.origin_y
        meta.origin.orientation.w = 1.0
        msg = numpy_msg(OccupancyGrid)()
        msg.header.stamp = now
        msg.header.frame_id = self.map_frame
        msg.info = meta
        msg.data = np.ascontiguousarray(grid, dtype=np.int8).ravel()
        self.map_pub.publish(msg)
        self.meta_pub.publish(meta)
        with self.lock:
            self.map_msg = msg
        self.map_dirty = False
        self.last_map_time = now


def main():
    rospy.init_node("slam_gmapping")
    try:
        SlamMapperNode()
    except ValueError as err:  # a parameter with a wrong type or range
        rospy.logfatal("slam_mapper: %s" % err)
        raise SystemExit(1) from err
    rospy.spin()
