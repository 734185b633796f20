#!/usr/bin/env python3
"""rostest: target_detector on synthetic compressed panoramas (no simulator).

The test publishes ``camera/image_raw/compressed`` (JPEG of a synthetic double panorama
with a cone at a known bearing and range, see target_follower.synthetic), ``scan`` (a
laser 0.1 m ahead of base_link, a static TF the test broadcasts, whose beams hit the
cone's trunk and a wall behind it; a few NaN beams elsewhere) and ``odom`` (still). It
asserts the Target message: the cone's bearing within 2 deg, range from the laser within
0.15 m; a target-free frame gives an explicit empty list; corrupt JPEG frames give a
warning naming the problem, throttled to one per 5 s, and the node goes on. A turning
robot: the picture taken ``camera_latency`` before the frame's stamp, the scan at the
stamp after the robot turned 0.35 rad (odometry): the cone's range is still the laser's.
"""
import math
import sys
import time
import unittest

import cv2
import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CompressedImage, LaserScan
from std_msgs.msg import Float64

from ascc_common.camera_model import PanoramicCamera
from ascc_common.pose2d import quaternion_from_yaw
from ascc_testing.rosout import RosoutWatcher, assert_throttled
from ascc_testing.waits import wait_for
from target_follower import synthetic as S
from target_follower.msg import Detection, Target

NODE = "/target_detector"
LASER_X_M = 0.1
CONE_RADIUS_M = 0.1  # trunk radius at the laser's height
WARN_PERIOD_S = 5.0


def scan_msg(stamp, cone_xy):
    """A 360-degree scan from (LASER_X_M, 0): a wall at 4 m, the cone's trunk a circle."""
    a = -math.pi + 0.005 * np.arange(1257)
    d = np.stack([np.cos(a), np.sin(a)], axis=1)
    c = np.asarray(cone_xy) - [LASER_X_M, 0.0]
    along = d @ c
    perp2 = c @ c - along ** 2
    hit = (along > 0) & (perp2 < CONE_RADIUS_M ** 2)
    r = np.full(a.size, 4.0)
    r[::200] = np.nan  # bad beams, none on the cone
    r[hit] = along[hit] - np.sqrt(CONE_RADIUS_M ** 2 - perp2[hit])
    m = LaserScan()
    m.header.stamp, m.header.frame_id = stamp, "laser"
    m.angle_min, m.angle_increment = float(a[0]), 0.005
    m.angle_max = float(a[-1])
    m.range_min, m.range_max = 0.02, 5.6
    m.ranges = r.tolist()
    return m


class TargetDetectorTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("target_detector_test")
        cls.watcher = RosoutWatcher()
        cls.targets = []
        rospy.Subscriber("target", Target, cls.targets.append, queue_size=50)
        cls.image_pub = rospy.Publisher("camera/image_raw/compressed", CompressedImage,
                                        queue_size=1)
        cls.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=1)
        cls.odom_pub = rospy.Publisher("odom", Odometry, queue_size=5)
        cls.latency_pub = rospy.Publisher("camera_latency", Float64, queue_size=1, latch=True)
        cls.cam = PanoramicCamera()
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = "base_link", "laser"
        t.transform.translation.x, t.transform.translation.z = LASER_X_M, 0.2
        t.transform.rotation.w = 1.0
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()
        cls.static_tf.sendTransform(t)
        wait_for(lambda: cls.image_pub.get_num_connections() > 0, 30, "target_detector")

    def send(self, jpeg_bytes, cone_xy=(9.0, 9.0)):
        """Publish scan, odom and one frame (stamped now); return its Target message."""
        stamp = rospy.Time.now()
        self.scan_pub.publish(scan_msg(stamp, cone_xy))
        odom = Odometry()
        odom.header.stamp = stamp
        self.odom_pub.publish(odom)
        rospy.sleep(0.1)  # the scan and odom callbacks before the frame's
        m = CompressedImage()
        m.header.stamp, m.header.frame_id = stamp, "camera"
        m.format = "jpeg"
        m.data = jpeg_bytes
        n = len(self.targets)
        self.image_pub.publish(m)
        return n, stamp

    def wait_target(self, n, stamp):
        wait_for(lambda: any(t.header.stamp == stamp for t in self.targets[n:]), 20,
                 "a Target message for the frame")
        return [t for t in self.targets[n:] if t.header.stamp == stamp][0]

    @staticmethod
    def jpeg(img):
        return cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 85])[1].tobytes()

    def test_1_cone_bearing_and_laser_range(self):
        img = S.background(self.cam, np.random.default_rng(7))
        bearing, r = 0.6, 1.5
        S.draw_cone(img, self.cam, bearing, r)
        cone_xy = (r * math.cos(bearing), r * math.sin(bearing))
        msg = self.wait_target(*self.send(self.jpeg(img), cone_xy))
        self.assertGreaterEqual(len(msg.detections), 1)
        d = msg.detections[0]
        self.assertEqual(d.kind, "cone")
        self.assertEqual(msg.header.frame_id, "base_link")
        self.assertLess(abs(math.degrees(d.bearing_rad - bearing)), 2.0)
        self.assertEqual(d.range_source, Detection.RANGE_LASER)
        self.assertLess(abs(d.range_m - (r - CONE_RADIUS_M)), 0.15)
        self.assertLess(math.hypot(d.position.x - cone_xy[0], d.position.y - cone_xy[1]), 0.2)
        self.watcher.wait_for(10, "the NaN-scan warning", node=NODE, level="warn",
                              contains="nan/inf")

    def test_2_no_target_is_an_explicit_empty_list(self):
        img = S.background(self.cam, np.random.default_rng(8))
        msg = self.wait_target(*self.send(self.jpeg(img)))
        self.assertEqual(list(msg.detections), [])

    def test_3_corrupt_jpeg_warns_throttled_and_goes_on(self):
        img = S.background(self.cam, np.random.default_rng(9))
        good = self.jpeg(img)
        start = time.monotonic()
        for i in range(12):
            bad = good[:len(good) // 3] if i % 2 else b"\xff\xd8 not a jpeg"
            self.send(bad)
            rospy.sleep(0.25)
        self.watcher.wait_for(10, "the corrupt-JPEG warning", node=NODE, level="warn",
                              contains="cannot decode")
        end = time.monotonic()
        records = self.watcher.matching(node=NODE, contains="cannot decode")
        assert_throttled(records, WARN_PERIOD_S, start, end, clock="wall_s",
                         what="corrupt-JPEG warning")
        S.draw_cone(img, self.cam, -2.5, 1.2)
        msg = self.wait_target(*self.send(self.jpeg(img)))
        self.assertEqual(len(msg.detections), 1)
        self.assertLess(abs(math.degrees(msg.detections[0].bearing_rad + 2.5)), 2.0)

    def test_4_turning_robot_laser_range_at_the_pictures_time(self):
        """The picture is taken 0.3 s before the frame's stamp (camera_latency) with the
        cone at 0.6 rad; by the stamp, when the scan is taken, the robot has turned 0.35
        rad: in the scan the cone lies at 0.25 rad, 0.5 m beside the camera's ray."""
        latency, turn, bearing, r = 0.3, 0.35, 0.6, 1.5
        self.latency_pub.publish(Float64(data=latency))
        wait_for(lambda: self.latency_pub.get_num_connections() > 0, 10, "camera_latency")
        rospy.sleep(0.3)
        img = S.background(self.cam, np.random.default_rng(10))
        S.draw_cone(img, self.cam, bearing, r)
        stamp = rospy.Time.now()
        for dt, yaw in ((-0.6, 0.0), (-latency, 0.0), (0.0, turn)):
            odom = Odometry()
            odom.header.stamp = stamp + rospy.Duration(dt)
            q = quaternion_from_yaw(yaw)
            o = odom.pose.pose.orientation
            o.x, o.y, o.z, o.w = q
            self.odom_pub.publish(odom)
            rospy.sleep(0.05)
        seen = (r * math.cos(bearing - turn), r * math.sin(bearing - turn))
        self.scan_pub.publish(scan_msg(stamp, seen))
        rospy.sleep(0.1)
        m = CompressedImage()
        m.header.stamp, m.header.frame_id = stamp, "camera"
        m.format = "jpeg"
        m.data = self.jpeg(img)
        n = len(self.targets)
        self.image_pub.publish(m)
        msg = self.wait_target(n, stamp)
        d = msg.detections[0]
        self.assertLess(abs(math.degrees(d.bearing_rad - bearing)), 2.0)
        self.assertEqual(d.range_source, Detection.RANGE_LASER)
        self.assertLess(abs(d.range_m - (r - CONE_RADIUS_M)), 0.15)


if __name__ == "__main__":
    rostest.rosrun("target_follower", "target_detector", TargetDetectorTest, sys.argv)
