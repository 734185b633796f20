#!/usr/bin/env python3
"""rostest: node q24_camera against the fake Q24 (test/fake_q24.py) over loopback HTTP.

The fake server runs in this process on a free port and the node is launched by this
script (roslaunch's script API) with ``~url`` pointing at it, so that the test can make
the server misbehave while the node runs. Checks: the frames on
camera/image_raw/compressed are byte-identical to what was served, in order, stamped when
their first byte arrived (no sim time: the stamps and the server's send times share the
wall clock); camera/image_raw holds the same images decoded; camera/frame_age and the
diagnostics' frame rate; then, one after the other, a connection dropped mid-frame, corrupt
frames, a stall, a 404 and an HTML page: each gives its warning on /rosout naming the URL
and the problem, at most once per WARN_PERIOD_S for corrupt frames, none of the corrupt
frames is published, and frames flow again afterwards.
"""
import os
import statistics
import sys
import threading
import time
import unittest

import cv2
import numpy as np
import roslaunch
import roslaunch.scriptapi
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from sensor_msgs.msg import CompressedImage, Image
from std_msgs.msg import Float64

from ascc_testing.rosout import RosoutWatcher, assert_throttled
from ascc_testing.waits import Latest, wait_for

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fake_q24 import FakeQ24, make_jpeg  # noqa: E402  (helper next to this file)

NODE = "/q24_camera"
FPS = 15.0               # the fake camera's frame rate
TIMEOUT_S = 1.0          # the node's ~timeout_s in this test
MAX_FRAME_AGE_S = 0.5    # the node's ~max_frame_age_s (its default)
WARN_PERIOD_S = 5.0      # the node's throttle period for each kind of warning
WIDTH, HEIGHT = 320, 240


class Frames:
    """Every message on ``topic`` with the wall time it was received."""

    def __init__(self, topic, msg_type):
        self.lock = threading.Lock()
        self.msgs = []
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=100)

    def _cb(self, msg):
        with self.lock:
            self.msgs.append((time.time(), msg))

    def since(self, wall_s):
        with self.lock:
            return [m for t, m in self.msgs if t >= wall_s]

    def wait_since(self, wall_s, count, timeout_s, what):
        wait_for(lambda: len(self.since(wall_s)) >= count, timeout_s, what)
        return self.since(wall_s)


class TestQ24Camera(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rostest_q24_camera")
        cls.fake = FakeQ24(fps=FPS, jpeg=make_jpeg(WIDTH, HEIGHT))
        cls.fake.start()
        cls.url = cls.fake.url
        cls.rosout = RosoutWatcher()
        cls.compressed = Frames("camera/image_raw/compressed", CompressedImage)
        cls.raw = Frames("camera/image_raw", Image)
        cls.age = Frames("camera/frame_age", Float64)
        cls.diag = Latest("/diagnostics", DiagnosticArray, keep_all=True)
        for name, value in (("url", cls.url), ("timeout_s", TIMEOUT_S),
                            ("publish_raw", True), ("reconnect_min_s", 0.2),
                            ("reconnect_max_s", 1.0)):
            rospy.set_param(NODE + "/" + name, value)
        cls.launch = roslaunch.scriptapi.ROSLaunch()
        cls.launch.start()
        cls.proc = cls.launch.launch(roslaunch.core.Node(
            "target_follower", "q24_camera", name=NODE[1:], output="screen"))

    @classmethod
    def tearDownClass(cls):
        cls.launch.stop()
        cls.fake.stop()

    def sent(self):
        return {s.data: s for s in self.fake.sent_frames(good_only=False)}

    def status(self, since_wall_s=0.0):
        """The node's newest diagnostics status (received after ``since_wall_s``)."""
        for msg in reversed(list(self.diag.all or [])):
            for st in msg.status:
                if st.name == "q24_camera: stream" and msg.header.stamp.to_sec() >= since_wall_s:
                    return st, {kv.key: kv.value for kv in st.values}
        return None, {}

    def assert_alive(self, since_wall_s, what):
        """Good frames come again after ``since_wall_s``; every one was served intact."""
        msgs = self.compressed.wait_since(since_wall_s, 5, 30.0, "frames again after " + what)
        sent = self.sent()
        for m in msgs:
            self.assertIn(bytes(m.data), sent, "%s: a frame never served" % what)
            self.assertFalse(sent[bytes(m.data)].corrupt, "%s: corrupt frame published" % what)
        self.assertTrue(self.proc.is_alive(), what)

    def test_a_frames_untouched_stamped_and_decoded(self):
        msgs = self.compressed.wait_since(0.0, 30, 60.0, "30 compressed frames")
        sent = self.sent()
        lags, indices = [], []
        for m in msgs:
            data = bytes(m.data)
            self.assertIn(data, sent, "a published frame was never served")
            self.assertEqual(m.format, "bgr8; jpeg compressed bgr8")
            self.assertEqual(m.header.frame_id, "camera")
            lags.append(m.header.stamp.to_sec() - sent[data].wall_s)
            indices.append(sent[data].index)
        self.assertEqual(indices, sorted(set(indices)), "frames out of order or repeated")
        # stamped when the first byte arrived: never before the server sent it, and
        # one loopback hop after it for most frames (a starved reader thread may read
        # any one frame late, so no bound on the largest; that the stamp is the first
        # byte's, not the last's, test_mjpeg.py shows without a clock)
        self.assertGreater(min(lags), -0.005, lags)
        self.assertLess(statistics.median(lags), 0.05, lags)

        raws = self.raw.wait_since(0.0, 5, 30.0, "raw images")
        by_stamp = {m.header.stamp.to_nsec(): bytes(m.data) for m in msgs}
        matched = 0
        for r in raws:
            self.assertEqual((r.encoding, r.width, r.height, r.step),
                             ("bgr8", WIDTH, HEIGHT, 3 * WIDTH))
            data = by_stamp.get(r.header.stamp.to_nsec())
            if data is not None:
                expected = cv2.imdecode(np.frombuffer(data, np.uint8),
                                        cv2.IMREAD_COLOR)
                self.assertEqual(bytes(r.data), expected.tobytes())
                matched += 1
        self.assertGreater(matched, 0, "no raw image with a compressed frame's stamp")

    def test_b_frame_age_and_diagnostics(self):
        t0 = time.time()
        ages = self.age.wait_since(t0, 10, 30.0, "10 frame_age messages")
        self.assertLess(statistics.median(m.data for m in ages), MAX_FRAME_AGE_S)
        wait_for(lambda: self.status(t0 + 6.0)[0] is not None, 30.0,
                 "diagnostics 6 s into streaming (the rate's 5 s window full)")
        st, values = self.status(t0 + 6.0)
        self.assertEqual(st.level, DiagnosticStatus.OK, st)
        rate = float(values["frame rate [Hz]"])
        self.assertGreater(rate, 0.6 * FPS, values)
        self.assertLess(rate, 1.2 * FPS, values)
        self.assertEqual(values["url"], self.url)
        self.assertEqual(values["dropped corrupt"], "0")

    def test_c_dropped_connection_reconnects(self):
        t0 = time.time()
        connections = self.fake.connections
        self.fake.cut_now()
        self.rosout.wait_for(20.0, "warning about the dropped connection", node=NODE,
                             level="warn", contains=(self.url, "inside a frame", "reconnect"))
        wait_for(lambda: self.fake.connections > connections, 20.0, "a new connection")
        self.assert_alive(time.time(), "the dropped connection")
        wait_for(lambda: int(self.status(t0)[1].get("reconnects", 0)) >= 1, 10.0,
                 "diagnostics counting the reconnect")

    def test_d_corrupt_frames_are_dropped_and_warned_throttled(self):
        start = time.monotonic()
        t0 = time.time()
        published_before = len(self.compressed.since(0.0))
        self.fake.garbage_every = 2
        # corrupt frames for more than one throttle period: two warnings at least
        wait_for(lambda: time.monotonic() - start > WARN_PERIOD_S + 3.0, 30.0,
                 "corrupt frames being served")
        self.fake.garbage_every = None
        end = time.monotonic()
        corrupt_sent = [s for s in self.fake.sent_frames(good_only=False)
                        if s.corrupt and s.wall_s >= t0]
        self.assertGreater(len(corrupt_sent), 10)
        # good frames went on meanwhile, and none of the corrupt ones went out
        self.assertGreater(len(self.compressed.since(0.0)), published_before + 10)
        self.assert_alive(t0, "corrupt frames")
        records = self.rosout.matching(node=NODE, level="warn",
                                       contains=("corrupt frame", self.url))
        counted = assert_throttled(records, WARN_PERIOD_S, start, end + 1.0, clock="wall_s",
                                   what="corrupt-frame warning")
        self.assertGreaterEqual(len(counted), 2, [r.text for r in counted])
        for r in counted:  # each names what was wrong with the frame it dropped
            self.assertRegex(r.text, r"no JPEG start marker \(SOI\)|no JPEG end marker "
                             r"\(EOI\)|does not decode", r.text)
        wait_for(lambda: int(self.status(time.time() - 0.5)[1].get("dropped corrupt", 0))
                 >= len(corrupt_sent) // 2, 10.0, "diagnostics counting the corrupt frames")

    def test_e_stall_then_resume(self):
        t0 = time.time()
        self.fake.stalled.set()
        self.rosout.wait_for(20.0, "warning about the stalled stream", node=NODE,
                             level="warn", contains=(self.url, "no data"))
        wait_for(lambda: any(m.data > TIMEOUT_S for m in self.age.since(t0)), 10.0,
                 "frame_age beyond the timeout")
        wait_for(lambda: (self.status(time.time() - 0.5)[0] or DiagnosticStatus()).level
                 == DiagnosticStatus.ERROR, 10.0, "diagnostics ERROR while stalled")
        self.fake.stalled.clear()
        self.assert_alive(time.time(), "the stall")

    def test_f_404_and_html(self):
        for answer, needle in (("404", "404"), ("html", "text/html")):
            self.fake.answer = answer
            self.fake.cut_now()
            self.rosout.wait_for(20.0, "warning about a %s answer" % answer, node=NODE,
                                 level="warn", contains=(self.url, needle))
        t0 = time.time()
        self.fake.answer = "stream"
        self.assert_alive(t0, "404 and HTML answers")


if __name__ == "__main__":
    rostest.rosrun("target_follower", "q24_camera", TestQ24Camera)
