#!/usr/bin/env python3
"""rostest: frontier_explorer against fake_world.py (fake map, TF and move_base).

Checks, waiting on conditions with timeouts (no fixed sleeps):
* the explorer starts exploring, publishes markers for every phase and the goal;
* ~stop pauses it (status idle), ~start resumes;
* it finishes with status "done", having covered >= 95 % of the fake office's reachable
  area, without a single goal outside known free space.
"""

import json
import os
import sys
import threading
import unittest

import rospy
import rostest
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fake_world  # noqa: E402  (test helper next to this file)

from ascc_testing.waits import ConditionWaitMixin  # noqa: E402
from frontier_detector.report import coverage  # noqa: E402
from frontier_detector.rosmsg import grid_from_msg  # noqa: E402

NODE = "frontier_explorer"


class ExplorerTest(ConditionWaitMixin, unittest.TestCase):
    def setUp(self):
        self.cond = threading.Condition()
        self.statuses = []
        self.stats = None
        self.map = None
        self.marker_ns = set()
        rospy.Subscriber(NODE + "/status", String, self._status)
        rospy.Subscriber("fake_world/stats", String, self._stats)
        rospy.Subscriber("map", OccupancyGrid, self._map)
        rospy.Subscriber(NODE + "/markers", MarkerArray, self._markers)

    def _status(self, msg):
        with self.cond:
            self.statuses.append(msg.data)
            self.cond.notify_all()

    def _stats(self, msg):
        with self.cond:
            self.stats = json.loads(msg.data)
            self.cond.notify_all()

    def _map(self, msg):
        with self.cond:
            self.map = msg
            self.cond.notify_all()

    def _markers(self, msg):
        with self.cond:
            self.marker_ns.update(m.ns for m in msg.markers if m.points or m.ns == "goal")
            self.cond.notify_all()

    def test_explores_fake_office(self):
        self.wait_for(lambda: self.statuses and self.statuses[-1] == "exploring", 30.0,
                      "status exploring")
        self.wait_for(lambda: self.stats is not None and self.stats["goals"] >= 1, 30.0,
                      "a first goal")
        self.wait_for(lambda: {"phase1", "phase2", "phase3", "goal"} <= self.marker_ns,
                      30.0, "markers of every phase")
        rospy.wait_for_service(NODE + "/stop", 10.0)
        # Pause while a goal is being driven (the fake takes up to 2 s per goal).
        self.wait_for(lambda: self.statuses[-1] == "exploring", 10.0, "exploring")
        self.assertTrue(rospy.ServiceProxy(NODE + "/stop", Trigger)().success)
        self.wait_for(lambda: self.statuses[-1] == "idle", 10.0, "status idle")
        self.assertTrue(rospy.ServiceProxy(NODE + "/start", Trigger)().success)
        self.wait_for(lambda: self.statuses[-1] == "done", 150.0, "status done")
        with self.cond:
            stats, last_map = dict(self.stats), self.map
        self.assertEqual(stats["bad_goals"], 0, stats)
        grid, info, counts = grid_from_msg(last_map)
        self.assertGreater(counts["non_trinary"], 0)      # the explorer had to threshold
        truth, tinfo = fake_world.build_world()
        cov = coverage(grid, info, truth, tinfo, fake_world.START,
                       clearance_m=fake_world.CLEARANCE_M)
        rospy.loginfo("fake office: coverage %.3f after %d goals, %.1f m"
                      % (cov, stats["goals"], stats["path_m"]))
        self.assertGreaterEqual(cov, 0.95)


if __name__ == "__main__":
    rospy.init_node("rostest_explorer")
    rostest.rosrun("frontier_detector", "explorer_fake_move_base", ExplorerTest)
