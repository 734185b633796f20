#!/usr/bin/env python3
"""rostest: frontier_explorer with no move_base server, then with the robot off the map.

1. No action server: ~status says waiting_for_move_base; the node stays alive and answers
   ~stop (idle) and ~start.
2. This script then starts a move_base server that counts goals: the robot's TF pose is
   off the map, so ~status must become robot_outside_map and no goal may arrive.
Waits on conditions with timeouts, no fixed sleeps.
"""

import os
import sys
import threading
import unittest

import actionlib
import rosgraph
import rospy
import rostest
from move_base_msgs.msg import MoveBaseAction
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ascc_testing.waits import ConditionWaitMixin  # noqa: E402

NODE = "frontier_explorer"


class BadInputTest(ConditionWaitMixin, unittest.TestCase):
    def setUp(self):
        self.cond = threading.Condition()
        self.statuses = []
        self.marker_msgs = 0
        rospy.Subscriber(NODE + "/status", String, self._status)
        rospy.Subscriber(NODE + "/markers", MarkerArray, self._markers)

    def _markers(self, _msg):
        with self.cond:
            self.marker_msgs += 1
            self.cond.notify_all()

    def _status(self, msg):
        with self.cond:
            self.statuses.append(msg.data)
            self.cond.notify_all()

    def test_reports_and_survives(self):
        self.wait_for(lambda: "waiting_for_move_base" in self.statuses, 30.0,
                      "status waiting_for_move_base")
        # Still alive and serving: stop -> idle, start -> the same problem again.
        rospy.wait_for_service(NODE + "/stop", 10.0)
        self.assertTrue(rospy.ServiceProxy(NODE + "/stop", Trigger)().success)
        self.wait_for(lambda: self.statuses[-1] == "idle", 10.0, "status idle")
        self.assertTrue(rospy.ServiceProxy(NODE + "/start", Trigger)().success)
        self.wait_for(lambda: self.statuses[-1] == "waiting_for_move_base", 10.0,
                      "waiting_for_move_base again")
        master = rosgraph.Master("/rostest_bad_input")
        publishers = dict(master.getSystemState()[0])
        self.assertIn("/" + NODE, publishers.get("/" + NODE + "/status", []))
        # Now a move_base appears; the robot is still off the map.
        goals = []
        server = actionlib.SimpleActionServer(
            "move_base", MoveBaseAction,
            execute_cb=lambda g: (goals.append(g), server.set_aborted()), auto_start=False)
        server.start()
        self.wait_for(lambda: self.statuses[-1] == "robot_outside_map", 30.0,
                      "status robot_outside_map")
        # Each plan publishes markers: after two more plans there is still no goal.
        with self.cond:
            n = self.marker_msgs
        self.wait_for(lambda: self.marker_msgs >= n + 2, 10.0, "two more plans")
        self.assertEqual(self.statuses[-1], "robot_outside_map")
        self.assertEqual(goals, [])


if __name__ == "__main__":
    rospy.init_node("rostest_bad_input")
    rostest.rosrun("frontier_detector", "explorer_bad_input", BadInputTest)
