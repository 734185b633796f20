#!/usr/bin/env python3
"""rostest: the driver (~robot_model create_2) on a virtual Create 1 stops at start-up with
a message naming the likely model (create_1) and ``~robot_model``, and publishes no
odometry from the Create 1's bytes. The virtual Create 1 does not know the Create 2's
packet group 100, so the frames it streams for our request are not the frames asked for.

The message is read from the driver's log file (records logged while a node shuts down
rarely reach /rosout) once the driver has exited.
"""
import glob
import os
import unittest

import rosnode
import rospkg
import rospy
import rostest
from nav_msgs.msg import Odometry

from ascc_testing.waits import Latest, wait_for

DRIVER = "/driver"


class ModelMismatchTest(unittest.TestCase):
    def test_driver_stops_naming_the_model_and_publishes_no_odometry(self):
        rospy.init_node("model_mismatch_test")
        odom = Latest("odom", Odometry)
        pattern = os.path.join(rospkg.get_log_dir(), rospy.get_param("/run_id"),
                               "driver-*.log")

        def fatal_lines():
            out = []
            for path in glob.glob(pattern):
                if not path.endswith("-stdout.log"):
                    with open(path) as f:
                        out += [line for line in f if "robot model mismatch:" in line]
            return out
        # the driver's model check gives its verdict 2 s after the first byte
        wait_for(lambda: fatal_lines(), 60.0, "the driver's fatal message in its log")
        wait_for(lambda: not rosnode.rosnode_ping(DRIVER, max_count=1), 30.0,
                 "the driver to exit on the model mismatch")
        fatal = fatal_lines()
        self.assertEqual(len(fatal), 1, "one fatal message: %s" % fatal)
        self.assertIn("[CRITICAL]", fatal[0])  # rospy.logfatal's level in the log file
        for words in ("expects a create_2", "likely a create_1", "~robot_model:=create_1",
                      "well-formed stream frames of 0 data bytes",
                      "No odometry was published"):
            self.assertIn(words, fatal[0])
        self.assertIsNone(odom.msg, "odometry published from another model's bytes")

if __name__ == "__main__":
    rostest.rosrun("irobot_create_2_1", "driver_model_mismatch", ModelMismatchTest)
