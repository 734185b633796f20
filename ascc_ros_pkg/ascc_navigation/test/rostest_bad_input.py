#!/usr/bin/env python3
"""rostest: bad input to the amcl and move_base stand-ins (see bad_input.test).

The test owns the world: it publishes /clock, TF odom -> base_link (robot standing at
(2, 2) of ``synthetic.office_world``) and base_link -> laser, the map, and scans ray-cast
on the map from a background thread. Waits are on conditions with wall-clock timeouts.
"""
import math
import sys
import threading
import time
import unittest

import actionlib
import numpy as np
import rospy
import rostest
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty

from ascc_navigation import synthetic as syn
from ascc_navigation.grid import OCCUPIED, grid_to_msg_data
from ascc_navigation.laser import LaserMount
from ascc_testing.waits import Latest, wait_for

POSE = (2.0, 2.0, 0.3)  # true robot pose in the map; odom starts there
MOUNT = LaserMount(0.1, 0.0, 0.0)
SIM_DT = 0.01  # [s] of simulated time per clock tick


class FakeWorld:
    """Clock, TF and scans of a standing robot, in a thread; ``scan_override`` replaces
    the next scans' frame and ranges (bad input)."""

    def __init__(self):
        self.grid, self.info = syn.office_world()
        self.spec = syn.LaserSpec()
        self.ranges = syn.simulate_scan(self.grid == OCCUPIED, self.info, POSE, MOUNT,
                                        self.spec, np.random.default_rng(0))
        self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
        self.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=5)
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.tf = tf2_ros.TransformBroadcaster()
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self.t = 100.0
        self.scan_override = None  # (frame, ranges) for bad scans
        self.lock = threading.Lock()
        self.running = True
        self.thread = threading.Thread(target=self.run, daemon=True)

    def start(self):
        laser = self.transform("base_link", "laser", (MOUNT.x, MOUNT.y, MOUNT.yaw), 0.0)
        self.static_tf.sendTransform(laser)
        m = OccupancyGrid()
        m.header.frame_id = "map"
        m.info.resolution = self.info.resolution
        m.info.width, m.info.height = self.info.width, self.info.height
        m.info.origin.orientation.w = 1.0
        m.data = grid_to_msg_data(self.grid)
        self.map_pub.publish(m)
        self.thread.start()

    @staticmethod
    def transform(parent, child, pose, stamp):
        t = TransformStamped()
        t.header.stamp = rospy.Time.from_sec(stamp)
        t.header.frame_id, t.child_frame_id = parent, child
        t.transform.translation.x, t.transform.translation.y = pose[0], pose[1]
        t.transform.rotation.z, t.transform.rotation.w = math.sin(pose[2] / 2), \
            math.cos(pose[2] / 2)
        return t

    def jump_back(self, seconds):
        with self.lock:
            self.t -= seconds

    def run(self):
        tick = 0
        while self.running and not rospy.is_shutdown():
            with self.lock:
                self.t += SIM_DT
                now = self.t
            self.clock_pub.publish(Clock(clock=rospy.Time.from_sec(now)))
            if tick % 10 == 0:  # 10 Hz of simulated time
                self.tf.sendTransform(self.transform("odom", "base_link", (0.0, 0.0, 0.0), now))
                self.scan_pub.publish(self.scan(now))
            tick += 1
            time.sleep(0.002)

    def scan(self, now):
        frame, ranges = "laser", self.ranges
        if self.scan_override is not None:
            frame, ranges = self.scan_override
        msg = LaserScan()
        msg.header.stamp = rospy.Time.from_sec(now)
        msg.header.frame_id = frame
        msg.angle_min = self.spec.angle_min
        msg.angle_max = self.spec.angle_min + self.spec.angle_increment * (self.spec.n - 1)
        msg.angle_increment = self.spec.angle_increment
        msg.range_min, msg.range_max = self.spec.range_min, self.spec.range_max
        msg.ranges = list(ranges)
        return msg


class BadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("bad_input_test")
        cls.world = FakeWorld()
        cls.amcl = Latest("amcl_pose", PoseWithCovarianceStamped)
        cls.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        cls.world.start()

    @classmethod
    def tearDownClass(cls):
        cls.world.running = False

    def poses_keep_coming(self, what):
        count = self.amcl.count
        # amcl_pose comes with filter updates; a no-motion update makes one happen
        rospy.ServiceProxy("request_nomotion_update", Empty)()
        wait_for(lambda: self.amcl.count > count, 30.0, "amcl_pose after %s" % what)
        p = self.amcl.msg.pose.pose.position
        self.assertLess(math.hypot(p.x - POSE[0], p.y - POSE[1]), 0.3, what)

    def test_1_amcl_survives_bad_scans_and_time_jumps(self):
        self.amcl.wait(60.0)
        self.poses_keep_coming("start-up")
        n = self.world.spec.n
        for frame, ranges in (("laser", []), ("laser", [float("nan")] * n),
                              ("laser", [float("inf")] * n), ("no_such_frame", [1.0] * n),
                              ("", [1.0] * n)):
            self.world.scan_override = (frame, ranges)
            stamp = self.world.t
            wait_for(lambda s=stamp: self.world.t > s + 0.5, 10.0, "bad scans to be sent")
        self.world.scan_override = None
        self.poses_keep_coming("bad scans")
        last = self.amcl.msg.header.stamp.to_sec()
        self.world.jump_back(60.0)  # a bag loop
        wait_for(lambda: self.amcl.msg.header.stamp.to_sec() < last - 30.0, 30.0,
                 "amcl_pose stamped after the jump back")
        self.poses_keep_coming("the clock jumped back")

    def test_2_move_base_rejects_bad_goals(self):
        self.assertTrue(self.client.wait_for_server(rospy.Duration(30.0)))
        for frame, x, words in (("no_such_frame", 3.0, "no_such_frame"),
                                ("map", float("nan"), "NaN")):
            g = MoveBaseGoal()
            g.target_pose.header.frame_id = frame
            g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, 2.0
            g.target_pose.pose.orientation.w = 1.0
            self.client.send_goal(g)
            wait_for(lambda: self.client.get_state() == GoalStatus.ABORTED, 20.0,
                     "goal in '%s' aborted" % frame)
            self.assertIn(words, self.client.get_goal_status_text())
        # after all that, and after a jump back, a good goal is still served
        self.world.jump_back(20.0)
        g = MoveBaseGoal()
        g.target_pose.header.frame_id = "map"
        g.target_pose.pose.position.x, g.target_pose.pose.position.y = 2.5, 2.0
        g.target_pose.pose.orientation.w = 1.0
        self.client.send_goal(g)
        wait_for(lambda: self.client.get_state() in (GoalStatus.ACTIVE, GoalStatus.SUCCEEDED),
                 20.0, "a valid goal to be accepted")
        self.client.cancel_goal()
        wait_for(lambda: self.client.get_state() == GoalStatus.PREEMPTED, 20.0, "PREEMPTED")


if __name__ == "__main__":
    rostest.rosrun("ascc_navigation", "bad_input", BadInputTest, sys.argv)
