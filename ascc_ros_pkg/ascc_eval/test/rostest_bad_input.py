#!/usr/bin/env python3
"""rostest: frontier_explorer with no move_base server, a robot off the map, malformed maps.

The explorer is launched with autostart false, so that this script's /rosout watcher is
connected before anything is logged.
1. No action server: ~status says waiting_for_move_base and the node warns, naming it, once
   per throttle period (not again after ~stop/~start within the period); the node stays
   alive and answers ~stop (idle) and ~start.
2. This script then starts a move_base server that counts goals: the robot's TF pose is
   off the map, so ~status becomes robot_outside_map, warned about at the first plan (a
   different problem is not hidden by the previous one's throttle), naming the robot's
   position, once per period; no goal arrives.
3. Malformed maps (data size != width x height), one per plan: each is ignored with a
   warning naming the sizes, at most once per period, and planning goes on with the last
   good map (status still robot_outside_map, not waiting_for_map); still no goal.
Waits on conditions with timeouts, no fixed sleeps.
"""

import threading
import unittest

import actionlib
import rosgraph
import rospy
import rostest
from move_base_msgs.msg import MoveBaseAction
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import ConditionWaitMixin

NODE = "frontier_explorer"
WARN_PERIOD_S = 10.0        # frontier_explorer's throttle of problem and bad-map warnings
PLANS = 3                   # planning ticks observed per phase


class BadInputTest(ConditionWaitMixin, unittest.TestCase):
    def setUp(self):
        self.cond = threading.Condition()
        self.statuses = []
        self.marker_msgs = 0
        self.rosout = RosoutWatcher()
        rospy.Subscriber(NODE + "/status", String, self._status)
        rospy.Subscriber(NODE + "/markers", MarkerArray, self._markers)
        self.rosout.wait_for_connection()

    def _markers(self, _msg):
        with self.cond:
            self.marker_msgs += 1
            self.cond.notify_all()

    def _status(self, msg):
        with self.cond:
            self.statuses.append(msg.data)
            self.cond.notify_all()

    def warnings(self, *contains):
        return self.rosout.matching(node="/" + NODE, level="warn", contains=contains)

    def assert_throttled(self, warns, what):
        """At least one, and at most one per WARN_PERIOD_S from the first one until now."""
        self.assertGreaterEqual(len(warns), 1, "no %s warning; the node's last warnings: %s"
                                % (what, [w.text for w in self.warnings()][-5:]))
        span = rospy.get_time() - warns[0].stamp_s
        self.assertLessEqual(len(warns), int(span // WARN_PERIOD_S) + 1,
                             [(w.stamp_s, w.text) for w in warns])

    def wait_plans(self, n, what):
        with self.cond:
            start = self.marker_msgs
        self.wait_for(lambda: self.marker_msgs >= start + n, 10.0 + 2.0 * n, what)

    def test_reports_and_survives(self):
        rospy.wait_for_service(NODE + "/start", 30.0)
        self.wait_for(lambda: self.statuses and self.statuses[-1] == "idle", 10.0,
                      "status idle (autostart false)")
        self.assertTrue(rospy.ServiceProxy(NODE + "/start", Trigger)().success)
        # 1. No move_base.
        self.wait_for(lambda: self.statuses[-1] == "waiting_for_move_base", 30.0,
                      "status waiting_for_move_base")
        self.rosout.wait_for(10.0, "the waiting_for_move_base warning", node="/" + NODE,
                             level="warn", contains=["waiting_for_move_base",
                                                     "move_base action server not up"])
        # Still alive and serving: stop -> idle, start -> the same problem again, which
        # is not warned about again within the period.
        self.assertTrue(rospy.ServiceProxy(NODE + "/stop", Trigger)().success)
        self.wait_for(lambda: self.statuses[-1] == "idle", 10.0, "status idle")
        self.assertTrue(rospy.ServiceProxy(NODE + "/start", Trigger)().success)
        self.wait_for(lambda: self.statuses[-1] == "waiting_for_move_base", 10.0,
                      "waiting_for_move_base again")
        self.assert_throttled(self.warnings("waiting_for_move_base"), "waiting_for_move_base")
        master = rosgraph.Master("/rostest_bad_input")
        publishers = dict(master.getSystemState()[0])
        self.assertIn("/" + NODE, publishers.get("/" + NODE + "/status", []))
        # 2. Now a move_base appears; the robot is still off the map.
        goals = []
        server = actionlib.SimpleActionServer(
            "move_base", MoveBaseAction,
            execute_cb=lambda g: (goals.append(g), server.set_aborted()), auto_start=False)
        server.start()
        self.wait_for(lambda: self.statuses[-1] == "robot_outside_map", 30.0,
                      "status robot_outside_map")
        # Each plan publishes markers: after PLANS more plans, still no goal, and the
        # warning was given (at the first of them), once.
        self.wait_plans(PLANS, "%d more plans" % PLANS)
        self.assertEqual(self.statuses[-1], "robot_outside_map")
        self.assert_throttled(self.warnings("robot_outside_map", "robot at (-30.00, 5.00)"),
                              "robot_outside_map (naming the robot's position)")
        self.assertEqual(goals, [])
        # 3. Malformed maps, a new one before each of PLANS plans.
        bad_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        with self.cond:
            n_status = len(self.statuses)
        for i in range(PLANS):
            bad = OccupancyGrid()
            bad.header.frame_id = "map"
            bad.header.stamp = rospy.Time.now()
            bad.info.resolution = 0.05
            bad.info.width, bad.info.height = 10, 10
            bad.info.origin.orientation.w = 1.0
            bad.data = [0] * (7 + i)
            bad_pub.publish(bad)
            if i == 0:
                self.rosout.wait_for(10.0, "the bad-map warning", node="/" + NODE,
                                     level="warn", contains=["bad map ignored",
                                                             "7 cells", "= 100"])
            self.wait_plans(1, "a plan after bad map %d" % (i + 1))
        self.wait_plans(1, "a plan after the last bad map")
        self.assert_throttled(self.warnings("bad map ignored"), "bad map")
        with self.cond:
            since = self.statuses[n_status:]
        self.assertNotIn("waiting_for_map", since)
        self.assertEqual(self.statuses[-1], "robot_outside_map")
        self.assertEqual(goals, [])


if __name__ == "__main__":
    rospy.init_node("rostest_bad_input")
    rostest.rosrun("ascc_eval", "explorer_bad_input", BadInputTest)
