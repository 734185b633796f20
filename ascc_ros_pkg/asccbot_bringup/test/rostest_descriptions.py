#!/usr/bin/env python3
"""rostest: one robot description per namespace (descriptions.launch), links prefixed by
the namespace, each robot's sensor frames on /tf_static at the description's mounts."""
import sys
import unittest
import xml.etree.ElementTree as ET

import rosnode
import rospy
import rostest
import tf2_ros
import yaml

from ascc_testing.waits import wait_for
from asccbot_bringup.description import DescriptionParams, mounts


class DescriptionsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("descriptions_test")
        cls.robots = rospy.get_param("~robots").split()
        cls.params = DescriptionParams(layout=rospy.get_param("~layout"),
                                       robot_model=rospy.get_param("~robot_model"))
        cls.params.validate()
        cls.buffer = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    def lookup(self, parent, child):
        wait_for(lambda: self.buffer.can_transform(parent, child, rospy.Time(0)), 60.0,
                 "TF %s -> %s" % (parent, child))
        return self.buffer.lookup_transform(parent, child, rospy.Time(0)).transform

    def test_descriptions_are_prefixed_per_namespace(self):
        self.assertEqual(len(self.robots), 3)
        nodes = rosnode.get_node_names()
        for robot in self.robots:
            urdf = rospy.get_param("/%s/robot_description" % robot)
            root = ET.fromstring(urdf)
            links = [e.get("name") for e in root.iter("link")]
            self.assertIn(robot + "/base_link", links)
            frames = links + [e.get("link") for tag in ("parent", "child")
                              for e in root.iter(tag)]
            self.assertEqual([f for f in frames if not f.startswith(robot + "/")], [], robot)
            self.assertIn("/%s/robot_state_publisher" % robot, nodes)
        self.assertFalse(rospy.has_param("/robot_description"))

    def test_sensor_frames_at_the_mounts(self):
        expected = mounts(self.params)
        for robot in self.robots:
            for frame, (x, y, z, _) in expected.items():
                t = self.lookup(robot + "/base_link", "%s/%s" % (robot, frame))
                for got, want in ((t.translation.x, x), (t.translation.y, y),
                                  (t.translation.z, z)):
                    self.assertAlmostEqual(got, want, places=4, msg=(robot, frame))
            # the webcam layout: the laser above the webcam
            self.assertGreater(self.lookup(robot + "/base_link", robot + "/laser").translation.z,
                               self.lookup(robot + "/base_link", robot + "/camera").translation.z)
            self.lookup(robot + "/base_link", robot + "/layer_4")

    def test_no_frame_outside_the_namespaces(self):
        for robot in self.robots:
            self.lookup(robot + "/base_link", robot + "/camera")
        frames = yaml.safe_load(self.buffer.all_frames_as_yaml()) or {}
        names = set(frames) | {f["parent"] for f in frames.values()}
        self.assertEqual(sorted(n for n in names
                                if not any(n.startswith(r + "/") for r in self.robots)), [])


if __name__ == "__main__":
    rostest.rosrun("asccbot_bringup", "descriptions_per_namespace", DescriptionsTest, sys.argv)
