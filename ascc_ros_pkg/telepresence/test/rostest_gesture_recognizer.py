#!/usr/bin/env python3
"""rostest: gesture_recognizer on skeleton_sim's TF, then on bad skeletons the test
publishes itself (gesture_recognizer.test)."""
import json
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped, Vector3Stamped
from std_msgs.msg import String

from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import Latest, wait_for
from telepresence.msg import Gesture
from telepresence.skeleton_sim import SensorParams, SkeletonSource, script_of

NODE = "/gesture_recognizer"
EPISODES = 15  # in skeleton_sim's ~episodes (gesture_recognizer.test)
LATE_S = 0.5  # the latency goal after a gesture ends [s]
CLEAN = SensorParams(noise_m=0.005, drop_prob=0.0, missing_joint_prob=0.0, lost_per_min=0.0)


class GestureRecognizerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rostest_gesture_recognizer")
        cls.rosout = RosoutWatcher()
        cls.gestures = Latest("gesture", Gesture, keep_all=True)
        cls.truth = Latest("ground_truth/gestures", String)
        cls.bad_angles = Latest("bad_templates/angles", Vector3Stamped)
        cls.tf = tf2_ros.TransformBroadcaster()
        cls.lock = threading.Lock()

    def wait_script_end(self):
        """The script's episodes (ground truth), once skeleton_sim has played it."""
        self.truth.wait(30.0)
        episodes = json.loads(self.truth.msg.data)["episodes"]
        self.assertEqual(len(episodes), EPISODES)
        wait_for(lambda: rospy.get_time() > episodes[-1]["end"] + 1.0, 120.0,
                 "the end of skeleton_sim's script")
        return episodes

    def publish_frames(self, source, user_map=lambda t, u: u, joints_edit=None):
        """Publish the simulated tracker's frames in real time (30 Hz), user ids mapped
        through ``user_map(t, user)``, joints changed by ``joints_edit(joints)``."""
        t0 = time.monotonic()
        for t in np.arange(0.0, source.end_s, 1.0 / 30.0):
            f = source.frame(float(t))
            time.sleep(max(0.0, t0 + t - time.monotonic()))
            if f is None:
                continue
            joints = dict(f.joints)
            if joints_edit is not None:
                joints_edit(joints)
            now = rospy.Time.now()
            msgs = []
            for name, xyz in joints.items():
                tr = TransformStamped()
                tr.header.stamp, tr.header.frame_id = now, "openni_depth_frame"
                tr.child_frame_id = "%s_%d" % (name, user_map(t, f.user))
                tr.transform.translation.x, tr.transform.translation.y, \
                    tr.transform.translation.z = (float(v) for v in xyz)
                tr.transform.rotation.w = 1.0
                msgs.append(tr)
            self.tf.sendTransform(msgs)

    def test_1_simulated_gestures_recognized_and_idle_motion_not(self):
        episodes = self.wait_script_end()
        got = [(g.header.stamp.to_sec(), g.command, g.error_rad2) for g in self.gestures.all]
        for e in episodes:
            inside = [g for g in got if e["start"] <= g[0] < e["end"]]
            if e["kind"] in ("come_close", "go_away"):
                right = [g for g in inside if g[1] == e["kind"]
                         and g[0] <= e["motion_end"] + LATE_S]
                self.assertTrue(right, "%s at %.1f-%.1f not recognized; commands %s"
                                % (e["kind"], e["start"], e["motion_end"], got))
                self.assertEqual([g for g in inside if g[1] != e["kind"]], [])
            elif e["kind"] != "rest":
                self.assertEqual(inside, [], "command during %s" % e["kind"])
        for g in self.gestures.all:
            self.assertLess(g.error_rad2, g.threshold_rad2)
            self.assertEqual(g.header.frame_id, "openni_depth_frame")

    def test_2_bad_skeletons_warned_and_no_command(self):
        self.wait_script_end()
        src = SkeletonSource(script_of(["rest", "come_close", "rest"], 11), CLEAN, 11)
        g = src.script[1]
        # another user id every 0.8 s of the gesture: no user alone performs a whole one
        # (0.8 s is less than a cycle and than the shortest window, 0.8 x 1.8 s)

        def users(t, _u):
            return 70 + max(0, int((t - g.t0) // 0.8))

        def nan_hand(joints):
            joints["right_hand"] = (float("nan"), 0.0, 1.0)

        def no_elbow(joints):
            joints.pop("right_elbow")

        for name, kwargs, words in [
                ("NaN", {"joints_edit": nan_hand}, ("user 60", "non-finite", "right_hand")),
                ("missing", {"joints_edit": no_elbow}, ("user 61", "missing", "right_elbow")),
                ("user change", {"user_map": users},
                 ("changed from 70 to 71",))]:
            if name == "NaN":
                kwargs["user_map"] = lambda t, u: 60
            elif name == "missing":
                kwargs["user_map"] = lambda t, u: 61
            start_wall = time.monotonic()
            n = self.gestures.count
            self.publish_frames(src, **kwargs)
            self.rosout.wait_for(5.0, name + " warning", node=NODE, level="warn",
                                 contains=words, since_wall_s=start_wall)
            time.sleep(0.3)  # a late command would come now
            self.assertEqual(self.gestures.all[n:], [], "command from %s skeletons" % name)

        # the same gesture, clean and of one user: recognized (the data, not the node, was bad)
        n = self.gestures.count
        self.publish_frames(src, user_map=lambda t, u: 80)
        self.gestures.wait(5.0, count=n + 1)
        self.assertEqual(self.gestures.msg.command, "come_close")
        self.assertEqual(self.gestures.msg.user, 80)

    def test_3_missing_and_malformed_templates_named_node_keeps_running(self):
        self.rosout.wait_for(20.0, "missing template", node="/bad_templates", level="warn",
                             contains=("/nonexistent/come_close.yaml", "come_close"))
        self.rosout.wait_for(20.0, "malformed template", node="/bad_templates",
                             level="warn", contains=("malformed_template.yaml", "yaw_rad"))
        self.rosout.wait_for(20.0, "no usable template", node="/bad_templates",
                             level="error", contains="no usable template")
        self.bad_angles.wait(60.0)


if __name__ == "__main__":
    rostest.rosrun("telepresence", "gesture_recognizer", GestureRecognizerTest, sys.argv)
