#!/usr/bin/env python3
"""Test helper node: a tiny fake world + fake move_base for explorer_fake_move_base.test.

A hand-made office (corridor, four rooms, furniture) is the ground truth. The node
* publishes `map` (latched) holding what has been "seen": cells on 360 rays of
  ~sensor_range_m from each pose the robot stopped at; free cells are written as 5 and
  occupied as 90 (cartographer-like probabilities) to exercise the explorer's thresholding;
* broadcasts TF map -> base_link at 20 Hz;
* serves the `move_base` action: a goal is rejected (aborted + counted as bad) unless its
  cell is free in the truth with the robot's clearance and known free in the current map;
  otherwise the robot "drives" there (waits distance / ~speed_mps, preemptible), the map is
  updated from the new pose and the goal succeeds;
* publishes `~stats` (std_msgs/String, JSON, latched): goals, bad_goals, preempted, path_m.
Parameters: ~sensor_range_m (4.0), ~speed_mps (3.0), ~start_xy ([1.0, 1.0], metres: the
robot's TF pose; may be off the map to test that case, the first map is always seen from
START), ~serve_move_base (true; false = no action server).
`build_world()` is imported by the test script to compute coverage.
"""

import json
import math
import threading

import actionlib
import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from move_base_msgs.msg import MoveBaseAction
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import String

from frontier_detector.frontiers import traversable_mask
from frontier_detector.grid import FREE, OCCUPIED, UNKNOWN, MapInfo
from frontier_detector.report import scan_truth

RES = 0.05
START = (1.0, 1.0)          # [m] robot start in the map frame
CLEARANCE_M = 0.17


def build_world():
    """12 m x 8 m office: corridor along the south, four rooms with doors to it."""
    h, w = int(8 / RES), int(12 / RES)
    t = np.full((h, w), FREE, np.int8)
    t[:2, :] = t[-2:, :] = t[:, :2] = t[:, -2:] = OCCUPIED
    t[40:42, :] = OCCUPIED                                   # corridor's north wall, y=2 m
    for x_wall in (60, 120, 180):                            # room dividers
        t[40:, x_wall: x_wall + 2] = OCCUPIED
    for door in (20, 80, 140, 200):                          # 1 m doors into the rooms
        t[40:42, door: door + 20] = FREE
    t[100:120, 30:45] = OCCUPIED                             # furniture
    t[120:140, 150:170] = OCCUPIED
    t[60:70, 200:230] = OCCUPIED
    return t, MapInfo(RES)


class FakeWorld:
    def __init__(self):
        self.truth, self.info = build_world()
        self.range_cells = int(rospy.get_param("~sensor_range_m", 4.0) / RES)
        self.speed = float(rospy.get_param("~speed_mps", 3.0))
        self.lock = threading.Lock()
        self.pose = tuple(rospy.get_param("~start_xy", list(START)))
        self.known = np.full(self.truth.shape, UNKNOWN, np.int8)
        self.trav = traversable_mask(self.truth, CLEARANCE_M / RES) > 0
        self.stats = {"goals": 0, "bad_goals": 0, "preempted": 0, "path_m": 0.0}
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.stats_pub = rospy.Publisher("~stats", String, queue_size=1, latch=True)
        self.tfb = tf2_ros.TransformBroadcaster()
        self._observe(START)                 # the first map is always seen from START
        if rospy.get_param("~serve_move_base", True):
            self.server = actionlib.SimpleActionServer(
                "move_base", MoveBaseAction, execute_cb=self._execute, auto_start=False)
            self.server.start()
        self._publish_stats()
        rospy.Timer(rospy.Duration(0.05), self._tf)

    def _observe(self, xy=None):
        rc = self.info.world_to_cell(*(xy or self.pose))
        # all round: 361 rays from -pi to pi are the 360 directions 1 deg apart
        scan_truth(self.truth, self.known, rc, 0.0, self.range_cells, 2.0 * math.pi, 361)
        m = OccupancyGrid()
        m.header.frame_id = "map"
        m.header.stamp = rospy.Time.now()
        m.info.resolution = RES
        m.info.height, m.info.width = self.known.shape
        m.info.origin.orientation.w = 1.0
        data = self.known.copy()
        data[data == FREE] = 5
        data[data == OCCUPIED] = 90
        m.data = data.ravel().tolist()
        self.map_pub.publish(m)

    def _tf(self, _event):
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id = "map"
        t.child_frame_id = "base_link"
        with self.lock:
            t.transform.translation.x, t.transform.translation.y = self.pose
        t.transform.rotation.w = 1.0
        self.tfb.sendTransform(t)

    def _publish_stats(self):
        self.stats_pub.publish(String(json.dumps(self.stats)))

    def _execute(self, goal):
        p = goal.target_pose.pose.position
        r, c = self.info.world_to_cell(p.x, p.y)
        ok = (goal.target_pose.header.frame_id == "map" and 0 <= r < self.truth.shape[0]
              and 0 <= c < self.truth.shape[1] and self.trav[r, c]
              and self.known[r, c] == FREE)
        self.stats["goals"] += 1
        if not ok:
            self.stats["bad_goals"] += 1
            self._publish_stats()
            self.server.set_aborted(text="goal not in known free space")
            return
        dist = math.hypot(p.x - self.pose[0], p.y - self.pose[1])
        deadline = rospy.Time.now() + rospy.Duration(min(2.0, dist / self.speed))
        rate = rospy.Rate(50)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                self.stats["preempted"] += 1
                self._publish_stats()
                self.server.set_preempted()
                return
            rate.sleep()
        with self.lock:
            self.pose = (p.x, p.y)
        self.stats["path_m"] += dist
        self._observe()
        self._publish_stats()
        self.server.set_succeeded()


if __name__ == "__main__":
    rospy.init_node("fake_world")
    FakeWorld()
    rospy.spin()
