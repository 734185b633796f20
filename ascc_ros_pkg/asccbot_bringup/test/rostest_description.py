#!/usr/bin/env python3
"""rostest: robot_state_publisher publishes the description's frames at the description's
mounts (read back from /tf_static), and run_if_installed starts a node under its name."""
import sys
import unittest

import rosnode
import rospy
import rostest
import tf2_ros
from std_msgs.msg import String

from ascc_common.params import from_params
from ascc_testing.waits import wait_for
from asccbot_bringup.description import DescriptionParams, mounts


class DescriptionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("description_test")
        cls.params = from_params(DescriptionParams, rospy.get_param, "~")
        cls.buffer = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    def lookup(self, child, parent="base_link"):
        wait_for(lambda: self.buffer.can_transform(parent, child, rospy.Time(0)), 60.0,
                 "TF %s -> %s" % (parent, child))
        t = self.buffer.lookup_transform(parent, child, rospy.Time(0)).transform
        return t.translation, t.rotation

    def test_sensor_frames_at_the_mounts(self):
        expected = mounts(self.params)
        self.assertEqual(set(expected), {"laser", "camera", "kinect"})
        for frame, (x, y, z, _) in expected.items():
            tr, rot = self.lookup(frame)
            for got, want in ((tr.x, x), (tr.y, y), (tr.z, z)):
                self.assertAlmostEqual(got, want, places=4, msg=frame)
            self.assertAlmostEqual(abs(rot.w), 1.0, places=6, msg=frame)  # yaw 0
        # webcam layout: the laser above the webcam
        self.assertGreater(self.lookup("laser")[0].z, self.lookup("camera")[0].z)
        for frame in ("layer_1", "layer_4", "fitpc2", "tablet", "left_wheel"):
            self.lookup(frame)

    def test_run_if_installed_keeps_name_and_arguments(self):
        msg = rospy.wait_for_message("wrapped", String, timeout=60.0)
        self.assertEqual(msg.data, "wrapped_data")
        self.assertIn("/through_wrapper", rosnode.get_node_names())


if __name__ == "__main__":
    rostest.rosrun("asccbot_bringup", "description_tf", DescriptionTest, sys.argv)
