#!/usr/bin/env python3
"""rostest: target_estimator's wiring on hand-computed numbers and both nodes' bad input.

target_estimator (robotA): a pose (1, 2, 90 deg) with covariance and a cone at bearing
-90 deg, laser range 1.9 m (+ 0.1 m offset) give the estimate (3, 2) in map with the
first-order covariance; a pose in the wrong frame, a NaN pose and a Target in the wrong
frame are dropped with a warning naming the robot. fusion (robotA, robotB): robotB's NaN
covariance, zero variance, wrong frame and future stamps are refused with a warning
naming robotB, robotA alone is fused meanwhile, and no fused value is ever NaN; the
warnings are throttled. gated/fusion (robotA, robotC, robotD, gate_chi2 13.8): robotD
1.4 m off the two others (as a robot whose amcl converged in the wrong place) is left
out, its status and a warning name it, and A and C are fused.
"""
import json
import math
import sys
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseWithCovarianceStamped
from std_msgs.msg import String

from ascc_common.pose2d import quaternion_from_yaw
from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import Latest, wait_for
from target_follower.msg import Detection, Target


def pose_msg(frame, x, y, yaw=0.0, cov=(0.01, 0.04, 0.0025), stamp=None):
    m = PoseWithCovarianceStamped()
    m.header.frame_id = frame
    m.header.stamp = stamp or rospy.Time.now()
    m.pose.pose.position.x, m.pose.pose.position.y = x, y
    q = quaternion_from_yaw(yaw)
    o = m.pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    c = [0.0] * 36
    c[0], c[7], c[35] = cov
    m.pose.covariance = c
    return m


def target_msg(frame, bearing, rng):
    t = Target()
    t.header.frame_id = frame
    t.header.stamp = rospy.Time.now()
    d = Detection()
    d.kind, d.bearing_rad, d.range_m, d.range_source = "cone", bearing, rng, \
        Detection.RANGE_LASER
    t.detections = [d]
    return t


class BadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("colloc_bad_input_test")
        cls.log = RosoutWatcher()
        cls.amcl = rospy.Publisher("robotA/amcl_pose", PoseWithCovarianceStamped,
                                   queue_size=5, latch=True)
        cls.target = rospy.Publisher("robotA/target", Target, queue_size=5)
        cls.est_a = rospy.Publisher("robotA/target_estimate", PoseWithCovarianceStamped,
                                    queue_size=5)
        cls.est_b = rospy.Publisher("robotB/target_estimate", PoseWithCovarianceStamped,
                                    queue_size=5)
        cls.est_c = rospy.Publisher("robotC/target_estimate", PoseWithCovarianceStamped,
                                    queue_size=5)
        cls.est_d = rospy.Publisher("robotD/target_estimate", PoseWithCovarianceStamped,
                                    queue_size=5)
        cls.gated_status = Latest("gated/fused_target/status", String, keep_all=True)
        cls.gated = Latest("gated/fused_target", PoseWithCovarianceStamped)
        cls.estimate = Latest("robotA/target_estimate", PoseWithCovarianceStamped)
        cls.status = Latest("fused_target/status", String, keep_all=True)
        cls.fused = Latest("fused_target", PoseWithCovarianceStamped, keep_all=True)
        cls.log.wait_for_connection()
        for pub in (cls.amcl, cls.target, cls.est_a, cls.est_b, cls.est_c,
                    cls.est_d):
            wait_for(lambda p=pub: p.get_num_connections() > 0, 30.0, pub.resolved_name)

    def send_target_until(self, condition, what):
        deadline = time.monotonic() + 20.0
        while not condition():
            self.assertLess(time.monotonic(), deadline, what)
            self.target.publish(target_msg("robotA/base_link", -math.pi / 2, 1.9))
            time.sleep(0.1)

    def test_1_estimator_on_hand_computed_numbers(self):
        self.amcl.publish(pose_msg("map", 1.0, 2.0, math.pi / 2))
        self.send_target_until(lambda: self.estimate.count > 0, "an estimate")
        m = self.estimate.msg
        self.assertEqual(m.header.frame_id, "map")
        self.assertAlmostEqual(m.pose.pose.position.x, 3.0, places=6)
        self.assertAlmostEqual(m.pose.pose.position.y, 2.0, places=6)
        c = m.pose.covariance  # 0.01 + 0.03^2; 0.04 + 2^2 (0.0025 + 0.02^2)
        self.assertAlmostEqual(c[0], 0.0109, places=9)
        self.assertAlmostEqual(c[7], 0.0516, places=9)

    def test_2_estimator_bad_input(self):
        node = "/robotA/target_estimator"
        self.amcl.publish(pose_msg("robotA/odom", 1.0, 2.0))
        self.log.wait_for(10.0, node=node, level="warn", contains=("robotA", "frame"))
        self.amcl.publish(pose_msg("map", float("nan"), 2.0))
        self.log.wait_for(10.0, node=node, level="warn", contains=("robotA", "non-finite"))
        self.target.publish(target_msg("robotB/base_link", 0.0, 1.0))
        self.log.wait_for(10.0, node=node, level="warn",
                          contains=("robotA", "target in frame"))
        # the good pose (bad ones were dropped): still (3, 2)
        n = self.estimate.count
        self.send_target_until(lambda: self.estimate.count > n, "an estimate after")
        self.assertAlmostEqual(self.estimate.msg.pose.pose.position.x, 3.0, places=6)

    def feed(self, bad, contains, seconds=2.0):
        t0 = time.monotonic()
        n0 = self.status.count
        while time.monotonic() - t0 < seconds:
            self.est_a.publish(pose_msg("map", 1.0, 1.0, cov=(0.01, 0.01, 1e6)))
            self.est_b.publish(bad())
            time.sleep(0.1)
        self.log.wait_for(10.0, node="/fusion", level="warn", contains=("robotB",) + contains)
        robots = [json.loads(m.data)["robots"] for m in self.status.all[n0 + 3:]]
        self.assertTrue(robots and all(r == ["robotA"] for r in robots), robots)

    def test_3_fusion_refuses_robotB_and_fuses_robotA(self):
        self.feed(lambda: pose_msg("map", 2.0, 2.0, cov=(float("nan"), 0.01, 1e6)),
                  ("finite",))
        self.feed(lambda: pose_msg("map", 2.0, 2.0, cov=(0.0, 0.01, 1e6)), ("positive",))
        self.feed(lambda: pose_msg("robotB/odom", 2.0, 2.0), ("frame",))
        self.feed(lambda: pose_msg("map", 2.0, 2.0, stamp=rospy.Time.now()
                                   + rospy.Duration(5.0)), ("clock offset",))
        for m in self.fused.all:
            p = m.pose.pose.position
            self.assertTrue(math.isfinite(p.x) and math.isfinite(p.y))
            self.assertTrue(all(math.isfinite(c) for c in m.pose.covariance))
        # throttled: robotB's NaN warning at most once per 5 s (2 s of bad input)
        nan_warnings = self.log.matching(node="/fusion", level="warn",
                                         contains=("robotB", "finite"))
        self.assertEqual(len(nan_warnings), 1)

    def test_4_gate_leaves_out_a_robot_far_off(self):
        cov = (4e-4, 4e-4, 1e6)  # 2 cm standard deviations, as amcl's refined clouds
        n0 = self.gated_status.count
        t0 = time.monotonic()
        while time.monotonic() - t0 < 2.0:
            self.est_a.publish(pose_msg("map", 1.0, 1.0, cov=cov))
            self.est_c.publish(pose_msg("map", 1.03, 1.0, cov=cov))
            self.est_d.publish(pose_msg("map", 2.4, 1.0, cov=cov))
            time.sleep(0.1)
        # taken now, within the window (later the estimates go stale)
        statuses = [json.loads(m.data) for m in self.gated_status.all[n0 + 3:]]
        fused = self.gated.msg
        self.log.wait_for(10.0, node="/gated/fusion", level="warn",
                          contains=("robotD", "inconsistent"))
        self.assertTrue(statuses)
        for s in statuses:
            self.assertEqual(s["robots"], ["robotA", "robotC"], s)
            self.assertIn("inconsistent", s["left_out"]["robotD"])
            self.assertNotIn("robotA", s["left_out"])
            self.assertNotIn("robotC", s["left_out"])
        p = fused.pose.pose.position
        self.assertAlmostEqual(p.x, 1.015, places=6)
        self.assertAlmostEqual(p.y, 1.0, places=6)

if __name__ == "__main__":
    rostest.rosrun("colloc_fusion", "colloc_bad_input", BadInputTest, sys.argv)
