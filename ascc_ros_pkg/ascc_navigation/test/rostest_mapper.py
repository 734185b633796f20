#!/usr/bin/env python3
"""rostest: the slam_gmapping stand-in maps part of the simulated office.

The robot is driven along ``~waypoints`` (world frame) by a simple controller on the
simulator's ground truth. Before, while it stands at the start, bad scans (empty, all NaN,
unknown frame) are published on ``scan``, each kind until the mapper's warning naming it
has come on /rosout (at most once per 5 s of wall time). Then: the map agrees with
``ground_truth/map`` (>= ``~min_accuracy`` of the known cells), holds only -1/0/100,
``dynamic_map`` serves it, the entropy was published, and TF map -> base_link matches the
true pose. Waits are on conditions with wall-clock timeouts, never fixed sleeps.
"""
import math
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.srv import GetMap
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from ascc_common.grid import map_from_msg
from ascc_common.pose2d import compose, inverse, wrap_angle, yaw_from_quaternion
from ascc_navigation.grid import map_agreement
from ascc_testing.rosout import RosoutWatcher, assert_throttled
from ascc_testing.waits import Latest, pose_of, wait_for

NODE = "/slam_gmapping"
WARN_PERIOD_S = 5.0  # the mapper's per-kind warning period (wall clock)
EXTRA = 5  # bad scans of a kind sent after its warning


class MapperTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("mapper_test")
        robot = rospy.get_param("~robot", "asccbot")
        cls.waypoints = [tuple(w) for w in rospy.get_param("~waypoints")]
        cls.min_accuracy = float(rospy.get_param("~min_accuracy", 0.95))
        cls.max_pose_error_m = float(rospy.get_param("~max_pose_error_m", 0.15))
        cls.drive_timeout_s = float(rospy.get_param("~drive_timeout_s", 150.0))
        cls.truth = Latest("ground_truth/%s/odom" % robot, Odometry)
        cls.start = Latest("ground_truth/%s/start_pose" % robot, PoseStamped)
        cls.truth_map = Latest("ground_truth/map", OccupancyGrid)
        cls.map = Latest("map", OccupancyGrid)
        cls.entropy = Latest("slam_gmapping/entropy", Float64)
        cls.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        cls.bad_scans = rospy.Publisher("scan", LaserScan, queue_size=5)
        cls.lock = threading.Lock()
        cls.bad = None  # (frame, ranges) of the bad scans to send, or None
        cls.bad_sent = 0
        cls.log = RosoutWatcher()
        cls.log.wait_for_connection()
        cls.sim_scan = None  # the newest simulator scan
        cls.scan_sub = rospy.Subscriber("scan", LaserScan, cls.on_scan, queue_size=5)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)

    @classmethod
    def on_scan(cls, msg):
        """Right after a simulator scan, the bad scan of the current kind with its stamp:
        the mapper queues the newest scans and feeds them to its filter in order, so the
        bad scan is processed right after the simulator scan (with the same TF).
        If this callback lags the mapper by a scan period (0.02 s of wall time at factor
        5, under load), the mapper has processed a newer scan: the bad one's time went
        back, and the mapper resets its map (bag loop rule), which at the start, where the
        robot stands, the later checks do not notice."""
        if msg._connection_header.get("callerid") == rospy.get_name():
            return  # our own
        with cls.lock:
            cls.sim_scan = msg
            bad = cls.bad
        if bad is None:
            return
        out = LaserScan()
        out.header.stamp = msg.header.stamp
        out.header.frame_id, out.ranges = bad
        out.angle_min, out.angle_max = msg.angle_min, msg.angle_max
        out.angle_increment = msg.angle_increment
        out.range_min, out.range_max = msg.range_min, msg.range_max
        cls.bad_scans.publish(out)
        with cls.lock:
            cls.bad_sent += 1

    def publish_bad_scans(self):
        """Scans the mapper must warn about (naming the problem, each kind at most once per
        WARN_PERIOD_S of wall time) and drop: each kind until its warning has come, then
        EXTRA more that the throttle must keep quiet."""
        wait_for(lambda: self.bad_scans.get_num_connections() > 0, 30.0, "the mapper on scan")
        wait_for(lambda: self.sim_scan is not None, 30.0, "a simulator scan")
        n = len(self.sim_scan.ranges)
        windows = []
        for frame, ranges, words in (
                ("laser", [], ("empty scan",)),
                ("laser", [float("nan")] * n, ("no valid range in the scan (%d beams" % n,)),
                ("no_such_frame", [1.0] * n, ("scan in frame 'no_such_frame' dropped",
                                              "no TF"))):
            start = time.monotonic()
            with self.lock:
                type(self).bad = (frame, ranges)
            wait_for(lambda w=words, t=start: self.bad_scan_warnings(w, t), 30.0,
                     "the mapper's warning %s" % (words,))
            sent = self.bad_sent
            wait_for(lambda s=sent: self.bad_sent >= s + EXTRA, 30.0,
                     "%d more bad scans %s" % (EXTRA, words))
            windows.append((words, start))
        with self.lock:
            type(self).bad = None
        self.scan_sub.unregister()
        end = time.monotonic()
        for words, start in windows:
            assert_throttled(self.bad_scan_warnings(words, start), WARN_PERIOD_S, start, end,
                             clock="wall_s", what="warning %s" % (words,))

    def bad_scan_warnings(self, words, since):
        """The mapper's warnings ``words`` since wall time ``since``, without those of a
        reset (a warning kind of its own, see on_scan)."""
        return [r for r in self.log.matching(node=NODE, level="warn", contains=words,
                                             since_wall_s=since)
                if "time went backwards" not in r.text]

    def drive_route(self):
        rate = rospy.Rate(20.0)  # simulated time
        deadline = time.monotonic() + self.drive_timeout_s
        for wx, wy in self.waypoints:
            while True:
                self.assertLess(time.monotonic(), deadline, "route not finished in time")
                x, y, yaw = pose_of(self.truth.msg)
                dist = math.hypot(wx - x, wy - y)
                if dist < 0.1:
                    break
                err = float(wrap_angle(math.atan2(wy - y, wx - x) - yaw))
                t = Twist()
                t.angular.z = max(-0.8, min(0.8, 2.0 * err))
                t.linear.x = 0.0 if abs(err) > 0.3 else min(0.3, 0.8 * dist)
                self.cmd.publish(t)
                rate.sleep()
        self.cmd.publish(Twist())

    def test_map_part_of_the_office(self):
        self.truth.wait(90.0)
        start = pose_of(self.start.wait(30.0))
        truth_msg = self.truth_map.wait(30.0)
        self.map.wait(60.0)  # the mapper has started on the first scans
        wait_for(lambda: self.cmd.get_num_connections() > 0, 30.0, "the driver on cmd_vel")
        self.publish_bad_scans()
        self.drive_route()
        entropies = self.entropy.count
        # The last filter update is published within map_update_interval (simulated time).
        settle = rospy.Time.now() + rospy.Duration(
            rospy.get_param("slam_gmapping/map_update_interval", 5.0) + 1.0)
        wait_for(lambda: rospy.Time.now() > settle, 60.0, "the final map to be published")

        msg = self.map.msg
        grid, info = map_from_msg(msg)
        self.assertTrue(set(np.unique(grid).tolist()) <= {-1, 0, 100})
        self.assertEqual(msg.header.frame_id, "map")
        truth, truth_info = map_from_msg(truth_msg)
        res = map_agreement(grid, info, truth, truth_info, offset=start)
        rospy.loginfo("mapper rostest: %s", res)
        self.assertGreater(res["known"], 5000, "the map should cover part of the office")
        self.assertGreaterEqual(res["accuracy"], self.min_accuracy, str(res))

        served = rospy.ServiceProxy("dynamic_map", GetMap)(GetMap._request_class()).map
        self.assertEqual((served.info.width, served.info.height),
                         (msg.info.width, msg.info.height))
        served_grid, _ = map_from_msg(served)   # checks the cell count
        self.assertTrue(set(np.unique(served_grid).tolist()) <= {-1, 0, 100})
        self.assertGreater(int((served_grid >= 0).sum()), 5000)
        self.assertGreater(entropies, 10)
        h = self.entropy.msg.data
        self.assertTrue(0.0 <= h <= math.log(30) + 1e-6, h)

        # TF map -> base_link (mapper's map->odom, driver's odom->base) vs the truth
        wait_for(lambda: self.tf_buffer.can_transform("map", "base_link", rospy.Time(0)),
                 10.0, "TF map -> base_link")
        tf = self.tf_buffer.lookup_transform("map", "base_link", rospy.Time(0))
        q = tf.transform.rotation
        est = np.array([tf.transform.translation.x, tf.transform.translation.y,
                        yaw_from_quaternion(q.x, q.y, q.z, q.w)])
        true_in_map = compose(inverse(start), pose_of(self.truth.msg))
        err = math.hypot(*(est[:2] - true_in_map[:2]))
        rospy.loginfo("mapper rostest: pose error %.3f m", err)
        self.assertLess(err, self.max_pose_error_m)


if __name__ == "__main__":
    rostest.rosrun("ascc_navigation", "mapper", MapperTest, sys.argv)
