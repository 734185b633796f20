#!/usr/bin/env python3
"""Test helper node: a tiny fake world + fake move_base for explorer_fake_move_base.test.

A hand-made office (corridor, four rooms, furniture) is the ground truth. The node
* publishes `map` (latched) holding what has been "seen": cells on 360 rays of
  ~sensor_range_m from each pose the robot stopped at; free cells are written as 5 and
  occupied as 90 (cartographer-like probabilities) to exercise the explorer's thresholding;
* broadcasts TF map -> base_link at 20 Hz;
* serves the `move_base` action: a goal is rejected (aborted + counted as bad) unless its
  cell is free in the truth with the robot's clearance and known free in the current map;
  otherwise the robot "drives" there (waits distance / ~speed_mps, at most 2 s,
  preemptible), the map is updated from the new pose and the goal succeeds;
  goals whose number (1, 2, ... in order of arrival) is in ~abort_goals are aborted at once
  as if move_base could not reach them (not counted as bad), those in ~stall_goals are
  accepted but the robot never moves (no map update) until the goal is preempted;
* publishes the ground truth the way ascc_sim does, for exploration_monitor (truth frame =
  the map frame): `ground_truth/map` (latched, -1/0/100), `ground_truth/asccbot/start_pose`
  (latched) and `ground_truth/asccbot/pose` (with the TF);
* publishes `~stats` (std_msgs/String, JSON, latched): goals, bad_goals, preempted, path_m,
  pose [x, y] and log: one entry per goal {n, x, y, stamp (the goal's header stamp),
  start, end (ROS time of arrival and end), outcome: succeeded | aborted | bad |
  preempted}.
Parameters: ~sensor_range_m (4.0), ~speed_mps (3.0), ~start_xy ([1.0, 1.0], metres: the
robot's TF pose; may be off the map to test that case, the first map is always seen from
START), ~serve_move_base (true; false = no action server), ~abort_goals ([]),
~stall_goals ([]).
`build_world()` is imported by the test script to compute coverage.
"""

import json
import math
import threading

import actionlib
import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, TransformStamped
from move_base_msgs.msg import MoveBaseAction
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import String

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_eval.report import scan_truth
from frontier_detector.frontiers import traversable_mask

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
    return t, GridInfo(RES, w, h)


class FakeWorld:
    def __init__(self):
        self.truth, self.info = build_world()
        self.range_cells = int(rospy.get_param("~sensor_range_m", 4.0) / RES)
        self.speed = float(rospy.get_param("~speed_mps", 3.0))
        self.lock = threading.Lock()
        self.pose = tuple(rospy.get_param("~start_xy", list(START)))
        self.known = np.full(self.truth.shape, UNKNOWN, np.int8)
        self.trav = traversable_mask(self.truth, CLEARANCE_M / RES) > 0
        self.abort_goals = set(rospy.get_param("~abort_goals", []))
        self.stall_goals = set(rospy.get_param("~stall_goals", []))
        self.stats = {"goals": 0, "bad_goals": 0, "preempted": 0, "path_m": 0.0,
                      "pose": list(self.pose), "log": []}
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.stats_pub = rospy.Publisher("~stats", String, queue_size=1, latch=True)
        self.truth_pub = rospy.Publisher("ground_truth/map", OccupancyGrid, queue_size=1,
                                         latch=True)
        self.start_pub = rospy.Publisher("ground_truth/asccbot/start_pose", PoseStamped,
                                         queue_size=1, latch=True)
        self.pose_pub = rospy.Publisher("ground_truth/asccbot/pose", PoseStamped,
                                        queue_size=10)
        self.tfb = tf2_ros.TransformBroadcaster()
        self.start_pub.publish(self._pose_msg(self.pose))
        self.truth_pub.publish(self._grid_msg(self.truth))
        self._observe(START)                 # the first map is always seen from START
        if rospy.get_param("~serve_move_base", True):
            self.server = actionlib.SimpleActionServer(
                "move_base", MoveBaseAction, execute_cb=self._execute, auto_start=False)
            self.server.start()
        self._publish_stats()
        rospy.Timer(rospy.Duration(0.05), self._tf)

    def _observe(self, xy=None):
        ix, iy = self.info.world_to_cell(*(xy or self.pose))
        rc = (iy, ix)
        # all round: 361 rays from -pi to pi are the 360 directions 1 deg apart
        scan_truth(self.truth, self.known, rc, 0.0, self.range_cells, 2.0 * math.pi, 361)
        data = self.known.copy()
        data[data == FREE] = 5
        data[data == OCCUPIED] = 90
        self.map_pub.publish(self._grid_msg(data))

    @staticmethod
    def _grid_msg(grid):
        m = OccupancyGrid()
        m.header.frame_id = "map"
        m.header.stamp = rospy.Time.now()
        m.info.resolution = RES
        m.info.height, m.info.width = grid.shape
        m.info.origin.orientation.w = 1.0
        m.data = grid.ravel().tolist()
        return m

    @staticmethod
    def _pose_msg(xy):
        p = PoseStamped()
        p.header.frame_id = "map"
        p.header.stamp = rospy.Time.now()
        p.pose.position.x, p.pose.position.y = xy
        p.pose.orientation.w = 1.0
        return p

    def _tf(self, _event):
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id = "map"
        t.child_frame_id = "base_link"
        with self.lock:
            xy = self.pose
        t.transform.translation.x, t.transform.translation.y = xy
        t.transform.rotation.w = 1.0
        try:
            self.tfb.sendTransform(t)
            self.pose_pub.publish(self._pose_msg(xy))
        except rospy.ROSException:
            if not rospy.core.is_shutdown_requested():
                raise
            # the node is shutting down under this timer: rospy closes its topics in the
            # pre-shutdown hooks, while rospy.is_shutdown() is still false

    def _publish_stats(self):
        self.stats["pose"] = list(self.pose)
        self.stats_pub.publish(String(json.dumps(self.stats)))

    def _end(self, entry, outcome):
        entry.update(outcome=outcome, end=rospy.get_time())
        self._publish_stats()

    def _execute(self, goal):
        p = goal.target_pose.pose.position
        c, r = self.info.world_to_cell(p.x, p.y)
        ok = (goal.target_pose.header.frame_id == "map" and 0 <= r < self.truth.shape[0]
              and 0 <= c < self.truth.shape[1] and self.trav[r, c]
              and self.known[r, c] == FREE)
        self.stats["goals"] += 1
        n = self.stats["goals"]
        entry = {"n": n, "x": p.x, "y": p.y, "stamp": goal.target_pose.header.stamp.to_sec(),
                 "start": rospy.get_time(), "end": None, "outcome": None}
        self.stats["log"].append(entry)
        if not ok:
            self.stats["bad_goals"] += 1
            self._end(entry, "bad")
            self.server.set_aborted(text="goal not in known free space")
            return
        if n in self.abort_goals:
            self._end(entry, "aborted")
            self.server.set_aborted(text="fake_world: ~abort_goals")
            return
        dist = math.hypot(p.x - self.pose[0], p.y - self.pose[1])
        stall = n in self.stall_goals
        deadline = rospy.Time.now() + rospy.Duration(min(2.0, dist / self.speed))
        rate = rospy.Rate(50)
        while (stall or rospy.Time.now() < deadline) and not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                self.stats["preempted"] += 1
                self._end(entry, "preempted")
                self.server.set_preempted()
                return
            rate.sleep()
        with self.lock:
            self.pose = (p.x, p.y)
        self.stats["path_m"] += dist
        self._observe()
        self._end(entry, "succeeded")
        self.server.set_succeeded()


if __name__ == "__main__":
    rospy.init_node("fake_world")
    FakeWorld()
    rospy.spin()
