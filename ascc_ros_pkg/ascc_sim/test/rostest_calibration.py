#!/usr/bin/env python3
"""rostest: irobot_create_2_1's calibrate_odometry in the simulator (calibration.test). The
laser-measured factor (true / odometry distance) must match the one the ground truth and
the driver's odometry give over the same runs (their path lengths while it drove), within
0.1 %: the realised ratio, which the wheels' random noise moves by ~0.1 % over these 4.8 m
(the laser sees the same runs, so that noise is not an error of the calibration); and the
wheels' error must be large enough that 1.0 would not pass. The file it writes
(``~output_file``, YAML the driver's parameters can load) must hold the same factor."""
import math
import os
import sys
import unittest

import rospy
import rostest
import yaml
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64

from ascc_testing.waits import Latest, wait_for


class PathLength:
    """Path length [m] of a nav_msgs/Odometry stream, summed over its messages."""

    def __init__(self, topic):
        self.length = 0.0
        self.first = None
        self.last = None
        self.sub = rospy.Subscriber(topic, Odometry, self.on_msg, queue_size=100)

    def on_msg(self, msg):
        p = msg.pose.pose.position
        if self.first is None:
            self.first = (p.x, p.y)
        if self.last is not None:
            self.length += math.hypot(p.x - self.last[0], p.y - self.last[1])
        self.last = (p.x, p.y)


class CalibrationTest(unittest.TestCase):
    def test_factor_matches_truth_over_odometry(self):
        rospy.init_node("calibration_test")
        robot = rospy.get_param("~robot", "asccbot")
        result = Latest("calibrate_odometry/odom_linear_scale_correction", Float64)
        truth = PathLength("ground_truth/%s/odom" % robot)
        odom = PathLength("odom")
        wait_for(lambda: result.msg is not None, 200.0, "calibrate_odometry's result")
        factor = result.msg.data
        true_factor = truth.length / odom.length
        rospy.loginfo("calibration: %.5f, truth / odometry over the runs %.5f (%.2f m / %.2f m)",
                      factor, true_factor, truth.length, odom.length)
        self.assertGreater(truth.length, 4.0)  # 4 runs of 1.2 m
        # both paths were followed from the start (calibration.test's start_delay_s)
        self.assertLess(math.hypot(truth.first[0] - 2.0, truth.first[1] - 2.5), 1e-3)
        self.assertLess(math.hypot(*odom.first), 1e-3)
        self.assertGreater(abs(true_factor - 1.0), 0.003, "the wheels' error is too small "
                           "for this test to tell a calibration from none")
        self.assertAlmostEqual(factor, true_factor, delta=0.001)
        path = rospy.get_param("~output_file")
        wait_for(lambda: os.path.exists(path) and os.path.getsize(path) > 0, 10.0,
                 "calibrate_odometry's output file")
        with open(path) as f:
            saved = yaml.safe_load(f)
        os.remove(path)
        self.assertAlmostEqual(saved["odom_linear_scale_correction"], factor, delta=1e-5)


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "calibration", CalibrationTest, sys.argv)
