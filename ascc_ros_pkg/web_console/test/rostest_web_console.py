#!/usr/bin/env python3
"""rostest: the web_console node on real topics and real WebSockets (console_node.test).

The node runs with token ``tok`` behind the velocity mux; the test plays the camera
(CompressedImage of random bytes at 20 Hz while ``camera_on``), the map (latched), and
pages (web_console.client.ConsoleClient, a raw socket that never reads)."""
import base64
import json
import math
import os
import socket
import sys
import threading
import time
import unittest
from xmlrpc.client import ServerProxy

import cv2
import numpy as np
import rosgraph
import rospy
import rostest
from geometry_msgs.msg import Twist
from move_base_msgs.msg import MoveBaseActionGoal
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import CompressedImage
from std_msgs.msg import Bool

from ascc_testing.waits import Recorder, wait_for
from web_console.client import ConsoleClient

NODE = "/web_console"
TOKEN = "tok"
FRAME_BYTES = 300000  # a big frame fills a never-reading page's socket within seconds


def value_within(fn, timeout_s, what):
    """The first truthy ``fn()`` within ``timeout_s`` (AssertionError naming ``what``)."""
    box = []
    wait_for(lambda: box.append(fn()) or box[-1], timeout_s, what)
    return box[-1]


class Camera:
    """Publishes frames of random bytes (format jpeg) at 20 Hz while ``on``; remembers
    them by stamp."""

    def __init__(self):
        self.pub = rospy.Publisher("camera/image_raw/compressed", CompressedImage,
                                   queue_size=1)
        self.on, self.sent, self.lock = False, {}, threading.Lock()
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        while not rospy.core.is_shutdown_requested():  # publishers close before is_shutdown()
            if self.on:
                msg = CompressedImage(format="bgr8; jpeg compressed bgr8",
                                      data=os.urandom(FRAME_BYTES))
                msg.header.stamp = rospy.Time.now()
                msg.header.frame_id = "camera"
                with self.lock:
                    self.sent[round(msg.header.stamp.to_sec(), 6)] = msg.data
                self.pub.publish(msg)
            time.sleep(0.05)


def rss_mb(node):
    """Resident memory [MB] of the ROS node ``node`` (its pid through its XML-RPC API)."""
    uri = rosgraph.Master("/rostest_web_console").lookupNode(node)
    _, _, pid = ServerProxy(uri).getPid("/rostest_web_console")
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise AssertionError("no VmRSS of %s" % node)


def never_reading_page(port):
    """A WebSocket handshake on a raw socket, then nothing is ever read."""
    s = socket.create_connection(("127.0.0.1", port))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(("GET /ws HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\n"
               "Connection: Upgrade\r\nSec-WebSocket-Key: %s\r\n"
               "Sec-WebSocket-Version: 13\r\n\r\n" % (port, key)).encode())
    return s


class WebConsoleTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rostest_web_console")
        cls.teleop = Recorder("teleop/cmd_vel", Twist)
        cls.out = Recorder("cmd_vel", Twist)
        cls.estop = Recorder("e_stop", Bool)
        cls.goals = Recorder("move_base/goal", MoveBaseActionGoal)
        cls.camera = Camera()
        cls.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        grid = OccupancyGrid()
        grid.header.frame_id = "map"
        grid.info.resolution, grid.info.width, grid.info.height = 0.1, 100, 50
        grid.info.origin.position.x, grid.info.origin.position.y = -2.0, -1.0
        grid.info.origin.orientation.w = 1.0
        grid.data = [0] * 5000
        cls.map_pub.publish(grid)
        cls.port = value_within(lambda: rospy.get_param(NODE + "/bound_port", None), 30.0,
                            "web_console bound its port")
        cls.url = "ws://127.0.0.1:%d/ws" % cls.port
        wait_for(lambda: cls.camera.pub.get_num_connections() > 0, 30.0,
                 "web_console subscribed to the camera")

    def page(self, auth=True):
        c = ConsoleClient(self.url)
        self.addCleanup(c.close)
        self.assertTrue(c.wait(lambda c: c.messages("hello"), 5.0), "no hello")
        if auth:
            c.send({"type": "auth", "token": TOKEN})
            ok = c.wait(lambda c: c.messages("auth"), 5.0)
            self.assertTrue(ok and ok[-1]["ok"], "token refused: %s" % ok)
        return c

    def drive_for(self, page, seconds, linear=0.2, angular=0.0):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            page.send({"type": "drive", "linear": linear, "angular": angular})
            time.sleep(0.05)
        return time.monotonic()

    def zero_after(self, t_wall, timeout_s=2.0):
        """Wall seconds from ``t_wall`` to the first zero on teleop/cmd_vel after it."""
        def first_zero():
            for t, msg in self.teleop.since(t_wall):
                if msg.linear.x == 0.0 and msg.angular.z == 0.0:
                    return max(t - t_wall, 1e-9)  # truthy even when immediate
            return None
        return value_within(first_zero, timeout_s, "a zero command after the page stopped")

    def test_1_video_is_passed_untouched_and_a_stuck_page_does_not_stall_others(self):
        stuck = never_reading_page(self.port)
        self.addCleanup(stuck.close)
        page = self.page(auth=False)
        rss_before = rss_mb(NODE)
        self.camera.on = True
        time.sleep(4.0)
        self.camera.on = False
        # 80 frames of 0.3 MB were offered to the stuck page: dropped, not queued
        grown = rss_mb(NODE) - rss_before
        self.assertLess(grown, 12.0, "the server grew by %.1f MB: frames queued" % grown)
        frames = [f for f in page.frames if f[1] == b"V"]
        # 20 Hz for 4 s: the reading page got most of them despite the stuck one
        self.assertGreater(len(frames), 60, "a reading page got %d frames" % len(frames))
        with self.camera.lock:
            sent = dict(self.camera.sent)
        for _, _, header, payload in frames[-5:]:
            self.assertEqual(payload, sent[round(header["stamp"], 6)],
                             "JPEG bytes changed on the way")
            self.assertGreaterEqual(header["age_s"], 0.0)
            self.assertLess(header["age_s"], 0.2)
        page.send({"type": "ping", "id": 7})
        self.assertTrue(page.wait(lambda c: [m for m in c.messages("pong") if m["id"] == 7],
                                  2.0), "no pong while a page is stuck")

    def test_2_watching_page_cannot_drive_and_errors_go_to_that_page_only(self):
        watcher, other = self.page(auth=False), self.page(auth=False)
        watcher.send({"type": "auth", "token": "wrong"})
        self.assertTrue(watcher.wait(lambda c: [m for m in c.messages("auth")
                                                if not m["ok"]], 3.0))
        n = len(self.teleop.all())
        watcher.send({"type": "drive", "linear": 0.2, "angular": 0.0})
        err = watcher.wait(lambda c: c.messages("error"), 3.0)
        self.assertIn("needs the token", err[-1]["message"])
        watcher.send({"type": "goal", "x": 1.0, "y": 1.0})
        watcher.wait(lambda c: len(c.messages("error")) >= 2, 3.0)
        time.sleep(0.3)
        self.assertEqual(len(self.teleop.all()), n, "a page without the token drove")
        self.assertEqual(other.messages("error"), [], "another page got the error")

    def test_3_bad_messages_are_refused_and_the_server_goes_on(self):
        page = self.page()
        bad = ["{nope", "[1]", json.dumps({"type": "warp"}),
               '{"type": "drive", "linear": NaN, "angular": 0}',
               '{"type": "drive", "linear": 1e999, "angular": 0}',
               json.dumps({"type": "ping", "pad": "x" * 10000}),
               json.dumps({"type": "goal", "x": 50.0, "y": 0.0})]
        for text in bad:
            page.send(text)
        page.send_binary(b"\x00\x01")
        errors = page.wait(lambda c: len(c.messages("error")) >= len(bad) + 1 and
                           c.messages("error"), 5.0)
        self.assertTrue(errors, "refusals: %s" % page.messages("error"))
        said = " | ".join(m["message"] for m in errors)
        for words in ("not JSON", "not a JSON object", "unknown message type",
                      "not finite", "over the limit", "outside the map", "binary"):
            self.assertIn(words, said)
        self.assertFalse(page.closed)
        page.send({"type": "ping", "id": 3})
        self.assertTrue(page.wait(lambda c: c.messages("pong"), 2.0))

    def test_4_lease_runs_out_and_closing_stops(self):
        page = self.page()
        t_stop = self.drive_for(page, 1.0, linear=0.9)
        fast = [m.linear.x for m in self.teleop.all()]
        self.assertIn(0.3, fast, "the speed limit (0.3 m/s) was not applied: %s" % fast[-5:])
        self.assertGreater(max(m.linear.x for m in self.out.all()), 0.0,
                           "the mux did not pass the operator's command")
        latency = self.zero_after(t_stop)
        # Causal: the last command was sent 0.05 s before t_stop, so a zero before 0.15 s
        # means the 0.2 s lease did not hold; the upper bound tells the lease from a hang or
        # another, longer timeout, not the latency (bench_console.py measures that: 20/20
        # under 0.3 s on the idle machine; here two rostests share two cores).
        self.assertGreaterEqual(latency, 0.14, "zero %.3f s after the last command: before "
                                "the lease ran out" % latency)
        self.assertLess(latency, 1.0, "lease expiry took %.3f s" % latency)
        # a second page cannot take over while the first holds the lease
        other = self.page()
        page.send({"type": "drive", "linear": 0.1, "angular": 0.0})
        time.sleep(0.05)
        other.send({"type": "drive", "linear": 0.1, "angular": 0.0})
        err = other.wait(lambda c: c.messages("error"), 2.0)
        self.assertIn("another page", err[-1]["message"])
        # closing the driving page: zero at once
        self.drive_for(page, 0.5)
        t_close = time.monotonic()
        page.close()
        latency = self.zero_after(t_close)
        self.assertLess(latency, 0.3, "closing took %.3f s to stop" % latency)

    def test_5_estop_latches_until_rearmed_with_the_token(self):
        page, watcher = self.page(), self.page(auth=False)
        watcher.send({"type": "estop", "on": True})  # anyone may stop the robot
        wait_for(lambda: self.estop.last() is not None and self.estop.last().data, 3.0,
                 "e_stop latched")
        page.send({"type": "drive", "linear": 0.1, "angular": 0.0})
        err = page.wait(lambda c: c.messages("error"), 2.0)
        self.assertIn("e-stop", err[-1]["message"])
        watcher.send({"type": "estop", "on": False})
        err = watcher.wait(lambda c: c.messages("error"), 2.0)
        self.assertIn("needs the token", err[-1]["message"])
        self.assertTrue(self.estop.last().data)
        page.send({"type": "estop", "on": False})
        wait_for(lambda: not self.estop.last().data, 3.0, "e_stop re-armed")

    def test_6_goal_in_the_map_frame(self):
        page = self.page()
        page.send({"type": "goal", "x": 3.0, "y": 2.0, "yaw": math.pi / 2})
        goal = value_within(self.goals.last, 5.0, "a move_base goal")
        pose = goal.goal.target_pose
        self.assertEqual(pose.header.frame_id, "map")
        self.assertAlmostEqual(pose.pose.position.x, 3.0)
        self.assertAlmostEqual(pose.pose.position.y, 2.0)
        self.assertAlmostEqual(pose.pose.orientation.z, math.sin(math.pi / 4))
        page.send({"type": "cancel"})
        status = page.wait(lambda c: [m for m in c.messages("status") if m["goal"]], 3.0)
        self.assertAlmostEqual(status[-1]["goal"]["x"], 3.0)

    def test_7_map_reaches_a_new_page_as_png(self):
        page = self.page(auth=False)
        maps = page.wait(lambda c: [f for f in c.frames if f[1] == b"M"], 5.0)
        self.assertTrue(maps, "no map sent to a new page")
        _, _, header, png = maps[-1]
        # the test's map: 100 x 50 cells of 0.1 m from (-2, -1), every cell known
        self.assertEqual((header["width"], header["height"]), (100, 50))
        self.assertAlmostEqual(header["origin_x"], -2.0)
        self.assertAlmostEqual(header["origin_y"], -1.0)
        self.assertAlmostEqual(header["resolution"], 0.1)
        image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
        self.assertEqual(image.shape, (50, 100))
        self.assertTrue((image == 254).all(), "free cells are not white")


if __name__ == "__main__":
    rostest.rosrun("web_console", "web_console_node", WebConsoleTest, sys.argv)
