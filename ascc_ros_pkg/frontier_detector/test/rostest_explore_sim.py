#!/usr/bin/env python3
"""rostest: the office explored in the simulator (explore_office_sim.test).

Waits (wall-clock timeout, no fixed sleep) for exploration_monitor's latched summary and
checks: the explorer finished (`done`, not the monitor's time limit), >= 95 % of the
ground truth's reachable area is mapped, the bumpers never hit anything.
"""

import json
import threading
import time
import unittest

import rospy
import rostest
from std_msgs.msg import String

WALL_TIMEOUT_S = 780.0


class ExploreSimTest(unittest.TestCase):
    def test_office_explored(self):
        cond = threading.Condition()
        box = {}

        def on_summary(msg):
            with cond:
                box["summary"] = json.loads(msg.data)
                cond.notify_all()

        rospy.Subscriber("exploration_monitor/summary", String, on_summary)
        deadline = time.monotonic() + WALL_TIMEOUT_S
        with cond:
            while "summary" not in box:
                left = deadline - time.monotonic()
                if left <= 0 or rospy.is_shutdown():
                    self.fail("no exploration summary within %.0f s wall time" % WALL_TIMEOUT_S)
                cond.wait(min(left, 1.0))
        s = box["summary"]
        rospy.loginfo("office exploration: %s" % json.dumps(s))
        self.assertEqual(s["end_reason"], "done", s)
        self.assertGreaterEqual(s["final_coverage"], 0.95, s)
        self.assertEqual(s["bumps"], 0, s)
        self.assertGreater(s["goals"], 0, s)


if __name__ == "__main__":
    rospy.init_node("rostest_explore_sim")
    rostest.rosrun("frontier_detector", "explore_office_sim", ExploreSimTest)
