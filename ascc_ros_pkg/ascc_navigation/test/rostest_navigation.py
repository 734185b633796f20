#!/usr/bin/env python3
"""rostest: the amcl and move_base stand-ins drive the simulated office.

1. ``~goals`` (world = map frame) are sent one after the other through the move_base
   action; each must succeed within ``~goal_timeout_s`` (simulated) with the robot never
   closer to an obstacle of the true map than its radius. Every amcl_pose is compared with
   the ground truth: mean position error <= ``~max_mean_error_m``, the 2-sigma ellipse of the
   reported covariance holds the truth in >= ``~min_containment`` of the estimates.
2. Invalid goals are aborted at once with a reason (zero quaternion, off the map, inside a
   wall); a free goal that no path reaches (outside the building's walls) within 10 s.
3. A goal cancelled while driving stops the robot (PREEMPTED, zero cmd_vel).
Bad scans and clock jumps are tested without the simulator (rostest_bad_input.py).
Waits are on conditions with wall-clock timeouts, never fixed sleeps.
"""
import math
import sys
import time
import unittest

import actionlib
import cv2
import numpy as np
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Odometry

from ascc_common.grid import OCCUPIED, map_from_msg
from ascc_common.pose2d import quaternion_from_yaw
from ascc_testing.waits import Latest, pose_of, wait_for

ROBOT_RADIUS_M = 0.165  # the simulated Create (ascc_sim/config/asccbot.yaml)


def goal_msg(x, y, q):
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = "map"
    g.target_pose.header.stamp = rospy.Time.now()
    g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
    o = g.target_pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    return g


class NavigationTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("navigation_test")
        robot = rospy.get_param("~robot", "asccbot")
        cls.goals = [tuple(g) for g in rospy.get_param("~goals")]
        cls.goal_timeout_s = float(rospy.get_param("~goal_timeout_s", 90.0))
        cls.max_mean_error_m = float(rospy.get_param("~max_mean_error_m", 0.10))
        cls.min_containment = float(rospy.get_param("~min_containment", 0.90))
        cls.unreachable = (float(rospy.get_param("~unreachable_goal_x")),
                           float(rospy.get_param("~unreachable_goal_y")))
        cls.truth = Latest("ground_truth/%s/odom" % robot, Odometry, keep_all=True)
        cls.amcl = Latest("amcl_pose", PoseWithCovarianceStamped, keep_all=True)
        cls.truth_map = Latest("ground_truth/map", OccupancyGrid)
        cls.cmd = Latest("cmd_vel", Twist)
        cls.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)

    def setUp(self):
        self.assertTrue(self.client.wait_for_server(rospy.Duration(60.0)),
                        "move_base action server")
        self.truth.wait(90.0)

    def run_goal(self, goal, timeout_s):
        """Sends a goal, returns (final state, status text, wall seconds)."""
        start = time.monotonic()
        self.client.send_goal(goal)
        done = self.client.wait_for_result(rospy.Duration(timeout_s))
        if not done:
            self.client.cancel_goal()
        return self.client.get_state(), self.client.get_goal_status_text(), \
            time.monotonic() - start

    def test_1_goals_reached_localization_honest(self):
        self.amcl.wait(60.0)
        first_truth = len(self.truth.all)
        for x, y, yaw in self.goals:
            state, text, secs = self.run_goal(goal_msg(x, y, quaternion_from_yaw(yaw)),
                                              self.goal_timeout_s)
            rospy.loginfo("navigation rostest: goal (%.2f, %.2f): %s '%s' %.1f s wall",
                          x, y, GoalStatus.to_string(state), text, secs)
            self.assertEqual(state, GoalStatus.SUCCEEDED, "goal (%.2f, %.2f): %s"
                             % (x, y, text))
            tx, ty, _ = pose_of(self.truth.msg)
            self.assertLess(math.hypot(tx - x, ty - y), 0.35, "stopped far from the goal")
        self.check_no_collision(self.truth.all[first_truth:])
        self.check_localization()

    def check_no_collision(self, truths):
        m = self.truth_map.wait(10.0)
        grid, info = map_from_msg(m)
        free = grid != OCCUPIED
        dist = cv2.distanceTransform(free.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        surface = np.maximum(dist - 0.5, 0.0) * info.resolution  # [m] to obstacle surfaces
        xy = np.array([pose_of(t)[:2] for t in truths])
        ix, iy = info.world_to_cell(xy[:, 0], xy[:, 1])
        clearance = surface[iy, ix].min()
        rospy.loginfo("navigation rostest: smallest clearance %.3f m", clearance)
        self.assertGreater(clearance, ROBOT_RADIUS_M - 0.5 * info.resolution)

    def check_localization(self):
        stamps = np.array([t.header.stamp.to_sec() for t in self.truth.all])
        truth_xy = np.array([pose_of(t)[:2] for t in self.truth.all])
        errors, inside = [], []
        for est in self.amcl.all[3:]:  # the first updates converge from the initial spread
            k = int(np.argmin(np.abs(stamps - est.header.stamp.to_sec())))
            if abs(stamps[k] - est.header.stamp.to_sec()) > 0.06:
                continue  # no ground truth close enough in time
            p = est.pose.pose.position
            d = truth_xy[k] - [p.x, p.y]
            cov = np.asarray(est.pose.covariance).reshape(6, 6)[:2, :2]
            errors.append(float(np.hypot(*d)))
            inside.append(float(d @ np.linalg.solve(cov, d)) <= 4.0)
        rospy.loginfo("navigation rostest: %d estimates, mean error %.3f m, max %.3f m, "
                      "2-sigma containment %.1f %%", len(errors), np.mean(errors),
                      np.max(errors), 100.0 * np.mean(inside))
        self.assertGreater(len(errors), 50)
        self.assertLess(np.mean(errors), self.max_mean_error_m)
        self.assertGreaterEqual(np.mean(inside), self.min_containment)

    def test_2_invalid_and_unreachable_goals_aborted(self):
        cases = [((5.0, 5.5), (0.0, 0.0, 0.0, 0.0), "quaternion", 3.0),
                 ((40.0, 5.5), (0.0, 0.0, 0.0, 1.0), "outside the map", 3.0),
                 ((9.45, 8.0), (0.0, 0.0, 0.0, 1.0), "obstacle", 3.0),  # in a wall
                 (self.unreachable, (0.0, 0.0, 0.0, 1.0), "not reachable", 10.0)]
        for (x, y), q, words, limit_s in cases:
            t0 = rospy.get_time()
            state, text, _ = self.run_goal(goal_msg(x, y, q), 60.0)
            sim_s = rospy.get_time() - t0
            rospy.loginfo("navigation rostest: goal (%.2f, %.2f): %s '%s' after %.1f s",
                          x, y, GoalStatus.to_string(state), text, sim_s)
            self.assertEqual(state, GoalStatus.ABORTED, text)
            self.assertIn(words, text)
            self.assertLess(sim_s, limit_s)

    def test_3_cancel_stops_the_robot(self):
        self.client.send_goal(goal_msg(6.9, 5.5, (0.0, 0.0, 0.0, 1.0)))
        wait_for(lambda: self.cmd.msg is not None and self.cmd.msg.linear.x > 0.1, 60.0,
                 "the robot to drive")
        self.client.cancel_goal()
        wait_for(lambda: self.client.get_state() == GoalStatus.PREEMPTED, 10.0, "PREEMPTED")
        wait_for(lambda: self.cmd.msg.linear.x == 0.0 and self.cmd.msg.angular.z == 0.0,
                 5.0, "a zero cmd_vel")
        t_stop = rospy.get_time()
        wait_for(lambda: rospy.get_time() > t_stop + 1.0, 10.0, "1 s of simulated time")
        twist = self.truth.msg.twist.twist
        self.assertLess(abs(twist.linear.x), 0.02)
        self.assertLess(abs(twist.angular.z), 0.05)


if __name__ == "__main__":
    rostest.rosrun("ascc_navigation", "navigation_office", NavigationTest, sys.argv)
