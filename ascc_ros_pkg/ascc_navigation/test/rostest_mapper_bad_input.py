#!/usr/bin/env python3
"""rostest: the slam_gmapping stand-in survives bad input (no simulator needed).

The test owns /clock, TF odom -> base_link (+ a static base_link -> laser) and ``scan``
(ray-cast in ``synthetic.office_world``). It drives 1 m, then sends bad scans (empty, all
NaN, unknown frame, zero angle increment, no frame_id; a tilted laser frame is covered by
the unit tests), each kind until the mapper's warning naming it arrives on /rosout and then
10 more, which the per-kind throttle must keep quiet (at most one warning per 5 s of wall
time); drives on, then makes the clock jump back (a bag loop: one warning, the map reset)
and drives the same stretch again. The node must keep publishing entropy and, after the
jump, a fresh map. Waits are on conditions with wall-clock timeouts.
"""
import sys
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import OccupancyGrid
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from ascc_common.grid import OCCUPIED
from ascc_common.pose2d import compose, quaternion_from_yaw
from ascc_navigation import synthetic as S
from ascc_navigation.laser import LaserMount
from ascc_testing.rosout import RosoutWatcher, assert_throttled
from ascc_testing.waits import Latest, wait_for

WORLD_START = np.array([2.0, 2.0, 0.0])  # odom origin in the synthetic office
MOUNT = LaserMount(0.05, 0.0, 0.0)
NODE = "/slam_gmapping"
WARN_PERIOD_S = 5.0  # the mapper's per-kind warning period (wall clock)
EXTRA = 10  # bad scans of a kind sent after its warning


def transform(stamp, parent, child, x, y, yaw):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x = x
    t.transform.translation.y = y
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
     t.transform.rotation.w) = quaternion_from_yaw(yaw)
    return t


class MapperBadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=10)
        rospy.init_node("mapper_bad_input_test")
        cls.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=10)
        cls.tf = tf2_ros.TransformBroadcaster()
        cls.static_tf = tf2_ros.StaticTransformBroadcaster()
        cls.entropy = Latest("slam_gmapping/entropy", Float64)
        cls.map = Latest("map", OccupancyGrid)
        cls.truth, cls.info = S.office_world()
        cls.spec = S.LaserSpec()
        cls.rng = np.random.default_rng(0)
        cls.log = RosoutWatcher()
        cls.log.wait_for_connection()

    def warnings(self, words, since):
        return self.log.matching(node=NODE, level="warn", contains=words, since_wall_s=since)

    def tick(self, t, odom_pose, ranges=None, frame="laser", increment=None):
        """Advance the clock to t [s], publish odom -> base_link and one scan at t."""
        stamp = rospy.Time.from_sec(t)
        self.clock.publish(Clock(clock=stamp))
        self.tf.sendTransform(transform(stamp, "odom", "base_link", *odom_pose))
        if ranges is None:
            world = compose(WORLD_START, odom_pose)
            ranges = S.simulate_scan(self.truth == OCCUPIED, self.info, world, MOUNT,
                                     self.spec, self.rng).tolist()
        msg = LaserScan()
        msg.header.stamp = stamp
        msg.header.frame_id = frame
        msg.angle_min = self.spec.angle_min
        msg.angle_increment = self.spec.angle_increment if increment is None else increment
        msg.angle_max = msg.angle_min + msg.angle_increment * (self.spec.n - 1)
        msg.range_min, msg.range_max = self.spec.range_min, self.spec.range_max
        msg.ranges = ranges
        self.scan_pub.publish(msg)
        time.sleep(0.04)  # pace the stream (wall clock); the node runs on the test's clock

    def drive(self, t0, x0, x1, step=0.05):
        t = t0
        for x in np.arange(x0, x1 + 1e-9, step):
            t += 0.1
            self.tick(t, (x, 0.0, 0.0))
        return t

    def test_bad_input(self):
        self.tick(0.5, (0.0, 0.0, 0.0))
        self.static_tf.sendTransform(transform(rospy.Time.from_sec(0.5), "base_link", "laser",
                                               MOUNT.x, MOUNT.y, MOUNT.yaw))
        wait_for(lambda: self.scan_pub.get_num_connections() > 0, 30.0, "the mapper on scan")
        t = 1.0
        for _ in range(30):  # until the mapper has started its map
            t += 0.1
            self.tick(t, (0.0, 0.0, 0.0))
            if self.map.count:
                break
        self.map.wait(10.0)
        t = self.drive(t, 0.0, 1.0)
        wait_for(lambda: self.entropy.count >= 3, 20.0, "entropy after 1 m")
        before_jump = self.map.msg.header.stamp

        n = self.spec.n
        # Each kind of bad scan is sent until its warning arrives (the mapper queues only
        # the newest scans: one alone may be pushed out unseen), then EXTRA more of it,
        # which the per-kind throttle (WARN_PERIOD_S of wall time) must keep quiet.
        kinds = ((([], "laser", None), ("empty scan",)),
                 (([float("nan")] * n, "laser", None),
                  ("no valid range in the scan (%d beams" % n,)),
                 (([1.0] * n, "no_such_frame", None),
                  ("scan in frame 'no_such_frame' dropped", "no TF")),
                 (([1.0] * n, "laser", 0.0), ("angle_increment is 0",)),
                 (([1.0] * n, "", None), ("scan without frame_id",)))
        windows = []
        for (ranges, frame, inc), words in kinds:
            start = time.monotonic()
            deadline = start + 20.0
            extra = EXTRA
            while extra > 0:
                if time.monotonic() > deadline:
                    self.fail("no warning %s from %s in 20 s" % (words, NODE))
                t += 0.1
                self.tick(t, (1.0, 0.0, 0.0), ranges=ranges, frame=frame, increment=inc)
                if self.warnings(words, start):
                    extra -= 1
            windows.append((words, start))
        end = time.monotonic()
        for words, start in windows:
            assert_throttled(self.warnings(words, start), WARN_PERIOD_S, start, end,
                             clock="wall_s", what="warning %s" % (words,))
        count = self.entropy.count
        t = self.drive(t, 1.0, 1.6)
        wait_for(lambda: self.entropy.count > count, 20.0, "entropy after the bad scans")

        # bag loop: the clock jumps back to 1.0 s and the robot is at the start again
        maps = self.map.count
        start = time.monotonic()
        t = self.drive(1.0, 0.0, 0.8)
        wait_for(lambda: self.map.count > maps and self.map.msg.header.stamp < before_jump,
                 20.0, "a new map after the clock jumped back")
        words = ("time went backwards by", "map reset")
        self.log.wait_for(20.0, "the mapper's warning about the clock", node=NODE,
                          level="warn", contains=words, since_wall_s=start)
        # one jump, one warning (the reset is not repeated for the scans after it)
        self.assertEqual(len(self.warnings(words, start)), 1)
        count = self.entropy.count
        self.drive(t, 0.8, 1.4)
        wait_for(lambda: self.entropy.count > count, 20.0, "entropy after the jump")
        grid = np.asarray(self.map.msg.data)
        self.assertTrue(set(np.unique(grid).tolist()) <= {-1, 0, 100})


if __name__ == "__main__":
    rostest.rosrun("ascc_navigation", "mapper_bad_input", MapperBadInputTest, sys.argv)
