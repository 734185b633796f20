#!/usr/bin/env python3
"""rostest: three robots in one simulator, each with its driver in its own namespace:
namespaced topics and frames, commands reach only their robot, robots see each other."""
import math
import sys
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from ascc_common.pose2d import compose, wrap_angle, yaw_of
from ascc_testing.waits import Latest, pose_of, wait_for
from irobot_create_2_1.msg import SensorPacket

ROBOTS = ("robotA", "robotB", "robotC")
ROBOT_RADIUS_M = 0.165


class ThreeRobotsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("three_robots_test")
        cls.scan = {r: Latest(r + "/scan", LaserScan) for r in ROBOTS}
        cls.odom = {r: Latest(r + "/odom", Odometry) for r in ROBOTS}
        cls.packet = {r: Latest(r + "/sensorPacket", SensorPacket) for r in ROBOTS}
        cls.truth = {r: Latest("ground_truth/%s/odom" % r, Odometry) for r in ROBOTS}
        cls.cmd = {r: rospy.Publisher(r + "/cmd_vel", Twist, queue_size=1) for r in ROBOTS}
        cls.tf = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.tf)

    def wait_all(self):
        for r in ROBOTS:
            for sub in (self.scan[r], self.odom[r], self.packet[r], self.truth[r]):
                sub.wait(120.0)

    def test_1_namespaces_and_frames(self):
        self.wait_all()
        for r in ROBOTS:
            self.assertEqual(self.scan[r].msg.header.frame_id, r + "/laser")
            self.assertEqual(self.odom[r].msg.header.frame_id, r + "/odom")
            self.assertEqual(self.odom[r].msg.child_frame_id, r + "/base_link")
            self.assertEqual(self.packet[r].msg.header.frame_id, r + "/base_link")
            self.assertEqual(self.truth[r].msg.header.frame_id, "map")
            for parent, child in (("/odom", "/base_link"), ("/base_link", "/laser")):
                wait_for(lambda p=r + parent, c=r + child: self.tf.can_transform(
                    p, c, rospy.Time(0)), 30.0, "TF %s -> %s" % (r + parent, r + child))
            # sim.launch's map_to_odom defaults to false: the simulator's static TF (the
            # laser mounts, in hand) carries no map -> <ns>/odom.
            self.assertFalse(self.tf.can_transform("map", r + "/odom", rospy.Time(0)),
                             "map -> %s/odom published with map_to_odom false" % r)
        published = {name for name, _ in rospy.get_published_topics()}
        for topic in ("/scan", "/odom", "/sensorPacket"):
            self.assertNotIn(topic, published)
            for r in ROBOTS:
                self.assertIn("/" + r + topic, published)

    def test_2_commands_reach_only_their_robot(self):
        self.wait_all()
        wait_for(lambda: all(p.get_num_connections() > 0 for p in self.cmd.values()), 30.0,
                 "the three drivers on cmd_vel")
        truth0 = {r: pose_of(self.truth[r].msg) for r in ROBOTS}
        odom0 = {r: pose_of(self.odom[r].msg) for r in ROBOTS}
        rate = rospy.Rate(20.0)
        t_end = rospy.get_time() + 2.0
        move = Twist()
        move.linear.x = 0.2
        while rospy.get_time() < t_end:
            self.cmd["robotB"].publish(move)
            self.cmd["robotA"].publish(Twist())
            rate.sleep()
        stop_t = rospy.get_time()
        wait_for(lambda: rospy.get_time() > stop_t + 0.5, 30.0, "0.5 s of simulated time")
        for r in ROBOTS:
            moved = math.dist(truth0[r][:2], pose_of(self.truth[r].msg)[:2])
            odom_moved = math.dist(odom0[r][:2], pose_of(self.odom[r].msg)[:2])
            if r == "robotB":
                self.assertGreater(moved, 0.3)
                self.assertAlmostEqual(odom_moved, moved, delta=0.03)
                # ... along its own heading in the map.
                heading = math.atan2(pose_of(self.truth[r].msg)[1] - truth0[r][1],
                                     pose_of(self.truth[r].msg)[0] - truth0[r][0])
                self.assertLess(abs(wrap_angle(heading - truth0[r][2])), 0.05)
            else:
                self.assertEqual(moved, 0.0, r)
                self.assertEqual(odom_moved, 0.0, r)

    def test_3_robots_see_each_other(self):
        self.wait_all()
        for _ in range(3):  # a few scans: the far return may drop out once
            self.scan["robotA"].wait(60.0, count=self.scan["robotA"].count + 1)
            scan = self.scan["robotA"].msg
            mount = self.tf.lookup_transform("robotA/base_link", "robotA/laser",
                                             rospy.Time(0)).transform
            laser = compose(pose_of(self.truth["robotA"].msg),
                            (mount.translation.x, mount.translation.y,
                             yaw_of(mount.rotation)))
            bx, by, _ = pose_of(self.truth["robotB"].msg)
            bearing = wrap_angle(math.atan2(by - laser[1], bx - laser[0]) - laser[2])
            k = int(round((bearing - scan.angle_min) / scan.angle_increment))
            dist = math.hypot(bx - laser[0], by - laser[1])
            got = np.array(scan.ranges[k - 1:k + 2])
            beam_err = abs(bearing - (scan.angle_min + k * scan.angle_increment))
            expected = dist * math.cos(beam_err) - ROBOT_RADIUS_M  # close to the centre line
            if np.any(np.isfinite(got)):
                break
        self.assertTrue(np.any(np.abs(got - expected) <= 0.03 * expected + 0.01),
                        "robotA sees %s at bearing %.3f, expected robotB at %.3f m"
                        % (got, bearing, expected))


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "three_robots", ThreeRobotsTest, sys.argv)
