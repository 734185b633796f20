#!/usr/bin/env python3
"""rostest: the virtual_create node on its own, talked to over its pty with pyserial.

Checks the announced port, Drive Direct -> ~wheel_speeds and ~ground_truth, the test
services (set_bump, inject_garbage, close_link with the reopen at the same path, state,
power_cycle).
"""
import json
import math
import os
import threading
import time
import unittest

import rospy
import rostest
import serial
from geometry_msgs.msg import Vector3Stamped
from nav_msgs.msg import Odometry
from std_srvs.srv import SetBool, Trigger

from irobot_create_2_1 import protocol as oi

NODE = "virtual_create"


class Latest:
    def __init__(self, topic, cls):
        self.msg = None
        self.cond = threading.Condition()
        rospy.Subscriber(topic, cls, self._cb, queue_size=10)

    def _cb(self, msg):
        with self.cond:
            self.msg = msg
            self.cond.notify_all()

    def wait_for(self, predicate, timeout_s, what):
        deadline = time.time() + timeout_s
        with self.cond:
            while self.msg is None or not predicate(self.msg):
                left = deadline - time.time()
                if left <= 0 or rospy.is_shutdown():
                    raise AssertionError("timed out waiting for %s (last: %s)"
                                         % (what, self.msg))
                self.cond.wait(min(left, 0.1))
            return self.msg


def wait_until(predicate, timeout_s, what):
    deadline = time.time() + timeout_s
    while not predicate():
        if time.time() > deadline:
            raise AssertionError("timed out waiting for %s" % what)
        time.sleep(0.01)


def read_exactly(port, n, timeout_s=5.0):
    got = bytearray()
    wait_until(lambda: got.extend(port.read(n - len(got))) or len(got) >= n, timeout_s,
               "%d bytes from the virtual Create" % n)
    return bytes(got)


class VirtualCreateNodeTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("virtual_create_test")
        cls.truth = Latest(NODE + "/ground_truth", Odometry)
        cls.wheels = Latest(NODE + "/wheel_speeds", Vector3Stamped)
        wait_until(lambda: rospy.has_param(NODE + "/port"), 20.0, "~port")
        cls.path = rospy.get_param(NODE + "/port")
        rospy.wait_for_service(NODE + "/close_link", 20.0)

    def open_port(self):
        port = serial.Serial(self.path, 57600, timeout=0.05)
        port.write(oi.start() + oi.safe())
        return port

    def test_a_drive_moves_ground_truth(self):
        self.assertEqual(self.path, rospy.get_param("~expected_link"))
        with self.open_port() as port:
            truth0 = self.truth.wait_for(lambda m: True, 10.0, "ground truth")
            port.write(oi.drive_direct(-100, 100))             # spin counter-clockwise
            self.wheels.wait_for(lambda m: abs(m.vector.x + 0.1) < 1e-9
                                 and abs(m.vector.y - 0.1) < 1e-9, 5.0, "spin speeds")
            q0 = truth0.pose.pose.orientation
            yaw0 = 2.0 * math.atan2(q0.z, q0.w)

            def turned(m):
                q = m.pose.pose.orientation
                yaw = 2.0 * math.atan2(q.z, q.w)
                return math.sin(yaw - yaw0) > 0.05 and m.twist.twist.angular.z > 0.5
            msg = self.truth.wait_for(turned, 5.0, "a counter-clockwise turn")
            self.assertEqual(msg.header.frame_id, "virtual_world")
            self.assertEqual(msg.child_frame_id, "base_link")
            port.write(oi.drive_direct(0, 0))
            self.wheels.wait_for(lambda m: m.vector.x == 0 and m.vector.y == 0, 5.0, "stop")

    def test_b_set_bump_and_garbage(self):
        set_bump = rospy.ServiceProxy(NODE + "/set_bump", SetBool)
        garbage = rospy.ServiceProxy(NODE + "/inject_garbage", Trigger)
        with self.open_port() as port:
            try:
                self.assertTrue(set_bump(True).success)
                port.reset_input_buffer()
                port.write(oi.sensors(7))
                self.assertEqual(read_exactly(port, 1)[0] & 0x03, 0x03)
            finally:
                set_bump(False)
            port.write(oi.sensors(7))
            self.assertEqual(read_exactly(port, 1)[0] & 0x03, 0x00)
            self.assertTrue(garbage().success)
            self.assertEqual(len(read_exactly(port, 64)), 64)

    def test_c_close_link_reopens_at_the_same_path(self):
        close = rospy.ServiceProxy(NODE + "/close_link", Trigger)
        port = self.open_port()
        try:
            self.assertTrue(close().success)

            def hung_up():
                try:
                    port.write(oi.sensors(35))
                    port.read(1)
                    return False
                except serial.SerialException:
                    return True
            wait_until(hung_up, 5.0, "the old port to hang up")
        finally:
            port.close()
        wait_until(lambda: os.path.exists(self.path), 10.0, "the link to come back")
        with self.open_port() as port2:
            port2.reset_input_buffer()
            port2.write(oi.sensors(35))
            self.assertEqual(read_exactly(port2, 1), bytes([2]))

    def test_d_state_and_power_cycle(self):
        state = rospy.ServiceProxy(NODE + "/state", Trigger)
        power_cycle = rospy.ServiceProxy(NODE + "/power_cycle", Trigger)
        rospy.wait_for_service(NODE + "/power_cycle", 10.0)
        wait_until(lambda: os.path.exists(self.path), 10.0, "the link")
        with self.open_port() as port:
            port.write(oi.leds(True, False, 7, 9) + oi.song(3, [60], [8]) + oi.play(3)
                       + oi.stream([7]) + oi.drive_direct(50, -50))
            wait_until(lambda: json.loads(state().message)["streaming"], 5.0, "stream on")
            s = json.loads(state().message)
            self.assertEqual(s["mode"], "safe")
            self.assertEqual(s["leds"], {"play": True, "advance": False, "power_color": 7,
                                         "power_intensity": 9})
            self.assertEqual((s["songs"], s["songs_played"]), ({"3": [[60, 8]]}, [3]))
            self.assertEqual(s["wheel_speeds_mps"], [0.05, -0.05])
            self.assertEqual(s["stream_ids"], [7])
            self.assertTrue(power_cycle().success)
            s = json.loads(state().message)
            self.assertEqual((s["mode"], s["streaming"], s["wheel_speeds_mps"]),
                             ("off", False, [0.0, 0.0]))
            port.reset_input_buffer()
            port.write(oi.sensors(35))                       # off: only Start is heard
            self.assertEqual(port.read(1), b"")
            port.write(oi.start() + oi.sensors(35))
            self.assertEqual(read_exactly(port, 1), bytes([1]))  # passive


if __name__ == "__main__":
    rostest.rosrun("irobot_create_2_1", "virtual_create_node", VirtualCreateNodeTest)
