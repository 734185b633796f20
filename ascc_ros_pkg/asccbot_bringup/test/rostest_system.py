#!/usr/bin/env python3
"""rostest (system_sim.test): the robot stack brought up by
launch/robot/explore.launch against the simulator publishes docs/DESIGN.md's topics with
their documented types and frames, and TF holds map -> odom -> base_link -> laser, camera."""
import sys
import unittest

import rosgraph
import rospy
import rostest
import tf2_ros
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry, Path
from sensor_msgs.msg import BatteryState, LaserScan
from std_msgs.msg import Float64, String
from visualization_msgs.msg import MarkerArray

from ascc_testing.waits import wait_for
from irobot_create_2_1.msg import Hazards, SensorPacket

# topic -> (message class, documented type, frame_id of its header or None)
TOPICS = {
    "odom": (Odometry, "nav_msgs/Odometry", "odom"),
    "scan": (LaserScan, "sensor_msgs/LaserScan", "laser"),
    "sensorPacket": (SensorPacket, "irobot_create_2_1/SensorPacket", None),
    "hazards": (Hazards, "irobot_create_2_1/Hazards", None),
    "battery": (BatteryState, "sensor_msgs/BatteryState", None),
    "/diagnostics": (DiagnosticArray, "diagnostic_msgs/DiagnosticArray", None),
    "/diagnostics_agg": (DiagnosticArray, "diagnostic_msgs/DiagnosticArray", None),
    "map": (OccupancyGrid, "nav_msgs/OccupancyGrid", "map"),
    "map_metadata": (MapMetaData, "nav_msgs/MapMetaData", None),
    "slam_gmapping/entropy": (Float64, "std_msgs/Float64", None),
    "frontier_explorer/status": (String, "std_msgs/String", None),
    "frontier_explorer/markers": (MarkerArray, "visualization_msgs/MarkerArray", None),
    "move_base/plan": (Path, "nav_msgs/Path", "map"),
    "cmd_vel": (Twist, "geometry_msgs/Twist", None),
}


class SystemTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("system_test")
        cls.buffer = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    def test_1_documented_topics_types_and_frames(self):
        master = rosgraph.Master("/system_test")
        for topic, (cls, type_name, frame) in TOPICS.items():
            msg = rospy.wait_for_message(topic, cls, timeout=180.0)
            types = dict(master.getTopicTypes())
            self.assertEqual(types.get(rospy.resolve_name(topic)), type_name, topic)
            if frame is not None:
                self.assertEqual(msg.header.frame_id, frame, topic)
            if topic == "odom":
                self.assertEqual(msg.child_frame_id, "base_link")
            if topic == "/diagnostics_agg":  # the aggregator groups the Create's status
                wait_for(lambda t=topic, c=cls: any(
                    s.name.startswith("/ASCCbot/Create")
                    for s in rospy.wait_for_message(t, c, 30.0).status),
                    60.0, "/ASCCbot/Create in /diagnostics_agg")

    def test_2_tf_chain_and_description(self):
        for parent, child in (("map", "odom"), ("odom", "base_link"), ("base_link", "laser"),
                              ("base_link", "camera"), ("map", "laser"), ("map", "camera")):
            wait_for(lambda p=parent, c=child: self.buffer.can_transform(p, c, rospy.Time(0)),
                     120.0,
                     "TF %s -> %s" % (parent, child))
        frames = yaml.safe_load(self.buffer.all_frames_as_yaml())
        for child, parent in (("odom", "map"), ("base_link", "odom"), ("laser", "layer_3"),
                              ("camera", "layer_4"), ("layer_4", "stand"),
                              ("stand", "base_link")):
            self.assertEqual(frames[child]["parent"], parent, child)
        t = self.buffer.lookup_transform("base_link", "laser", rospy.Time(0)).transform
        self.assertAlmostEqual(t.translation.z, 0.30, places=6)  # the simulator's mount
        self.assertIn('<robot name="asccbot"', rospy.get_param("robot_description"))


if __name__ == "__main__":
    rostest.rosrun("asccbot_bringup", "system_sim", SystemTest, sys.argv)
