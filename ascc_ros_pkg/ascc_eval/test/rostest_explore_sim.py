#!/usr/bin/env python3
"""rostest: the office explored in the simulator (explore_office_sim.test).

Waits (wall-clock timeout, no fixed sleep) for exploration_monitor's latched summary and
checks: the explorer finished (`done`, not the monitor's time limit), >= 95 % of the
ground truth's reachable area is mapped, the bumpers never hit anything.
Also logs (does not assert: it depends on the machine's load) what explains a failure:
the real-time factor achieved and the warnings of the robot's own nodes (driver, mapper,
navigator, simulator: late scans or TF, dropped commands, missing sensor frames), counted
by kind, which say whether they were starved of CPU.
"""

import collections
import json
import re
import threading
import time
import unittest

import rospy
import rostest
from std_msgs.msg import String

from ascc_testing.rosout import RosoutWatcher

WALL_TIMEOUT_S = 780.0
ROBOT_NODES = ("/simulator", "/driver", "/slam_gmapping", "/move_base")


def warning_kinds(records):
    """{text with its numbers replaced by #: count} of the robot's nodes' warnings."""
    kinds = collections.Counter()
    for r in records:
        if r.node in ROBOT_NODES:
            kinds["%s: %s" % (r.node, re.sub(r"[-+]?\d[\d.e+-]*", "#", r.text)[:110])] += 1
    return dict(kinds)


class ExploreSimTest(unittest.TestCase):
    def test_office_explored(self):
        cond = threading.Condition()
        box = {}

        def on_summary(msg):
            with cond:
                box["summary"] = json.loads(msg.data)
                cond.notify_all()

        rosout = RosoutWatcher()
        rospy.Subscriber("exploration_monitor/summary", String, on_summary)
        deadline = time.monotonic() + WALL_TIMEOUT_S
        with cond:
            while rospy.get_time() <= 0.0 and time.monotonic() < deadline:
                cond.wait(0.05)                   # the simulated clock starts (no box change)
        wall0, sim0 = time.monotonic(), rospy.get_time()
        with cond:
            while "summary" not in box:
                left = deadline - time.monotonic()
                if left <= 0 or rospy.is_shutdown():
                    self.fail("no exploration summary within %.0f s wall time" % WALL_TIMEOUT_S)
                cond.wait(min(left, 1.0))
        s = box["summary"]
        wall, sim = time.monotonic() - wall0, rospy.get_time() - sim0
        measured = ("office exploration: %.0f s simulated in %.0f s wall: real-time factor "
                    "%.2f (cap %s); the robot's nodes' warnings: %s"
                    % (sim, wall, sim / wall if wall > 0 else 0.0,
                       rospy.get_param("simulator/real_time_factor", "?"),
                       json.dumps(warning_kinds(rosout.matching(level="warn")), indent=1)))
        rospy.loginfo(measured)
        print(measured)
        rospy.loginfo("office exploration: %s" % json.dumps(s))
        self.assertEqual(s["end_reason"], "done", s)
        self.assertGreaterEqual(s["final_coverage"], 0.95, s)
        self.assertEqual(s["bumps"], 0, s)
        self.assertGreater(s["goals"], 0, s)


if __name__ == "__main__":
    rospy.init_node("rostest_explore_sim")
    rostest.rosrun("ascc_eval", "explore_office_sim", ExploreSimTest)
