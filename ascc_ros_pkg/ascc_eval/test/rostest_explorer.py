#!/usr/bin/env python3
"""rostest: frontier_explorer against fake_world.py (fake map, TF, move_base, ground truth).

explorer_fake_move_base.test makes the fake move_base abort one goal and stall a later one
(the robot does not move until it is preempted), sets return_to_start and a 6 s progress
timeout. Checks, waiting on conditions with timeouts (no fixed sleeps):
* the aborted goal is blacklisted: the next goal is elsewhere and it is never sent again;
* the stalled goal is given up after ~progress_timeout_s (not earlier), blacklisted and
  replaced ("no progress" logged), never sent again; both are in the `blacklist` markers;
* markers for every phase and the goal; ~stop pauses it (status idle), ~start resumes;
* it drives back to the start (status returning) and finishes with status done, having
  covered >= 95 % of the fake office's reachable area, without a goal outside known free
  space;
* the fake map's cartographer-like values (5 / 90) draw the thresholding warning with the
  count, throttled to once per 30 s;
* exploration_monitor ends the run by its ~max_time_s (end_reason max_time, not before the
  time), publishes the summary with the documented keys, writes <label>.json, the two
  PNGs and the explored map as YAML + PGM (consistent with the summary), then exits.
"""

import json
import math
import os
import shutil
import sys
import threading
import unittest

import cv2
import rosgraph
import rospy
import rostest
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fake_world  # noqa: E402  (test helper next to this file)

from ascc_common.map_io import load_map  # noqa: E402
from ascc_eval.report import coverage  # noqa: E402
from ascc_testing.rosout import RosoutWatcher  # noqa: E402
from ascc_testing.waits import ConditionWaitMixin, wait_for  # noqa: E402
from frontier_detector.rosmsg import grid_from_msg  # noqa: E402

NODE = "frontier_explorer"
MONITOR = "exploration_monitor"
THRESHOLD_WARN_PERIOD_S = 30.0      # frontier_explorer's throttle of the thresholding warning
SUMMARY_KEYS = ("final_coverage", "seen_coverage", "path_m", "time_s", "time_to_coverage_s",
                "time_to_seen_coverage_s", "goals", "bumps", "end_reason", "explorer_status")
MONITOR_CLEARANCE_M = 0.18          # exploration_monitor's ~clearance_m default


def dist(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


class Observed:
    """Everything the test listens to, subscribed once before the first test case (the
    monitor's latched summary disappears when the monitor exits)."""

    def __init__(self):
        self.cond = threading.Condition()
        self.statuses = []
        self.stats = None
        self.map = None
        self.marker_ns = set()
        self.blacklists = []            # the `blacklist` markers' points, one list per plan
        self.summary = None
        self.rosout = RosoutWatcher()
        rospy.Subscriber(NODE + "/status", String, self._status)
        rospy.Subscriber("fake_world/stats", String, self._stats)
        rospy.Subscriber("map", OccupancyGrid, self._map)
        rospy.Subscriber(NODE + "/markers", MarkerArray, self._markers)
        rospy.Subscriber(MONITOR + "/summary", String, self._summary)

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
            self.blacklists.extend([(p.x, p.y) for p in m.points]
                                   for m in msg.markers if m.ns == "blacklist")
            self.cond.notify_all()

    def _summary(self, msg):
        with self.cond:
            self.summary = json.loads(msg.data)
            self.cond.notify_all()


OBS = None


class ExplorerTest(ConditionWaitMixin, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        global OBS
        if OBS is None:
            OBS = Observed()

    def setUp(self):
        self.obs = OBS
        self.cond = OBS.cond
        self.statuses = OBS.statuses            # quoted by ConditionWaitMixin on timeout

    def log(self):
        return self.obs.stats["log"] if self.obs.stats else []

    def test_explores_fake_office(self):
        obs = self.obs
        radius = float(rospy.get_param(NODE + "/blacklist_radius_m"))
        timeout_s = float(rospy.get_param(NODE + "/progress_timeout_s"))
        period_s = float(rospy.get_param(NODE + "/planning_period_s"))
        self.assertEqual(timeout_s, 6.0)        # the .test's override is in effect
        self.wait_for(lambda: obs.statuses and obs.statuses[-1] == "exploring", 30.0,
                      "status exploring")
        (na,), (ns,) = rospy.get_param("fake_world/abort_goals"), \
            rospy.get_param("fake_world/stall_goals")
        self.assertLess(na, ns)
        # Goal na is aborted by the fake move_base: blacklisted, the next goal is elsewhere
        # (same map, same pose: without the blacklist the same point would be best again).
        self.wait_for(lambda: len(self.log()) >= na + 1, 30.0, "the goal after the aborted")
        with self.cond:
            ga, gn = (dict(e) for e in self.log()[na - 1:na + 1])
        self.assertEqual(ga["outcome"], "aborted", ga)
        pa = (ga["x"], ga["y"])
        self.assertGreater(dist(pa, (gn["x"], gn["y"])), radius, (ga, gn))
        # Goal ns stalls (the robot does not move, no new map): given up after the
        # progress timeout, blacklisted and replaced.
        self.wait_for(lambda: len(self.log()) >= ns + 1, timeout_s + 30.0,
                      "the goal after the stalled one")
        with self.cond:
            gs, gn = (dict(e) for e in self.log()[ns - 1:ns + 1])
        self.assertEqual(gs["outcome"], "preempted", gs)
        # The explorer's clock starts at the stalled goal's planning tick, at most one tick
        # before its stamp; the next goal leaves at the first tick after the timeout.
        self.assertGreaterEqual(gn["stamp"] - gs["stamp"], timeout_s - period_s, (gs, gn))
        ps = (gs["x"], gs["y"])
        obs.rosout.wait_for(10.0, "the progress timeout's reason", node="/" + NODE,
                            contains=["goal %d " % (ns + 1),
                                      "no progress towards (%.2f, %.2f)" % ps, "blacklisted"])
        self.assertGreater(dist((gn["x"], gn["y"]), ps), radius, (gs, gn))

        def both_blacklisted():
            return any(any(dist(p, pa) < 1e-3 for p in b) and any(dist(p, ps) < 1e-3 for p in b)
                       for b in obs.blacklists)
        self.wait_for(both_blacklisted, 10.0, "both goals in the blacklist markers")
        self.wait_for(lambda: {"phase1", "phase2", "phase3", "goal"} <= obs.marker_ns,
                      30.0, "markers of every phase")
        rospy.wait_for_service(NODE + "/stop", 10.0)
        # Pause while a goal is being driven (the fake takes up to 2 s per goal).
        self.wait_for(lambda: obs.statuses[-1] == "exploring", 10.0, "exploring")
        self.assertTrue(rospy.ServiceProxy(NODE + "/stop", Trigger)().success)
        self.wait_for(lambda: obs.statuses[-1] == "idle", 10.0, "status idle")
        self.assertTrue(rospy.ServiceProxy(NODE + "/start", Trigger)().success)
        self.wait_for(lambda: obs.statuses[-1] == "done", 150.0, "status done")
        t_done = rospy.get_time()
        with self.cond:
            stats, last_map, statuses = json.loads(json.dumps(obs.stats)), obs.map, \
                list(obs.statuses)
        log = stats["log"]
        self.assertEqual(stats["bad_goals"], 0, stats)
        # return_to_start: the last goal is the start pose, reached; then done.
        self.assertEqual(statuses[-2:], ["returning", "done"], statuses)
        back = log[-1]
        self.assertLess(dist((back["x"], back["y"]), fake_world.START), 1e-3, back)
        self.assertEqual(back["outcome"], "succeeded", back)
        self.assertLess(dist(stats["pose"], fake_world.START), 1e-3, stats["pose"])
        # Blacklisted goals are never sent again (the drive back to the start is no
        # frontier candidate, the blacklist does not apply to it).
        for e in log[na:-1]:
            self.assertGreater(dist((e["x"], e["y"]), pa), radius, (ga, e))
        for e in log[ns:-1]:
            self.assertGreater(dist((e["x"], e["y"]), ps), radius, (gs, e))
        # The fake map holds 5 / 90, not 0 / 100: the explorer thresholded it and said so,
        # with the count, at most once per throttle period.
        warns = obs.rosout.matching(node="/" + NODE, level="warn",
                                    contains=["not in {-1, 0, 100}", "(0 invalid)",
                                              "<= 19 free, >= 65 occupied"])
        self.assertGreaterEqual(len(warns), 1, "no thresholding warning")
        self.assertGreater(int(warns[0].text.split("map has ")[1].split()[0]), 0, warns[0])
        span = t_done - warns[0].stamp_s
        self.assertLessEqual(len(warns), int(span // THRESHOLD_WARN_PERIOD_S) + 1,
                             [(w.stamp_s, w.text) for w in warns])
        grid, info, _ = grid_from_msg(last_map)
        truth, tinfo = fake_world.build_world()
        cov = coverage(grid, info, truth, tinfo, fake_world.START,
                       clearance_m=fake_world.CLEARANCE_M)
        rospy.loginfo("fake office: coverage %.3f after %d goals, %.1f m"
                      % (cov, stats["goals"], stats["path_m"]))
        self.assertGreaterEqual(cov, 0.95)

    def test_monitor_ends_at_max_time_and_writes_files(self):
        obs = self.obs
        max_time_s = float(rospy.get_param(MONITOR + "/max_time_s"))
        out_dir = rospy.get_param(MONITOR + "/output_dir")
        self.addCleanup(shutil.rmtree, out_dir, True)
        self.wait_for(lambda: obs.summary is not None, max_time_s + 60.0, "monitor summary")
        s = obs.summary
        for key in SUMMARY_KEYS:
            self.assertIn(key, s)
        for key in ("time_to_coverage_s", "time_to_seen_coverage_s"):
            self.assertEqual(set(s[key]), {"0.90", "0.95", "0.99"}, s)
        self.assertEqual(s["end_reason"], "max_time", s)
        self.assertNotEqual(s["explorer_status"], "done", s)
        # Its times start at the first true pose, up to one monitor period before its
        # clock (first tick): the run lasted at least max_time_s - one period.
        self.assertGreaterEqual(s["time_s"], max_time_s - 1.0, s)
        self.assertGreater(s["final_coverage"], 0.0, s)
        self.assertGreaterEqual(s["goals"], 1, s)
        self.assertEqual(s["bumps"], 0, s)
        stem = os.path.join(out_dir, "fake_office_max_time")       # the label, file-safe
        with open(stem + ".json", encoding="utf-8") as f:
            written = json.load(f)
        for key in SUMMARY_KEYS:
            self.assertEqual(written[key], s[key], key)
        self.assertEqual(len(written["times_s"]), len(written["coverage"]))
        self.assertAlmostEqual(written["coverage"][-1], s["final_coverage"])
        for png in ("_map.png", "_coverage.png"):
            img = cv2.imread(stem + png)
            self.assertIsNotNone(img, stem + png)
            self.assertGreater(min(img.shape[:2]), 100, (png, img.shape))
        # The explored map (map_server YAML + PGM in the truth frame) is the map the final
        # coverage was measured on.
        grid, info = load_map(stem + "_explored.yaml")
        truth, tinfo = fake_world.build_world()
        self.assertEqual(grid.shape, truth.shape)
        self.assertAlmostEqual(info.origin_x, 0.0)
        self.assertAlmostEqual(info.origin_y, 0.0)
        cov = coverage(grid, info, truth, tinfo, fake_world.START,
                       clearance_m=MONITOR_CLEARANCE_M)
        self.assertAlmostEqual(cov, s["final_coverage"], places=6)
        # ~shutdown_when_finished (default true): the monitor exits.
        master = rosgraph.Master("/rostest_explorer")
        wait_for(lambda: all("/" + MONITOR not in nodes
                             for _, nodes in master.getSystemState()[0]),
                 30.0, "exploration_monitor to exit")


if __name__ == "__main__":
    rospy.init_node("rostest_explorer")
    rostest.rosrun("ascc_eval", "explorer_fake_move_base", ExplorerTest)
