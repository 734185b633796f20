#!/usr/bin/env python3
"""rostest: the gesture_control node on real topics, the test playing the robot
(gesture_control.test). The node runs with its defaults (GestureControlParams)."""
import math
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import Latest, wait_for
from telepresence.gesture_control import GestureControlParams
from telepresence.msg import Gesture

NODE = "/gesture_control"
P = GestureControlParams()
MOUNT_X = 0.05  # base_link -> laser [m]
BEAMS = np.linspace(-2.0, 2.0, 401)


class FakeRobot:
    """At 20 Hz: integrates the newest cmd_vel into x (1D, facing +x), publishes odometry
    and a scan of a wall at ``wall_x`` (while ``send_scan``)."""

    def __init__(self):
        self.x, self.v, self.wall_x = 0.0, 0.0, 2.5
        self.send_scan, self.nan_odom = True, False
        self.odom_pub = rospy.Publisher("odom", Odometry, queue_size=5)
        self.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=5)
        rospy.Subscriber("cmd_vel", Twist, self.on_cmd, queue_size=5)
        tf = TransformStamped()
        tf.header.stamp = rospy.Time.now()
        tf.header.frame_id, tf.child_frame_id = "base_link", "laser"
        tf.transform.translation.x, tf.transform.rotation.w = MOUNT_X, 1.0
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self.static_tf.sendTransform(tf)
        threading.Thread(target=self.run, daemon=True).start()

    def on_cmd(self, msg):
        self.v = msg.linear.x

    def run(self):
        dt = 0.05
        # is_shutdown_requested: true from the start of the shutdown, whose hooks close the
        # publishers while rospy.is_shutdown() is still false
        while not rospy.core.is_shutdown_requested():
            self.x += self.v * dt
            now = rospy.Time.now()
            odom = Odometry()
            odom.header.stamp, odom.header.frame_id = now, "odom"
            odom.pose.pose.position.x = float("nan") if self.nan_odom else self.x
            odom.pose.pose.orientation.w = 1.0
            self.odom_pub.publish(odom)
            if self.send_scan:
                scan = LaserScan()
                scan.header.stamp, scan.header.frame_id = now, "laser"
                scan.angle_min, scan.angle_increment = float(BEAMS[0]), float(BEAMS[1] - BEAMS[0])
                scan.range_min, scan.range_max = 0.02, 5.6
                d = self.wall_x - self.x - MOUNT_X
                with np.errstate(divide="ignore"):
                    r = np.where(np.cos(BEAMS) > 0.05, d / np.cos(BEAMS), np.inf)
                scan.ranges = np.minimum(r, 5.6).tolist()
                self.scan_pub.publish(scan)
            time.sleep(dt)


class GestureControlTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rostest_gesture_control")
        cls.rosout = RosoutWatcher()
        cls.robot = FakeRobot()
        cls.cmds = Latest("cmd_vel", Twist, keep_all=True)
        cls.state = Latest(NODE + "/state", String)
        cls.gesture_pub = rospy.Publisher("gesture", Gesture, queue_size=5)
        cls.state.wait(30.0)
        wait_for(lambda: cls.gesture_pub.get_num_connections() > 0, 30.0,
                 "gesture_control subscribed to gesture")
        time.sleep(0.5)  # a few scans and odometry messages in

    def send(self, command, age_s=0.0):
        g = Gesture(command=command, error_rad2=0.03, threshold_rad2=0.08, time_scale=1.0,
                    user=1)
        g.header.stamp = rospy.Time.now() - rospy.Duration(age_s)
        g.header.frame_id = "openni_depth_frame"
        self.gesture_pub.publish(g)

    def wait_state(self, state, timeout_s):
        wait_for(lambda: self.state.msg.data == state, timeout_s, "state %s (is %s)"
                 % (state, self.state.msg.data))

    def assert_quiet(self, seconds=1.0):
        n = self.cmds.count
        time.sleep(seconds)
        self.assertEqual(self.cmds.count, n, "cmd_vel while idle")

    def test_1_come_close_stops_at_the_stop_distance(self):
        self.robot.x, self.robot.wall_x = 0.0, 2.5
        n = self.cmds.count
        self.send("come_close")
        self.wait_state("coming", 5.0)
        self.wait_state("idle", 30.0)
        # the node sends the zero, then the state; they come on two connections, so the
        # state can arrive first (a CI run read 0.05 as the last command)
        wait_for(lambda: self.cmds.count > n and self.cmds.all[-1].linear.x == 0.0, 2.0,
                 "the zero command after the approach")
        speeds = [c.linear.x for c in self.cmds.all[n:]]
        self.assertEqual(speeds[-1], 0.0)  # one zero at the end
        self.assertTrue(all(0.0 < v <= P.approach_speed_mps + 1e-9 for v in speeds[:-1]))
        ahead = self.robot.wall_x - self.robot.x
        self.assertGreater(ahead, P.stop_distance_m - 0.05)
        self.assertLess(ahead, P.stop_distance_m + 0.05)
        self.assert_quiet()

    def test_2_go_away_backs_off_its_distance(self):
        x0 = self.robot.x
        n = self.cmds.count
        self.send("go_away")
        self.wait_state("backing", 5.0)
        self.wait_state("idle", 20.0)
        speeds = [c.linear.x for c in self.cmds.all[n:]]
        self.assertEqual(set(speeds[:-1]), {-P.backoff_speed_mps})
        self.assertEqual(speeds[-1], 0.0)
        self.assertAlmostEqual(x0 - self.robot.x, P.backoff_distance_m, delta=0.05)
        self.assert_quiet()

    def test_3_a_stale_scan_stops_the_approach(self):
        self.robot.x, self.robot.wall_x = 0.0, 4.0
        self.send("come_close")
        self.wait_state("coming", 5.0)
        self.robot.send_scan = False
        try:
            self.wait_state("idle", 5.0)
            wait_for(lambda: self.cmds.msg.linear.x == 0.0, 2.0, "a zero command")
            self.assert_quiet()
        finally:
            self.robot.send_scan = True

    def test_4_bad_gestures_and_odometry_warned_nothing_moves(self):
        start = time.monotonic()
        n = self.cmds.count
        self.send("dance")
        self.rosout.wait_for(5.0, "unknown command", node=NODE, level="warn",
                             contains=("dance",), since_wall_s=start)
        self.send("come_close", age_s=5.0)
        self.rosout.wait_for(5.0, "old gesture", node=NODE, level="warn",
                             contains=("come_close", "ago", "ignored"), since_wall_s=start)
        self.assertEqual(self.cmds.count, n)
        self.assertEqual(self.state.msg.data, "idle")
        self.robot.nan_odom = True
        try:
            self.rosout.wait_for(5.0, "NaN odometry", node=NODE, level="warn",
                                 contains=("nan",), since_wall_s=start)
            x0 = self.robot.x
            self.send("go_away")  # the last odometry goes stale: it stops within its timeout
            wait_for(lambda: self.cmds.count > n and self.cmds.msg.linear.x == 0.0, 5.0,
                     "go away ended (a zero command)")
            self.wait_state("idle", 2.0)
            moved = x0 - self.robot.x
            self.assertLess(moved, P.backoff_speed_mps * (P.odom_timeout_s + 0.2))
            self.assertLess(moved, P.backoff_distance_m / 2)
        finally:
            self.robot.nan_odom = False
        self.assertTrue(math.isfinite(self.robot.x))


if __name__ == "__main__":
    rostest.rosrun("telepresence", "gesture_control_node", GestureControlTest, sys.argv)
