#!/usr/bin/env python3
"""rostest: the ASCCbot follows a walking person in the simulated office
(follow_office_sim.test, thesis 5.3).

The whole pipeline runs as on a robot: the simulated Q24 serves its panorama as MJPEG over
HTTP, the real driver q24_camera reads it, target_detector finds the orange shirt (range
from the laser), target_follower drives the real Create driver. follow_monitor measures the
run on the simulator's ground truth. Waits (wall-clock timeout, no fixed sleep) for its
latched summary and checks what the issue asks of this test: the person's route ended (not
the time limit) after >= 30 m, no bumper hit, the robot ended within the distance band of
the set point, and the follower was following again after every corner. The distance
error on straight segments (the issue's +-0.3 m goal) is measured and logged here and
reported over 5 seeds by `scripts/bench_follow.py` (docs/results/target_follower.md).
"""

import json
import unittest

import rospy
import rostest
from std_msgs.msg import String

from ascc_testing.waits import Latest

WALL_TIMEOUT_S = 600.0


class FollowSimTest(unittest.TestCase):
    def test_person_followed_through_the_office(self):
        summary = Latest("follow_monitor/summary", String).wait(WALL_TIMEOUT_S)
        s = json.loads(summary.data)
        rospy.loginfo("follow run: %s" % json.dumps(s))
        print("follow run: %s" % json.dumps(s))
        band = s["band_m"]
        self.assertEqual(s["end_reason"], "route_done", s)
        self.assertEqual(s["bumps"], 0, s)
        self.assertGreaterEqual(s["person_path_m"], 30.0, s)
        self.assertLessEqual(abs(s["distance_final_m"] - s["set_distance_m"]), band, s)
        self.assertGreater(len(s["corners"]), 0, s)
        self.assertEqual(s["corners_reacquired"], len(s["corners"]), s)
        self.assertGreater(s["straight_samples"], 100, s)


if __name__ == "__main__":
    rospy.init_node("rostest_follow_sim")
    rostest.rosrun("ascc_eval", "follow_office_sim", FollowSimTest)
