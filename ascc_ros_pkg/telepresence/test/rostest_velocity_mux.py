#!/usr/bin/env python3
"""rostest: the velocity_mux node on real topics (velocity_mux.test).

Publishers stand in for the teleop, the gesture control and the navigator; each sends a
command whose linear.x names it (teleop 0.1, gesture 0.2, navigation 0.05 m/s) at 10 Hz
of wall time while its ``on`` flag is set. The node runs with config/velocity_mux.yaml
(timeouts 0.5 s; gesture 200 > teleop 100 > navigation 10; lock e_stop 255)."""
import math
import sys
import threading
import time
import unittest

import rospkg
import rospy
import rostest
import yaml
from geometry_msgs.msg import Twist
from std_msgs.msg import Bool, String

from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import Latest, wait_for

NODE = "/velocity_mux"
SPEED = {"teleop": 0.1, "gesture": 0.2, "navigation": 0.05}  # [m/s] each input's mark


class Source:
    """Publishes its mark on ``topic`` at 10 Hz while ``on``; ``nan`` sends NaN instead."""

    def __init__(self, name, topic):
        self.name, self.on, self.nan = name, False, False
        self.pub = rospy.Publisher(topic, Twist, queue_size=1)
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        while not rospy.core.is_shutdown_requested():  # publishers close before is_shutdown()
            if self.on:
                cmd = Twist()
                cmd.linear.x = float("nan") if self.nan else SPEED[self.name]
                self.pub.publish(cmd)
            time.sleep(0.1)


class VelocityMuxTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rostest_velocity_mux")
        cls.rosout = RosoutWatcher()
        cls.out = Latest("cmd_vel", Twist, keep_all=True)
        cls.active = Latest(NODE + "/active", String)
        cls.sources = {n: Source(n, "%s/cmd_vel" % ("nav" if n == "navigation" else n))
                       for n in SPEED}
        cls.e_stop = rospy.Publisher("e_stop", Bool, queue_size=1, latch=True)
        for s in cls.sources.values():
            wait_for(lambda s=s: s.pub.get_num_connections() > 0, 30.0,
                     "velocity_mux subscribed to %s" % s.pub.resolved_name)
        cls.active.wait(30.0)

    def setUp(self):
        for s in self.sources.values():
            s.on = s.nan = False
        self.e_stop.publish(Bool(data=False))
        wait_for(lambda: self.active.msg.data == "idle", 5.0, "the mux idle")

    def wait_active(self, name, timeout_s=5.0):
        wait_for(lambda: self.active.msg.data == name, timeout_s, "active input %s (is %s)"
                 % (name, self.active.msg.data))

    def wait_zero(self):
        wait_for(lambda: self.out.msg is not None and self.out.msg.linear.x == 0.0, 5.0,
                 "a zero command on cmd_vel")

    def outputs_since(self, n):
        return [m.linear.x for m in self.out.all[n:]]

    def test_priority_handover_and_stop(self):
        self.sources["teleop"].on = True
        self.wait_active("teleop")
        n = self.out.count
        self.out.wait(count=n + 3)
        self.assertEqual(set(self.outputs_since(n)), {SPEED["teleop"]})

        self.sources["navigation"].on = True  # lower priority: never forwarded
        self.sources["gesture"].on = True  # higher: takes over
        self.wait_active("gesture")
        n = self.out.count
        self.out.wait(count=n + 5)
        self.assertEqual(set(self.outputs_since(n)), {SPEED["gesture"]})

        self.sources["gesture"].on = False  # stale after 0.5 s: teleop again
        t0 = time.monotonic()
        self.wait_active("teleop")
        self.assertLess(time.monotonic() - t0, 2.0)
        n = self.out.count
        self.out.wait(count=n + 3)
        self.assertEqual(set(self.outputs_since(n)), {SPEED["teleop"]})

        self.sources["teleop"].on = False
        self.wait_active("navigation")
        self.sources["navigation"].on = False
        self.wait_active("idle")
        self.wait_zero()  # one zero: the robot stops
        n = self.out.count
        time.sleep(1.0)  # nothing more once idle
        self.assertEqual(self.out.count, n)

    def test_e_stop_lock_blocks_everything_until_released(self):
        self.sources["gesture"].on = True
        self.wait_active("gesture")
        self.e_stop.publish(Bool(data=True))
        self.wait_active("idle")
        self.wait_zero()
        n = self.out.count
        time.sleep(1.0)  # gesture keeps sending: nothing passes the lock
        self.assertEqual(self.outputs_since(n), [])
        self.e_stop.publish(Bool(data=False))
        self.wait_active("gesture")
        self.out.wait(count=n + 2)
        self.assertEqual(set(self.outputs_since(n)), {SPEED["gesture"]})

    def test_nan_command_dropped_with_a_warning_and_the_robot_stops(self):
        self.sources["teleop"].on = True
        self.wait_active("teleop")
        start = time.monotonic()
        self.sources["teleop"].nan = True
        self.rosout.wait_for(10.0, "NaN warning", node=NODE, level="warn",
                             contains=("teleop", "nan"), since_wall_s=start)
        self.wait_active("idle")  # NaN commands are dropped: the input goes stale
        self.wait_zero()
        self.assertTrue(all(math.isfinite(v) for v in self.outputs_since(0)))

    def test_node_runs_with_the_packages_config(self):
        path = rospkg.RosPack().get_path("telepresence") + "/config/velocity_mux.yaml"
        with open(path) as f:
            cfg = yaml.safe_load(f)
        self.assertEqual(rospy.get_param(NODE + "/topics"), cfg["topics"])
        self.assertEqual(rospy.get_param(NODE + "/locks"), cfg["locks"])


if __name__ == "__main__":
    rostest.rosrun("telepresence", "velocity_mux", VelocityMuxTest, sys.argv)
