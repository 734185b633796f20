"""Node ``target_follower``: follows the detector's target (thesis 2.4, 5.3).

Subscribes ``target`` (target_follower/Target, the detector's frames), ``scan``
(sensor_msgs/LaserScan; its mount from TF ``~base_frame`` -> the scan's frame) and ``odom``
(nav_msgs/Odometry, the base's pose). Publishes ``cmd_vel`` (geometry_msgs/Twist; launch
files remap it, e.g. to ``follower/cmd_vel`` in front of a mux), ``~state``
(std_msgs/String, latched, on change: following / searching / lost / blocked / stale /
disabled), ``~followed`` (geometry_msgs/PointStamped, the tracked target predicted to now,
in the odometry frame), ``~trail`` (nav_msgs/Path, the target's trail the robot steers
along, odometry frame, while subscribed) and ``~camera_latency`` (std_msgs/Float64 [s], the
camera latency subtracted from the frames' stamps: target_follower.latency) with
``~camera_latency_std`` (std_msgs/Float64 [s], its evidence's standard error; inf before
any). Service
``~enable`` (std_srvs/SetBool; ``~start_enabled``).

Callbacks only store the newest input; a timer at ``~rate_hz`` runs the tracker
(target_follower.tracker: which detection is the followed target, in odom), the safety
sector and the control law (target_follower.follower) and publishes. Commands: every cycle
while following, searching, blocked or stale (zero when the target or the scan is stale);
one zero when the robot stops (lost) or is disabled, then nothing, so that cmd_vel is free
for others. Parameters: ``target_follower.following.TargetFollowerParams`` (package README).
"""
import functools
import threading

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PointStamped, PoseStamped, Twist
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64, String
from std_srvs.srv import SetBool, SetBoolResponse

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import yaw_of
from ascc_navigation.mapper import ScanInput, check_scan
from ascc_navigation.ros.laser_tf import mount_from_tf
from target_follower.follower import (
    ACTIVE_STATES,
    DISABLED,
    LOST,
    Follower,
    SafetySector,
)
from target_follower.following import OdomHistory, TargetFollowerParams, observation_from_detection
from target_follower.latency import LatencyEstimator
from target_follower.msg import Target
from target_follower.tracker import Tracker
from target_follower.trail import Trail

WARN_PERIOD_S = 5.0  # throttle period of repeated warnings [s]


class TargetFollowerNode:
    def __init__(self):
        p = from_params(TargetFollowerParams, rospy.get_param, "~")
        self.p = p
        self.period = 1.0 / p.rate_hz  # [s]
        self.follower = Follower(p.follower)
        self.tracker = Tracker(p.tracker)
        self.trail = Trail(p.trail)
        self.trail_track_id = None
        self.odom = OdomHistory(p.odom_keep_s())
        self.latency = LatencyEstimator(p.latency)
        self.lock = threading.Lock()
        self.enabled = p.start_enabled
        self.target_msg = None  # newest Target, not yet given to the tracker
        self.target_stamp = None  # [s] of the newest Target message
        self.scan_msg = None  # newest scan, not yet checked
        self.scan_stamp = None  # [s] of the newest usable scan
        # the safety sector on the newest usable scan: (curvature, length) -> (blocked, why)
        self.path_check = lambda _k, _d: (True, "no scan yet")
        self.sectors = {}  # (frame, beams, angle_min, increment) -> SafetySector
        self.odom_frame = "odom"
        self.state = None
        self.last_now = None

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.state_pub = rospy.Publisher("~state", String, queue_size=1, latch=True)
        self.point_pub = rospy.Publisher("~followed", PointStamped, queue_size=1)
        self.trail_pub = rospy.Publisher("~trail", Path, queue_size=1)
        self.latency_pub = rospy.Publisher("~camera_latency", Float64, queue_size=1)
        self.latency_std_pub = rospy.Publisher("~camera_latency_std", Float64, queue_size=1)
        rospy.Subscriber("target", Target, self.on_target, queue_size=1)
        rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1)
        rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=10)
        rospy.Service("~enable", SetBool, self.on_enable)
        if not self.enabled:
            self._set_state(DISABLED, "~start_enabled is false")
        # PacedTimer, not rospy.Timer: it wakes once per period, not on every /clock message
        # of a simulator, and stops when the shutdown starts (ascc_common.paced_timer)
        self.timer = PacedTimer(self.period, self.on_timer, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="control")
        rospy.on_shutdown(self.stop_robot)

    # -- callbacks: store the newest input -----------------------------------------------
    def on_target(self, msg):
        with self.lock:
            self.target_msg = (msg, rospy.Time.now())

    def on_scan(self, msg):
        with self.lock:
            self.scan_msg = msg

    def on_odom(self, msg):
        p = msg.pose.pose
        pose = (p.position.x, p.position.y, yaw_of(p.orientation))
        if not np.all(np.isfinite(pose)):
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: odometry pose with "
                                   "NaN/inf %s ignored" % (pose,))
            return
        with self.lock:
            self.odom.add(msg.header.stamp.to_sec(), pose)
            self.odom_frame = msg.header.frame_id or self.odom_frame

    def on_enable(self, req):
        with self.lock:
            if req.data and not self.enabled:
                self._reset()
            elif not req.data and self.enabled:
                self._send(0.0, 0.0)  # under the lock: no command of the timer after it
                self._set_state(DISABLED, "~enable false")
            self.enabled = bool(req.data)
        return SetBoolResponse(True, "enabled" if req.data else "disabled")

    # -- the control loop ----------------------------------------------------------------
    def on_timer(self):
        with self.lock:
            now = rospy.Time.now()
            dt = self._dt(now)
            if not self.enabled:
                return
            t = now.to_sec()
            self._take_target()
            self._take_scan(now)
            pose = self.odom.newest() or (0.0, 0.0, 0.0)
            aim = self._aim(t, pose)
            cmd = self.follower.step(t, dt, self.target_stamp, aim, self.scan_stamp,
                                     self.path_check)
            if cmd.state in ACTIVE_STATES or cmd.state != self.state:
                self._send(cmd.v, cmd.w)
            self._set_state(cmd.state, cmd.reason)
            if cmd.state == LOST:
                self.trail.clear()
            elif self.trail.note_blocked(t, cmd.blocked):
                rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: held by the safety "
                                       "stop for %.1f s on the target's trail (%s): trail "
                                       "dropped, facing the target"
                                       % (self.p.trail.trail_blocked_s, cmd.reason))
            if self.tracker.track is not None:
                self._publish_point(now, self.tracker.track.predicted(t))
            if self.trail_pub.get_num_connections() > 0:
                self._publish_trail(now)

    def _aim(self, t, pose):
        """The tracked target predicted to ``t``, steered along its trail (trail.py)."""
        aim = self.tracker.aim(t, pose)
        track = self.tracker.track
        if aim is None:  # lost from view: along the trail to where it was last seen
            return self.trail.search_aim(pose, self.p.follower.distance_m)
        if track is None or not track.has_position:
            return aim
        fp = self.p.follower
        return self.trail.aim(pose, track.predicted(t), aim,
                              fp.distance_m + fp.distance_tolerance_m, tuple(track.vel))

    def _dt(self, now):
        if self.last_now is not None and now < self.last_now:
            rospy.logwarn("target_follower: time went back by %.2f s (bag loop or restarted "
                          "clock); forgetting the target, odometry and TF"
                          % (self.last_now - now).to_sec())
            self.tf_buffer.clear()
            self._reset()
        dt = self.period if self.last_now is None else (now - self.last_now).to_sec()
        self.last_now = now
        return float(np.clip(dt, 0.0, 2.0 * self.period))

    def _reset(self):
        self.follower.reset()
        self.tracker.reset()
        self.trail.clear()
        self.latency.reset_track()
        self.odom.clear()
        self.target_msg = None
        self.target_stamp = self.scan_stamp = None
        self.sectors.clear()
        self.state = None

    def _take_target(self):
        """Give the newest Target message to the tracker (bad ones warned and dropped)."""
        if self.target_msg is None:
            return
        (msg, received), self.target_msg = self.target_msg, None
        frame = msg.header.frame_id
        if frame and frame.lstrip("/") != self.p.base_frame:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: Target in frame '%s', "
                                   "expected '%s'; ignored" % (frame, self.p.base_frame))
            return
        stamp = msg.header.stamp
        if stamp.is_zero():
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: Target without a "
                                   "stamp; taking its arrival time")
            stamp = received
        observations = []
        for d in msg.detections:
            obs, problem = observation_from_detection(d)
            if obs is None:
                rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: bad detection "
                                       "ignored: %s" % problem)
            else:
                observations.append(obs)
        t = stamp.to_sec()
        taken = t - self.latency.latency_s  # when the frame was exposed (latency.py)
        pose = self.odom.pose_at(taken)
        if pose is None:
            rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: no odometry on %s yet; "
                                   "tracking as if the robot stood still"
                                   % rospy.resolve_name("odom"))
            pose = (0.0, 0.0, 0.0)
        track = self.tracker.update(taken, pose, observations)
        if track is not None and track.has_position and track.t_s == taken:  # seen now
            if track.id != self.trail_track_id:  # a new track: joins the trail or not
                self.trail.restart(track.seen)
                self.trail_track_id = track.id
                self.latency.reset_track()
            else:
                self.trail.add(track.seen, track.innovation_m)
            self.latency.add(t, track.seen_base, self.odom.stamps, self.odom.poses)
            self.latency_pub.publish(Float64(data=self.latency.latency_s))
            self.latency_std_pub.publish(Float64(data=self.latency.latency_std_s))
        self.target_stamp = t if self.target_stamp is None else max(self.target_stamp, t)

    def _take_scan(self, now):
        """Check the newest scan against the safety sector; an unusable one is warned about
        and not counted as fresh (so the robot stops when no usable scan is recent)."""
        msg, self.scan_msg = self.scan_msg, None
        if msg is None:
            return
        scan = ScanInput(msg.header.stamp.to_sec(), msg.ranges, msg.angle_min,
                         msg.angle_increment, msg.range_min, msg.range_max)
        problem = check_scan(scan)
        sector = None if problem else self._sector(msg)
        if sector is None:
            if problem:
                rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: scan unusable: %s"
                                       % problem)
            return
        self.path_check = functools.partial(sector.check, np.asarray(scan.ranges, float),
                                            scan.range_min, scan.range_max)
        self.scan_stamp = scan.stamp

    def _sector(self, msg):
        """The safety sector of this scan's layout and mount (cached), None if the mount is
        unknown (warned)."""
        key = (msg.header.frame_id, len(msg.ranges), msg.angle_min, msg.angle_increment)
        if key not in self.sectors:
            try:
                mount = mount_from_tf(self.tf_buffer, self.p.base_frame,
                                      msg.header.frame_id)
            except (tf2_ros.TransformException, ValueError) as e:
                rospy.logwarn_throttle(WARN_PERIOD_S, "target_follower: scan frame '%s' "
                                       "unusable: %s" % (msg.header.frame_id, e))
                return None
            angles = mount.beam_angles(len(msg.ranges), msg.angle_min, msg.angle_increment)
            self.sectors[key] = SafetySector(self.p.follower, angles, (mount.x, mount.y))
        return self.sectors[key]

    # -- outputs --------------------------------------------------------------------------
    def _set_state(self, state, reason):
        if state != self.state:
            rospy.loginfo("target_follower: %s%s", state, " (%s)" % reason if reason else "")
            self.state_pub.publish(String(data=state))
            self.state = state

    def _publish_point(self, now, xy):
        msg = PointStamped()
        msg.header.stamp = now
        msg.header.frame_id = self.odom_frame if self.odom.newest() else self.p.base_frame
        msg.point.x, msg.point.y = float(xy[0]), float(xy[1])
        self.point_pub.publish(msg)

    def _publish_trail(self, now):
        msg = Path()
        msg.header.stamp = now
        msg.header.frame_id = self.odom_frame
        for x, y in self.trail.points:
            ps = PoseStamped()
            ps.header = msg.header
            ps.pose.position.x, ps.pose.position.y = x, y
            ps.pose.orientation.w = 1.0
            msg.poses.append(ps)
        self.trail_pub.publish(msg)

    def _send(self, v, w):
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = v, w
        self.cmd_pub.publish(cmd)

    def stop_robot(self):
        with self.lock:  # after a control step under way: its command goes out first
            self._send(0.0, 0.0)


def main():
    rospy.init_node("target_follower")
    TargetFollowerNode()
    rospy.spin()
