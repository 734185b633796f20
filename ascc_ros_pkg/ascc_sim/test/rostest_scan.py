#!/usr/bin/env python3
"""rostest: the simulated URG-04LX scans agree with an independent ray cast of the PGM
(read here with OpenCV, traversed cell by cell per beam) from the true laser pose (ground
truth + the static base_link -> laser TF), within the +-3 % noise and the dropouts."""
import math
import os
import sys
import unittest

import cv2
import numpy as np
import rospy
import rostest
import tf2_ros
import yaml
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from ascc_common.pose2d import compose, yaw_of
from ascc_testing.waits import Latest, pose_of, wait_for

N_SCANS = 20


def load_pgm_solid(map_yaml):
    """Occupied cells of a map_server map (trinary, negate 0): (solid[iy, ix], res, ox, oy)."""
    with open(map_yaml, encoding="utf-8") as f:
        doc = yaml.safe_load(f)
    img = cv2.imread(os.path.join(os.path.dirname(map_yaml), doc["image"]),
                     cv2.IMREAD_GRAYSCALE)
    p_occupied = (255.0 - img) / 255.0
    solid = np.flipud(p_occupied > doc.get("occupied_thresh", 0.65))
    return solid, float(doc["resolution"]), doc["origin"][0], doc["origin"][1]


def cast(solid, res, ox, oy, x, y, angle, max_range):
    """First occupied cell along one beam (Amanatides-Woo): distance or inf."""
    u, v = (x - ox) / res, (y - oy) / res
    dx, dy = math.cos(angle), math.sin(angle)
    ix, iy = int(math.floor(u)), int(math.floor(v))
    sx, sy = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
    tx = ((ix + (dx > 0)) - u) / dx if dx else math.inf
    ty = ((iy + (dy > 0)) - v) / dy if dy else math.inf
    ddx, ddy = (abs(1 / dx) if dx else math.inf), (abs(1 / dy) if dy else math.inf)
    t = 0.0
    h, w = solid.shape
    while t * res <= max_range:
        if 0 <= ix < w and 0 <= iy < h and solid[iy, ix]:
            return t * res
        if tx < ty:
            t, ix, tx = tx, ix + sx, tx + ddx
        else:
            t, iy, ty = ty, iy + sy, ty + ddy
    return math.inf


class ScanTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("scan_test")
        cls.robot = rospy.get_param("~robot", "asccbot")
        cls.map_yaml = rospy.get_param("~map_yaml")
        cls.scans = Latest("scan", LaserScan, keep_all=True)
        cls.truth = Latest("ground_truth/%s/odom" % cls.robot, Odometry)
        cls.tf = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.tf)

    def test_scan_matches_pgm(self):
        self.truth.wait(90.0)
        first = self.scans.wait(90.0)
        self.scans.wait(120.0, count=N_SCANS + 1)
        scans = self.scans.all[1:N_SCANS + 1]

        # Message fields: URG-04LX geometry, frame 'laser', 10 Hz in simulated time.
        self.assertEqual(first.header.frame_id, "laser")
        self.assertEqual(len(first.ranges), 683)
        self.assertAlmostEqual(first.angle_min, math.radians(-120.0), places=6)
        self.assertAlmostEqual(first.angle_increment, 2 * math.pi / 1024, places=9)
        self.assertAlmostEqual(first.angle_max, first.angle_min + 682 * first.angle_increment,
                               places=5)
        self.assertAlmostEqual(first.range_min, 0.02, places=6)
        self.assertAlmostEqual(first.range_max, 4.094, places=5)
        self.assertAlmostEqual(first.scan_time, 0.1, places=6)
        stamps = np.array([s.header.stamp.to_sec() for s in scans])
        self.assertTrue(np.allclose(np.diff(stamps), 0.1, atol=1e-6), np.diff(stamps))

        # True laser pose: ground truth of the robot + the static TF.
        wait_for(lambda: self.tf.can_transform("base_link", "laser", rospy.Time(0)), 30.0,
                 "the static base_link -> laser transform")
        mount = self.tf.lookup_transform("base_link", "laser", rospy.Time(0)).transform
        laser = compose(pose_of(self.truth.msg), (mount.translation.x, mount.translation.y,
                                                  yaw_of(mount.rotation)))
        solid, res, ox, oy = load_pgm_solid(self.map_yaml)
        angles = first.angle_min + np.arange(683) * first.angle_increment
        expected = np.array([cast(solid, res, ox, oy, laser[0], laser[1], laser[2] + a,
                                  first.range_max) for a in angles])
        measured = np.array([s.ranges for s in scans], dtype=np.float64)

        hit = np.isfinite(expected)
        self.assertGreater(hit.sum(), 400, "the test pose must see walls")
        self.assertGreater((~hit).sum(), 10, "the test pose must see open space too")
        # No return where the PGM has nothing within range.
        self.assertTrue(np.all(np.isposinf(measured[:, ~hit])))
        m, e = measured[:, hit], np.broadcast_to(expected[hit], measured[:, hit].shape)
        dropped = np.isnan(m)
        beyond = np.isposinf(m)  # noise may push a return just past range_max
        self.assertTrue(np.all(e[beyond] * 1.03 > first.range_max))
        ok = ~dropped & ~beyond
        rel = (m[ok] - e[ok]) / e[ok]
        self.assertTrue(np.all(np.abs(m[ok] - e[ok]) <= 0.03 * e[ok] + 0.0015),
                        "max relative error %.4f" % np.abs(rel).max())
        self.assertLess(dropped.mean(), 0.15)
        self.assertGreater(dropped.mean(), 0.0)  # far / grazing returns do drop out
        self.assertLess(abs(rel.mean()), 0.002)
        self.assertTrue(0.005 < rel.std() < 0.015, rel.std())  # noise is really there
        rospy.loginfo("scan: %d beams x %d scans vs the PGM: rel. error mean %.4f std %.4f,"
                      " %.1f %% dropped", hit.sum(), len(scans), rel.mean(), rel.std(),
                      100 * dropped.mean())


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "scan", ScanTest, sys.argv)
