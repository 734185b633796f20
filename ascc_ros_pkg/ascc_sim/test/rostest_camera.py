#!/usr/bin/env python3
"""rostest: sim_camera publishes camera/image_raw (bgr8), camera/image_raw/compressed
(JPEG) and camera/camera_info of the configured size in frame ``camera``, the static TF
base_link -> camera at the mount, and serves the same frames as a decodable MJPEG stream;
the office's cone shows up in orange at its true bearing."""
import math
import sys
import time
import unittest
import urllib.request

import cv2
import numpy as np
import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from ascc_testing.waits import Latest, pose_of, wait_for

CONE = (4.8, 8.0)  # cone1 in worlds/office.yaml


def read_part(resp, boundary):
    """The body of the next multipart part."""
    line = resp.readline()
    while line in (b"\r\n", b"\n"):
        line = resp.readline()
    assert line.rstrip(b"\r\n") == b"--" + boundary, line
    length = None
    while True:
        line = resp.readline().rstrip(b"\r\n")
        if not line:
            break
        key, value = line.decode().split(":", 1)
        if key.strip().lower() == "content-length":
            length = int(value)
    return resp.read(length)


class CameraTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("camera_test")
        cls.raw = Latest("camera/image_raw", Image)
        cls.jpeg = Latest("camera/image_raw/compressed", CompressedImage)
        cls.info = Latest("camera/camera_info", CameraInfo)
        cls.truth = Latest("ground_truth/asccbot/odom", Odometry)
        cls.node = rospy.get_param("~camera_node")

    def test_topics(self):
        raw = self.raw.wait(120.0, count=3)
        self.assertEqual((raw.height, raw.width, raw.encoding), (768, 1024, "bgr8"))
        self.assertEqual(raw.step, 3072)
        self.assertEqual(raw.header.frame_id, "camera")
        info = self.info.wait(60.0)
        self.assertEqual((info.height, info.width), (768, 1024))
        self.assertEqual(info.distortion_model, "equirectangular")
        self.assertEqual(info.header.frame_id, "camera")
        comp = self.jpeg.wait(60.0, count=2)
        self.assertEqual(comp.format, "bgr8; jpeg compressed bgr8")
        img = cv2.imdecode(np.frombuffer(comp.data, np.uint8), cv2.IMREAD_COLOR)
        self.assertEqual(img.shape, (768, 1024, 3))
        self.assertGreater(comp.header.stamp.to_sec(), 0.0)

    def test_cone_at_its_bearing(self):
        raw = self.raw.wait(120.0)
        info = self.info.wait(60.0)
        x, y, yaw = pose_of(self.truth.wait(60.0))
        img = np.frombuffer(raw.data, np.uint8).reshape(raw.height, raw.width, 3)
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        top = cv2.inRange(hsv, (5, 200, 150), (22, 255, 255))[:raw.height // 2]
        v, u = np.nonzero(top)
        self.assertGreater(len(u), 200, "no orange cone in the front strip")
        # bearing from camera_info: K[2] is bearing 0, K[0] pixels per radian
        bearing = (info.K[2] - (u.mean() + 0.5)) / info.K[0]
        truth = math.atan2(CONE[1] - y, CONE[0] - x) - yaw
        err = math.degrees(abs(math.remainder(bearing - truth, 2 * math.pi)))
        self.assertLess(err, 2.0)

    def test_static_tf(self):
        buf = tf2_ros.Buffer()
        tf2_ros.TransformListener(buf)
        wait_for(lambda: buf.can_transform("base_link", "camera", rospy.Time(0)), 60.0,
                 "TF base_link -> camera")
        t = buf.lookup_transform("base_link", "camera", rospy.Time(0)).transform
        self.assertAlmostEqual(t.translation.z, 0.55, places=3)

    def test_mjpeg_stream(self):
        name = self.node + "/http_bound_port"
        wait_for(lambda: rospy.has_param(name), 60.0, "parameter " + name)
        port = rospy.get_param(name)
        self.assertGreater(port, 0)
        deadline = time.monotonic() + 60.0
        resp = urllib.request.urlopen("http://127.0.0.1:%d/" % port, timeout=30)
        ctype = resp.headers["Content-Type"]
        self.assertTrue(ctype.startswith("multipart/x-mixed-replace; boundary="), ctype)
        boundary = ctype.split("boundary=", 1)[1].encode()
        frames = []
        while len(frames) < 2 and time.monotonic() < deadline:
            frames.append(cv2.imdecode(np.frombuffer(read_part(resp, boundary), np.uint8),
                                       cv2.IMREAD_COLOR))
        resp.close()
        self.assertEqual(len(frames), 2)
        for f in frames:
            self.assertIsNotNone(f)
            self.assertEqual(f.shape, (768, 1024, 3))


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "sim_camera_test", CameraTest, sys.argv)
