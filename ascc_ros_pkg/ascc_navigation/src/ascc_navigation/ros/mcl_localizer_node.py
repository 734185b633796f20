"""amcl stand-in: Monte Carlo localization on a known map (run it as node name ``amcl``).

Subscribes ``scan`` (sensor_msgs/LaserScan), ``map`` (nav_msgs/OccupancyGrid, latched, e.g.
from map_server or the simulator's ground truth remapped) and ``initialpose``
(PoseWithCovarianceStamped); reads odometry from TF (odom -> base_link at the scan's stamp,
base_link -> laser). Publishes ``amcl_pose`` (latched PoseWithCovarianceStamped, covariance
from the particle spread), ``particlecloud`` (PoseArray) and TF map -> odom, post-dated by
``~transform_tolerance``. Services ``global_localization`` and ``request_nomotion_update``
(std_srvs/Empty). With ``~refine_estimate`` (stand-in only) the published pose is
scan-matched to the map after every filter update (ascc_navigation.mcl.refine_pose).
Parameters: amcl's names (``ascc_navigation.mcl.MclNodeParams``, config/amcl.yaml,
package README). Callbacks only store the newest message; a timer runs
the filter (ascc_navigation.mcl).
"""

import threading

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Pose, PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty, EmptyResponse

from ascc_common.grid import map_from_msg
from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import quaternion_from_yaw, yaw_from_quaternion
from ascc_navigation import mcl
from ascc_navigation.ros.laser_tf import mount_from_tf

WARN_PERIOD_S = 5.0  # throttle period of repeated warnings [s]
DEFAULT_RANGE_MAX_M = 4.0  # z_rand's range when ~laser_max_range is unset (URG-04LX)


def pose_msg(x, y, yaw):
    p = Pose()
    p.position.x, p.position.y = x, y
    q = quaternion_from_yaw(yaw)
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = q
    return p


class MclLocalizerNode:
    def __init__(self):
        p = from_params(mcl.MclNodeParams, rospy.get_param, "~")
        self.params = p.filter
        self.global_frame = p.global_frame_id
        self.odom_frame = p.odom_frame_id
        self.base_frame = p.base_frame_id
        self.tf_tolerance = rospy.Duration(p.transform_tolerance)
        self.tf_broadcast = p.tf_broadcast
        self.first_map_only = p.first_map_only
        self.laser_min_range = p.laser_min_range  # [m], -1: scan's
        self.laser_max_range = p.laser_max_range  # [m], -1: scan's
        gui_rate = p.gui_publish_rate  # [Hz], -1: every update
        self.cloud_period = rospy.Duration(1.0 / gui_rate) if gui_rate > 0 else rospy.Duration(0)
        self.tf_wait = rospy.Duration(p.tf_wait_s)  # [s] for odom TF
        self.initial = (np.array([p.initial_pose_x, p.initial_pose_y, p.initial_pose_a]),
                        np.diag([p.initial_cov_xx, p.initial_cov_yy, p.initial_cov_aa]))
        self.rng = np.random.default_rng(None if p.seed < 0 else p.seed)

        self.lock = threading.Lock()
        self.pending_scan = None
        self.pending_map = None
        self.pending_initial = None
        self.pending_global = False
        self.localizer = None
        self.mounts = {}  # laser frame -> LaserMount
        self.last_stamp = None  # stamp of the last processed scan
        self.map_to_odom = None  # (x, y, yaw), once the filter has run
        self.last_cloud = rospy.Time(0)

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.tf_broadcaster = tf2_ros.TransformBroadcaster()
        self.pose_pub = rospy.Publisher("amcl_pose", PoseWithCovarianceStamped, queue_size=2,
                                        latch=True)
        self.cloud_pub = rospy.Publisher("particlecloud", PoseArray, queue_size=2, latch=True)
        rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1)
        rospy.Subscriber("map", OccupancyGrid, self.on_map, queue_size=1)
        rospy.Subscriber("initialpose", PoseWithCovarianceStamped, self.on_initial_pose,
                         queue_size=1)
        rospy.Service("global_localization", Empty, self.on_global_localization)
        rospy.Service("request_nomotion_update", Empty, self.on_nomotion_update)
        # not a rospy.Timer: under simulated time that wakes on every /clock message
        self.timer = PacedTimer(p.process_period_s, self.on_timer,
                                rospy.get_time, rospy.core.is_shutdown_requested, name="filter")

    # -- callbacks: store the newest input -----------------------------------------------
    def on_scan(self, msg):
        self.pending_scan = msg

    def on_map(self, msg):
        if self.first_map_only and self.localizer is not None:
            return
        self.pending_map = msg

    def on_initial_pose(self, msg):
        self.pending_initial = msg

    def on_global_localization(self, _req):
        self.pending_global = True
        return EmptyResponse()

    def on_nomotion_update(self, _req):
        with self.lock:
            if self.localizer is not None:
                self.localizer.request_nomotion_update()
        return EmptyResponse()

    # -- the work, on the timer ---------------------------------------------------------
    def on_timer(self):
        with self.lock:
            self._apply_map()
            if self.localizer is None:
                return
            self._apply_requests()
            scan, self.pending_scan = self.pending_scan, None
            if scan is not None:
                self._process(scan)

    def _apply_map(self):
        msg, self.pending_map = self.pending_map, None
        if msg is None:
            return
        try:
            grid, info = map_from_msg(msg)
            info.check_axis_aligned()
            field = mcl.LikelihoodField(grid, info, self.params.laser_sigma_hit,
                                        self.params.laser_z_hit, self.params.laser_z_rand,
                                        self.params.laser_likelihood_max_dist,
                                        self.laser_max_range if self.laser_max_range > 0
                                        else DEFAULT_RANGE_MAX_M)
        except ValueError as e:
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: ignoring map: %s" % e)
            return
        if msg.header.frame_id and msg.header.frame_id != self.global_frame:
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: map frame '%s' is not ~global_frame_id "
                                   "'%s'; using it as such" % (msg.header.frame_id,
                                                               self.global_frame))
        rospy.loginfo("amcl: map %dx%d cells at %.3f m", info.width, info.height,
                      info.resolution)
        if self.localizer is None:
            self.localizer = mcl.MonteCarloLocalizer(field, self.params, self.rng)
            self.localizer.initialize_gaussian(*self.initial)
            rospy.loginfo("amcl: initial pose (%.2f, %.2f, %.2f)", *self.initial[0])
        else:
            self.localizer.set_map(field)

    def _apply_requests(self):
        msg, self.pending_initial = self.pending_initial, None
        if msg is not None:
            if msg.header.frame_id and msg.header.frame_id != self.global_frame:
                rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: ignoring initial pose in frame "
                                       "'%s' (expected '%s')" % (msg.header.frame_id,
                                                                 self.global_frame))
            else:
                self._set_initial(msg)
        if self.pending_global:
            self.pending_global = False
            self.localizer.initialize_global()
            self.localizer.reset_odometry()
            rospy.loginfo("amcl: global localization: %d particles spread over the free "
                          "space", len(self.localizer.poses))

    def _set_initial(self, msg):
        p = msg.pose.pose
        q = p.orientation
        values = [p.position.x, p.position.y, q.x, q.y, q.z, q.w]
        if not np.all(np.isfinite(values)) or abs(q.x) + abs(q.y) + abs(q.z) + abs(q.w) == 0:
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: ignoring initial pose with NaN or a "
                                   "zero quaternion")
            return
        c = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)[np.ix_([0, 1, 5],
                                                                            [0, 1, 5])]
        if not np.all(np.isfinite(c)) or np.any(np.linalg.eigvalsh(0.5 * (c + c.T)) < 0):
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: initial pose covariance is not valid; "
                                   "using ~initial_cov_*")
            c = self.initial[1]
        mean = (p.position.x, p.position.y, yaw_from_quaternion(q.x, q.y, q.z, q.w))
        self.localizer.initialize_gaussian(mean, c)
        self.localizer.reset_odometry()
        rospy.loginfo("amcl: initial pose (%.2f, %.2f, %.2f)", *mean)

    def _mount(self, frame, stamp):
        if frame not in self.mounts:
            self.mounts[frame] = mount_from_tf(self.tf_buffer, self.base_frame, frame,
                                               self.tf_wait.to_sec(), stamp)
        return self.mounts[frame]

    def _process(self, scan):
        stamp = scan.header.stamp
        if self.last_stamp is not None and stamp < self.last_stamp:
            rospy.logwarn("amcl: scan time went back by %.2f s (bag loop or restarted clock): "
                          "clearing TF, next scan updates without odometry",
                          (self.last_stamp - stamp).to_sec())
            self.tf_buffer.clear()
            self.mounts.clear()
            self.localizer.reset_odometry()
        self.last_stamp = stamp
        if not scan.header.frame_id:
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: scan has an empty frame_id; ignored")
            return
        try:
            mount = self._mount(scan.header.frame_id, stamp)
            t = self.tf_buffer.lookup_transform(self.odom_frame, self.base_frame, stamp,
                                                self.tf_wait)
        except (tf2_ros.TransformException, ValueError) as e:
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: no usable transform for scan frame "
                                   "'%s' at %.2f (%s -> %s): %s" % (
                                       scan.header.frame_id, stamp.to_sec(), self.odom_frame,
                                       self.base_frame, e))
            return
        tr, q = t.transform.translation, t.transform.rotation
        odom = np.array([tr.x, tr.y, yaw_from_quaternion(q.x, q.y, q.z, q.w)])
        rmin = max(scan.range_min, self.laser_min_range)
        rmax = self.laser_max_range if self.laser_max_range > 0 else scan.range_max
        pts = mcl.scan_endpoints(scan.ranges, scan.angle_min, scan.angle_increment, mount,
                                 rmin, rmax, self.params.laser_max_beams)
        if len(pts) == 0:
            rospy.logwarn_throttle(WARN_PERIOD_S, "amcl: scan in '%s' has no valid range (%d "
                                   "beams, all NaN/inf or outside [%.2f, %.2f) m)" % (
                                       scan.header.frame_id, len(scan.ranges), rmin, rmax))
        elif self.localizer.process(odom, pts):
            if self.params.refine_estimate:
                many = mcl.scan_endpoints(scan.ranges, scan.angle_min, scan.angle_increment,
                                          mount, rmin, rmax, self.params.refine_max_beams)
                mean, cov = self.localizer.refined_estimate(many)
                rospy.logdebug("amcl: refinement moved the estimate %.3f m, %.4f rad",
                               *self.localizer.last_refinement[:2])
            else:
                mean, cov = self.localizer.estimate()
            self.map_to_odom = mcl.map_to_odom(mean, odom)
            self._publish_pose(stamp, mean, cov)
        self._publish_tf(stamp)

    # -- outputs --------------------------------------------------------------------------
    def _publish_pose(self, stamp, mean, cov):
        msg = PoseWithCovarianceStamped()
        msg.header.stamp = stamp
        msg.header.frame_id = self.global_frame
        msg.pose.pose = pose_msg(*mean)
        msg.pose.covariance = mcl.covariance_6x6(cov)
        self.pose_pub.publish(msg)
        if self.cloud_pub.get_num_connections() == 0:
            return
        if stamp - self.last_cloud >= self.cloud_period or stamp < self.last_cloud:
            self.last_cloud = stamp
            cloud = PoseArray()
            cloud.header = msg.header
            cloud.poses = [pose_msg(*p) for p in self.localizer.poses]
            self.cloud_pub.publish(cloud)

    def _publish_tf(self, stamp):
        if not self.tf_broadcast or self.map_to_odom is None:
            return
        x, y, yaw = self.map_to_odom
        t = TransformStamped()
        t.header.stamp = stamp + self.tf_tolerance
        t.header.frame_id = self.global_frame
        t.child_frame_id = self.odom_frame
        t.transform.translation.x, t.transform.translation.y = x, y
        q = quaternion_from_yaw(yaw)
        r = t.transform.rotation
        r.x, r.y, r.z, r.w = q
        self.tf_broadcaster.sendTransform(t)


def main():
    rospy.init_node("amcl")
    MclLocalizerNode()
    rospy.spin()
