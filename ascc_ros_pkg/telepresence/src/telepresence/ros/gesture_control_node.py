"""Node ``gesture_control``: moves the robot on a recognized gesture
(telepresence.gesture_control).

Subscribes ``gesture`` (telepresence/Gesture, from gesture_recognizer), ``scan``
(sensor_msgs/LaserScan; its mount from TF ``~base_frame`` -> the scan's frame) and
``odom`` (nav_msgs/Odometry). Publishes ``cmd_vel`` (geometry_msgs/Twist; launch files
remap it to ``gesture/cmd_vel`` in front of the velocity mux, where it outranks the
operator) while a motion runs, one zero when it ends, then nothing (the mux hands the
base back), and ``~state`` (std_msgs/String, latched: idle, coming, backing).
Parameters: ``GestureControlNodeParams`` (package README).

Callbacks store the newest input; a timer at ``~rate_hz`` runs the controller. Bad input:
a gesture with an unknown command or older than ``~max_gesture_age_s`` is ignored with a
warning; an unusable scan or an unknown laser mount is warned about and does not count as
fresh (come_close then stops: it never drives without measuring); odometry with NaN is
ignored (go_away then stops).
"""
import math
import threading
from dataclasses import dataclass

import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import ParamError, from_params, nested, param
from ascc_common.throttle import Throttle
from ascc_navigation.mapper import ScanInput, check_scan
from ascc_navigation.ros.laser_tf import mount_from_tf
from telepresence.gesture_control import (
    IDLE,
    GestureController,
    GestureControlParams,
    distance_ahead,
)
from telepresence.msg import Gesture

WARN_PERIOD_S = 5.0  # throttle period of repeated warnings, per kind [s]


@dataclass
class GestureControlNodeParams:
    base_frame: str = param("base_link", "the robot's frame (the laser mount is looked up "
                            "from it)")
    max_gesture_age_s: float = param(1.0, "a gesture stamped longer ago is ignored [s]",
                                     gt=0.0)
    control: GestureControlParams = nested(GestureControlParams)


class GestureControlNode:
    def __init__(self):
        self.p = from_params(GestureControlNodeParams, rospy.get_param, "~")
        self.ctl = GestureController(self.p.control)
        self.lock = threading.Lock()
        self.throttle = Throttle(WARN_PERIOD_S)
        self.gesture = None
        self.scan_msg = None
        self.ahead = self.scan_t = None
        self.odom_xy = self.odom_t = None
        self.mounts = {}
        self.state = None
        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.state_pub = rospy.Publisher("~state", String, queue_size=1, latch=True)
        self._set_state(IDLE, "started")
        rospy.Subscriber("gesture", Gesture, self.on_gesture, queue_size=5)
        rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1)
        rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=5)
        # PacedTimer: wakes once per period, not on every /clock message of a simulator,
        # and stops when the shutdown starts (ascc_common.paced_timer)
        self.timer = PacedTimer(1.0 / self.p.control.rate_hz, self.on_timer, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="control")
        rospy.on_shutdown(self.on_shutdown)

    def on_gesture(self, msg):
        with self.lock:
            self.gesture = msg

    def on_scan(self, msg):
        with self.lock:
            self.scan_msg = msg

    def on_odom(self, msg):
        p = msg.pose.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self._warn("odom", "odometry with NaN/inf position ignored")
            return
        with self.lock:
            self.odom_xy, self.odom_t = (p.x, p.y), msg.header.stamp.to_sec()

    def on_timer(self):
        with self.lock:
            now = rospy.get_time()
            self._take_gesture(now)
            self._take_scan()
            cmd = self.ctl.step(now, self.ahead, self.scan_t, self.odom_xy, self.odom_t)
            if cmd.ended is not None or cmd.state != IDLE:
                self._send(cmd.v)
            self._set_state(cmd.state, cmd.ended)

    def _take_gesture(self, now):
        msg, self.gesture = self.gesture, None
        if msg is None:
            return
        age = now - msg.header.stamp.to_sec()
        if age > self.p.max_gesture_age_s:
            self._warn("old", "gesture '%s' stamped %.2f s ago (> ~max_gesture_age_s %.2f); "
                       "ignored" % (msg.command, age, self.p.max_gesture_age_s))
            return
        try:
            self.ctl.on_gesture(msg.command, now)
        except ValueError as err:
            self._warn("command", "%s; ignored" % err)
            return
        rospy.loginfo("gesture_control: %s (match error %.4f rad^2, user %d)", msg.command,
                      msg.error_rad2, msg.user)

    def _take_scan(self):
        msg, self.scan_msg = self.scan_msg, None
        if msg is None:
            return
        scan = ScanInput(msg.header.stamp.to_sec(), msg.ranges, msg.angle_min,
                         msg.angle_increment, msg.range_min, msg.range_max)
        problem = check_scan(scan)
        if problem:
            self._warn("scan", "scan unusable: %s" % problem)
            return
        mount = self._mount(msg.header.frame_id)
        if mount is None:
            return
        angles = mount.beam_angles(len(scan.ranges), scan.angle_min, scan.angle_increment)
        self.ahead = distance_ahead(scan.ranges, angles, (mount.x, mount.y), scan.range_min,
                                    scan.range_max, self.p.control.path_half_width_m)
        self.scan_t = scan.stamp

    def _mount(self, frame):
        if frame not in self.mounts:
            try:
                self.mounts[frame] = mount_from_tf(self.tf_buffer, self.p.base_frame, frame)
            except (tf2_ros.TransformException, ValueError) as err:
                self._warn("mount", "scan frame '%s' unusable: %s" % (frame, err))
                return None
        return self.mounts[frame]

    def _set_state(self, state, reason):
        if state != self.state:
            rospy.loginfo("gesture_control: %s%s", state, " (%s)" % reason if reason else "")
            self.state_pub.publish(String(data=state))
            self.state = state

    def _send(self, v):
        cmd = Twist()
        cmd.linear.x = v
        self.cmd_pub.publish(cmd)

    def _warn(self, kind, text):
        if self.throttle.ready(kind, rospy.get_time()):
            rospy.logwarn("gesture_control: %s", text)

    def on_shutdown(self):
        with self.lock:  # after a control step under way: its command goes out first
            if self.ctl.state != IDLE:
                self._send(0.0)


def main():
    rospy.init_node("gesture_control")
    try:
        GestureControlNode()
    except ParamError as err:
        rospy.logfatal("gesture_control: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
