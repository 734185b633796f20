#!/usr/bin/env python3
"""rostest: drive into a wall through cmd_vel; the robot must stop at the wall (ground
truth), the bump bits in sensorPacket must go up, and pushing on must not move it."""
import math
import sys
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from ascc_testing.waits import Latest, pose_of, wait_for
from irobot_create_2_1.msg import SensorPacket

ROBOT_RADIUS_M = 0.165


class BumpTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("bump_test")
        robot = rospy.get_param("~robot", "asccbot")
        cls.wall_y = float(rospy.get_param("~wall_face_y_m"))
        cls.packet = Latest("sensorPacket", SensorPacket, keep_all=True)
        cls.odom = Latest("odom", Odometry)
        cls.truth = Latest("ground_truth/%s/odom" % robot, Odometry)
        cls.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)

    def forward(self, until, timeout_s=60.0, v=0.2):
        rate = rospy.Rate(20.0)  # simulated time
        deadline = rospy.get_time() + timeout_s
        t = Twist()
        t.linear.x = v
        while not until():
            self.assertLess(rospy.get_time(), deadline, "timed out driving forward")
            self.cmd.publish(t)
            rate.sleep()

    def test_bump(self):
        self.packet.wait(90.0)
        self.truth.wait(30.0)
        wait_for(lambda: self.cmd.get_num_connections() > 0, 30.0, "the driver on cmd_vel")
        self.assertFalse(self.packet.msg.bumpLeft or self.packet.msg.bumpRight)
        y_start = pose_of(self.truth.msg)[1]
        self.forward(lambda: self.packet.msg.bumpLeft and self.packet.msg.bumpRight)
        # Head-on: both switches, and the robot stands at the wall, not in it: read at a
        # ground-truth message from after the bump was seen (the newest one can be a
        # period older, 2 cm before the wall at 0.2 m/s)
        bumped = rospy.Time.from_sec(rospy.get_time())
        wait_for(lambda: self.truth.msg.header.stamp >= bumped, 10.0,
                 "ground truth after the bump")
        y_hit = pose_of(self.truth.msg)[1]
        self.assertGreater(y_start - y_hit, 0.8)
        self.assertGreaterEqual(y_hit, self.wall_y + ROBOT_RADIUS_M - 1e-3)
        self.assertLess(y_hit, self.wall_y + ROBOT_RADIUS_M + 0.02)
        # Keep commanding forward: after the last odometry packet in flight has arrived
        # (0.5 s), 2 s more of pushing must not move the robot nor its odometry.
        t_settle = rospy.get_time() + 0.5
        self.forward(lambda: rospy.get_time() > t_settle)
        y_settled = pose_of(self.truth.msg)[1]  # touching: within 2 mm of the wall
        self.assertGreaterEqual(y_settled, self.wall_y + ROBOT_RADIUS_M - 1e-6)
        self.assertLess(y_settled, self.wall_y + ROBOT_RADIUS_M + 2e-3)
        odom_x = pose_of(self.odom.msg)[0]  # odom x: forward from the start
        t_end = rospy.get_time() + 2.0
        self.forward(lambda: rospy.get_time() > t_end)
        y_after = pose_of(self.truth.msg)[1]
        self.assertAlmostEqual(y_after, y_settled, delta=1e-6)
        self.assertGreaterEqual(y_after, self.wall_y + ROBOT_RADIUS_M - 1e-3)
        self.assertLess(abs(self.truth.msg.twist.twist.linear.x), 1e-3)
        self.assertAlmostEqual(pose_of(self.odom.msg)[0], odom_x, delta=1e-6)
        self.assertTrue(self.packet.msg.bumpLeft and self.packet.msg.bumpRight)
        # Backing off releases the bumper.
        self.forward(lambda: not (self.packet.msg.bumpLeft or self.packet.msg.bumpRight),
                     v=-0.1)
        self.assertGreater(pose_of(self.truth.msg)[1], y_after + 1e-3)
        stamps = [p.header.stamp.to_sec() for p in self.packet.all if p.bumpLeft]
        rospy.loginfo("bump: stopped at y %.4f (wall face %.3f + radius), bumped for %.2f s",
                      y_hit, self.wall_y, max(stamps) - min(stamps))
        self.assertFalse(math.isnan(y_hit))


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "bump", BumpTest, sys.argv)
