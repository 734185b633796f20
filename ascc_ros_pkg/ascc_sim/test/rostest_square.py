#!/usr/bin/env python3
"""rostest: drive a 1 m square through cmd_vel (closed loop on the driver's odom) in the
office world; the driver's odometry must end where the ground truth says, within the
odometry noise the simulator is configured with."""
import math
import sys
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry

from ascc_testing.waits import Latest, compose, pose_of, wait_for, wrap

WHEEL_BASE_M = 0.258


class SquareTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("square_test")
        robot = rospy.get_param("~robot", "asccbot")
        cls.side_m = float(rospy.get_param("~side_m", 1.0))
        cls.odom = Latest("odom", Odometry, keep_all=True)
        cls.truth = Latest("ground_truth/%s/odom" % robot, Odometry, keep_all=True)
        cls.start = Latest("ground_truth/%s/start_pose" % robot, PoseStamped)
        cls.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        cls.scale_sigma = float(rospy.get_param("/simulator/robot/encoder_scale_sigma"))
        cls.noise_k = float(rospy.get_param("/simulator/robot/encoder_noise_m_per_sqrt_m"))

    def drive(self, condition, v, w, timeout_s=120.0):
        rate = rospy.Rate(20.0)  # simulated time
        deadline = rospy.get_time() + timeout_s
        while not condition():
            self.assertLess(rospy.get_time(), deadline, "manoeuvre did not finish")
            t = Twist()
            t.linear.x, t.angular.z = v, w
            self.cmd.publish(t)
            rate.sleep()

    def travelled(self, x0, y0):
        x, y, _ = pose_of(self.odom.msg)
        return math.hypot(x - x0, y - y0)

    def turned(self, yaw0):
        return wrap(pose_of(self.odom.msg)[2] - yaw0)

    def test_square(self):
        self.odom.wait(90.0)
        self.start.wait(30.0)
        start = pose_of(self.start.msg)
        wait_for(lambda: self.cmd.get_num_connections() > 0, 30.0, "the driver on cmd_vel")
        sides = []
        for _ in range(4):
            x0, y0, _ = pose_of(self.odom.msg)
            gx0, gy0, _ = pose_of(self.truth.msg)
            self.drive(lambda a=x0, b=y0: self.travelled(a, b) >= self.side_m - 0.1, 0.2, 0.0)
            self.drive(lambda a=x0, b=y0: self.travelled(a, b) >= self.side_m, 0.05, 0.0)
            gx1, gy1, _ = pose_of(self.truth.msg)
            sides.append((self.travelled(x0, y0), math.hypot(gx1 - gx0, gy1 - gy0)))
            yaw0 = pose_of(self.odom.msg)[2]
            self.drive(lambda a=yaw0: self.turned(a) >= math.pi / 2 - 0.2, 0.0, 0.5)
            self.drive(lambda a=yaw0: self.turned(a) >= math.pi / 2 - 0.005, 0.0, 0.1)  # slow
        self.drive(lambda: True, 0.0, 0.0)  # one stop command, then wait for rest
        stopped = rospy.get_time()
        wait_for(lambda: rospy.get_time() > stopped + 1.0
                 and abs(self.truth.msg.twist.twist.linear.x) < 1e-6
                 and abs(self.truth.msg.twist.twist.angular.z) < 1e-6, 60.0,
                 "the robot to stand still")
        odom_in_map = compose(start, pose_of(self.odom.msg))
        truth = pose_of(self.truth.msg)

        # The robot really drove the sides it was told to (ground truth), within the
        # wheel scale errors and the 20 Hz sampling of the truth (1 cm at 0.2 m/s).
        for odom_side, truth_side in sides:
            self.assertGreaterEqual(odom_side, self.side_m)
            self.assertAlmostEqual(truth_side, odom_side,
                                   delta=3 * self.scale_sigma * odom_side + 0.03)

        # Odometry vs ground truth. 3-sigma bounds of the configured wheel-encoder errors
        # (per-wheel scale sigma s, random travel error k * sqrt(d)) over the wheel travel
        # of the square: 4 sides + 4 quarter turns of each wheel on its half base.
        travel = 4 * self.side_m + 4 * (WHEEL_BASE_M / 2) * (math.pi / 2)
        sigma_heading = math.hypot(math.sqrt(2) * self.scale_sigma * travel,
                                   math.sqrt(2 * travel) * self.noise_k) / WHEEL_BASE_M
        quantum = math.radians(1.0) + 0.01  # the Create reports whole degrees / mm
        heading_tol = 3 * sigma_heading + quantum
        position_tol = heading_tol * 2 * self.side_m + 3 * self.scale_sigma * travel + 0.02
        err_pos = math.hypot(odom_in_map[0] - truth[0], odom_in_map[1] - truth[1])
        err_yaw = abs(wrap(odom_in_map[2] - truth[2]))
        rospy.loginfo("square: odom %s truth %s -> error %.3f m (tol %.3f), %.2f deg "
                      "(tol %.2f)", odom_in_map, truth, err_pos, position_tol,
                      math.degrees(err_yaw), math.degrees(heading_tol))
        self.assertLess(err_pos, position_tol)
        self.assertLess(err_yaw, heading_tol)
        # Path length is nearly immune to heading errors: the scale errors bound it.
        odom_len, truth_len = path_length(self.odom.all), path_length(self.truth.all)
        self.assertGreater(truth_len, 4 * self.side_m - 0.05)
        self.assertAlmostEqual(truth_len, odom_len, delta=3 * self.scale_sigma * odom_len
                               + 3 * self.noise_k * math.sqrt(odom_len) + 0.02)


def path_length(odoms):
    pts = [(m.pose.pose.position.x, m.pose.pose.position.y) for m in odoms]
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:]))


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "square", SquareTest, sys.argv)
