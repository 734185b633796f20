#!/usr/bin/env python3
"""rostest: bad input to the amcl and move_base stand-ins, and what they promise beyond the
office run (see bad_input.test).

The test owns the world: it publishes /clock, TF odom -> base_link (robot standing at
(2, 2) of ``synthetic.office_world``) and base_link -> laser, the map, and scans ray-cast
on the map from a background thread; the robot does not move, whatever cmd_vel says.
Bad input must be answered by the promised warning on /rosout, naming what was wrong, at
most once per throttle period (``WARN_PERIOD_S`` of ROS time, rospy's logwarn_throttle).
Besides: move_base stops the robot when its pose or the scan goes stale and resumes after,
``move_base_simple/goal`` starts a goal; amcl re-initialises on ``initialpose`` and spreads
its particles over the free space on ``global_localization``. Waits are on conditions with
wall-clock timeouts.
"""
import math
import re
import sys
import threading
import time
import unittest

import actionlib
import numpy as np
import rospy
import rostest
import tf2_ros
from actionlib_msgs.msg import GoalStatus, GoalStatusArray
from geometry_msgs.msg import (
    PoseArray,
    PoseStamped,
    PoseWithCovarianceStamped,
    TransformStamped,
    Twist,
)
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Empty

from ascc_common.grid import FREE, OCCUPIED, grid_to_msg_data
from ascc_common.pose2d import yaw_of
from ascc_navigation import synthetic as syn
from ascc_navigation.laser import LaserMount
from ascc_testing.rosout import RosoutWatcher, assert_throttled
from ascc_testing.waits import Latest, wait_for

POSE = (2.0, 2.0, 0.3)  # true robot pose in the map; odom starts there
MOUNT = LaserMount(0.1, 0.0, 0.0)
SIM_DT = 0.01  # [s] of simulated time per clock tick
WARN_PERIOD_S = 5.0  # both nodes' throttle period (ROS time)
SCAN_TIMEOUT_S = 0.5  # move_base stand_in/scan_timeout_s (config/move_base.yaml)
POSE_MAX_AGE_S = 0.5 + 1.0  # move_base: transform_tolerance + 1 s


class FakeWorld:
    """Clock, TF and scans of a standing robot, in a thread; ``scan_override`` replaces
    the next scans' frame and ranges (bad input). The scans go to amcl on ``scan`` and to
    move_base on ``nav_scan`` (bad_input.test remaps it), so that move_base's scan can go
    stale while amcl keeps the pose (TF map -> odom) fresh: ``send_nav_scans`` False stops
    them, ``send_odom_tf`` False the odometry TF (and so amcl's TF: a stale pose)."""

    def __init__(self):
        self.grid, self.info = syn.office_world()
        self.spec = syn.LaserSpec()
        self.ranges = syn.simulate_scan(self.grid == OCCUPIED, self.info, POSE, MOUNT,
                                        self.spec, np.random.default_rng(0))
        self.clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
        self.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=5)
        self.nav_scan_pub = rospy.Publisher("nav_scan", LaserScan, queue_size=5)
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.tf = tf2_ros.TransformBroadcaster()
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self.t = 100.0
        self.scan_override = None  # (frame, ranges) for bad scans
        self.send_nav_scans = True
        self.send_odom_tf = True
        self.lock = threading.Lock()
        self.running = True
        self.thread = threading.Thread(target=self.run, daemon=True)

    def start(self):
        laser = self.transform("base_link", "laser", (MOUNT.x, MOUNT.y, MOUNT.yaw), 0.0)
        self.static_tf.sendTransform(laser)
        m = OccupancyGrid()
        m.header.frame_id = "map"
        m.info.resolution = self.info.resolution
        m.info.width, m.info.height = self.info.width, self.info.height
        m.info.origin.orientation.w = 1.0
        m.data = grid_to_msg_data(self.grid)
        self.map_pub.publish(m)
        self.thread.start()

    @staticmethod
    def transform(parent, child, pose, stamp):
        t = TransformStamped()
        t.header.stamp = rospy.Time.from_sec(stamp)
        t.header.frame_id, t.child_frame_id = parent, child
        t.transform.translation.x, t.transform.translation.y = pose[0], pose[1]
        t.transform.rotation.z, t.transform.rotation.w = math.sin(pose[2] / 2), \
            math.cos(pose[2] / 2)
        return t

    def now(self):
        with self.lock:
            return self.t

    def jump_back(self, seconds):
        with self.lock:
            self.t -= seconds

    def run(self):
        tick = 0
        while self.running and not rospy.is_shutdown():
            with self.lock:
                self.t += SIM_DT
                now = self.t
            self.clock_pub.publish(Clock(clock=rospy.Time.from_sec(now)))
            if tick % 10 == 0:  # 10 Hz of simulated time
                if self.send_odom_tf:
                    self.tf.sendTransform(self.transform("odom", "base_link", (0.0, 0.0, 0.0),
                                                         now))
                scan = self.scan(now)
                self.scan_pub.publish(scan)
                if self.send_nav_scans:
                    self.nav_scan_pub.publish(scan)
            tick += 1
            time.sleep(0.002)

    def scan(self, now):
        frame, ranges = "laser", self.ranges
        if self.scan_override is not None:
            frame, ranges = self.scan_override
        msg = LaserScan()
        msg.header.stamp = rospy.Time.from_sec(now)
        msg.header.frame_id = frame
        msg.angle_min = self.spec.angle_min
        msg.angle_max = self.spec.angle_min + self.spec.angle_increment * (self.spec.n - 1)
        msg.angle_increment = self.spec.angle_increment
        msg.range_min, msg.range_max = self.spec.range_min, self.spec.range_max
        msg.ranges = list(ranges)
        return msg


class Commands:
    """Every cmd_vel the navigator sends, in arrival order (one connection: send order)."""

    def __init__(self):
        self.all = []
        self.lock = threading.Lock()
        self.sub = rospy.Subscriber("cmd_vel", Twist, self._cb, queue_size=100)

    def _cb(self, msg):
        with self.lock:
            self.all.append(msg.linear.x != 0.0 or msg.angular.z != 0.0)  # True: moving

    def count(self):
        with self.lock:
            return len(self.all)

    def since(self, index):
        with self.lock:
            return self.all[index:]


def first_number(pattern, text):
    m = re.search(pattern, text)
    if m is None:
        raise AssertionError("%r not in %r" % (pattern, text))
    return float(m.group(1))


def spread_m(poses):
    """Root of the summed x and y variances of a PoseArray's positions [m]."""
    xy = np.array([(p.position.x, p.position.y) for p in poses.poses])
    return float(np.sqrt(xy.var(axis=0).sum()))


class BadInputTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("bad_input_test")
        cls.log = RosoutWatcher()
        cls.world = FakeWorld()
        cls.amcl = Latest("amcl_pose", PoseWithCovarianceStamped)
        cls.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        cls.cmds = Commands()
        cls.status = Latest("move_base/status", GoalStatusArray)
        cls.current_goal = Latest("move_base/current_goal", PoseStamped)
        cls.cloud = Latest("particlecloud", PoseArray, keep_all=True)
        cls.simple_goal = rospy.Publisher("move_base_simple/goal", PoseStamped, queue_size=1)
        cls.initial_pose = rospy.Publisher("initialpose", PoseWithCovarianceStamped,
                                           queue_size=1)
        cls.log.wait_for_connection()
        cls.world.start()

    @classmethod
    def tearDownClass(cls):
        cls.world.running = False

    def setUp(self):  # a failed test must not leave the next one with bad input
        self.world.scan_override = None
        self.world.send_nav_scans = self.world.send_odom_tf = True

    # -- helpers ------------------------------------------------------------------------
    def nomotion_pose(self, what):
        """Ask amcl for a filter update of the standing robot; returns the next amcl_pose
        (x, y, yaw)."""
        count = self.amcl.count
        # amcl_pose comes with filter updates; a no-motion update makes one happen
        rospy.ServiceProxy("request_nomotion_update", Empty)()
        wait_for(lambda: self.amcl.count > count, 30.0, "amcl_pose after %s" % what)
        p = self.amcl.msg.pose.pose
        return p.position.x, p.position.y, yaw_of(p.orientation)

    def poses_keep_coming(self, what):
        x, y, _ = self.nomotion_pose(what)
        self.assertLess(math.hypot(x - POSE[0], y - POSE[1]), 0.3, what)

    def wait_pose_near(self, target, tol_m, what, timeout_s=30.0):
        """No-motion updates until amcl_pose is within tol_m of target; returns it."""
        deadline = time.monotonic() + timeout_s
        while True:
            x, y, yaw = self.nomotion_pose(what)
            if math.hypot(x - target[0], y - target[1]) < tol_m:
                return x, y, yaw
            if time.monotonic() > deadline:
                self.fail("%s: amcl_pose (%.2f, %.2f) not within %.2f m of (%.2f, %.2f)"
                          % (what, x, y, tol_m, *target[:2]))

    def warned(self, node, words, since, what, timeout_s=30.0):
        return self.log.wait_for(timeout_s, what, node=node, level="warn", contains=words,
                                 since_wall_s=since)

    def assert_throttled_since(self, node, words, since, t0, t1, what):
        """The warnings ``words`` of ``node`` received since wall time ``since`` came at
        most once per WARN_PERIOD_S of ROS time. Their window is the ROS time the bad
        input lasted, [t0, t1] of the test's clock, widened to the records' own stamps
        (a node's clock may lag the test's)."""
        records = self.log.matching(node=node, level="warn", contains=words,
                                    since_wall_s=since)
        stamps = [r.stamp_s for r in records]
        return assert_throttled(records, WARN_PERIOD_S, min([t0] + stamps),
                                max([t1] + stamps), what="%s warning %s" % (node, words))

    def publish_initial_pose(self, frame, x, y, yaw, var_xy, var_yaw):
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = frame
        msg.header.stamp = rospy.Time.now()
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        msg.pose.pose.orientation.z = math.sin(yaw / 2)
        msg.pose.pose.orientation.w = math.cos(yaw / 2)
        cov = np.zeros((6, 6))
        cov[0, 0] = cov[1, 1] = var_xy
        cov[5, 5] = var_yaw
        msg.pose.covariance = cov.ravel().tolist()
        wait_for(lambda: self.initial_pose.get_num_connections() > 0, 30.0,
                 "amcl on initialpose")
        self.initial_pose.publish(msg)

    def goal_status(self, goal_id):
        for s in self.status.msg.status_list if self.status.msg else []:
            if s.goal_id.id == goal_id:
                return s.status
        return None

    def wait_moving_since(self, index, what, timeout_s=30.0):
        wait_for(lambda: any(self.cmds.since(index)), timeout_s,
                 "a non-zero cmd_vel: %s" % what)

    def assert_stops(self, goal_id, words, what):
        """The robot, moving towards ``goal_id``, was just made blind or lost: move_base
        warns (``words``) and stops it: a zero command, and no other for the next second of
        simulated time (10 control cycles); the goal stays ACTIVE. Returns the warning."""
        start = self.cmds.count()
        record = self.warned("/move_base", words, time.monotonic(),
                             "move_base's warning: %s" % what)
        # Commands arrive in send order, so a command sent before the stop arrives before
        # the stop's zero: from the first zero that follows the warning on, all are zero.
        after = self.cmds.count() - start
        wait_for(lambda: False in self.cmds.since(start)[after:], 30.0,
                 "a zero cmd_vel after the warning (%s)" % what)
        first_zero = start + after + self.cmds.since(start)[after:].index(False)
        t = self.world.now()
        wait_for(lambda: self.world.now() > t + 1.0, 30.0, "1 s of simulated time")
        self.assertNotIn(True, self.cmds.since(first_zero),
                         "robot driven after it was stopped (%s)" % what)
        self.assertEqual(self.goal_status(goal_id), GoalStatus.ACTIVE,
                         "the goal should stay active while %s" % what)
        return record

    # -- tests --------------------------------------------------------------------------
    def test_1_amcl_warns_about_bad_scans_and_time_jumps(self):
        self.amcl.wait(60.0)
        self.poses_keep_coming("start-up")
        n = self.world.spec.n
        no_range = ("scan in 'laser' has no valid range",)
        kinds = ((("laser", []), no_range + ("(0 beams",)),
                 (("laser", [float("nan")] * n), no_range + ("(%d beams" % n,)),
                 (("laser", [float("inf")] * n), no_range + ("(%d beams" % n,)),
                 (("no_such_frame", [1.0] * n), ("no usable transform", "'no_such_frame'")),
                 (("", [1.0] * n), ("empty frame_id",)))
        since, t0 = time.monotonic(), self.world.now()
        for override, words in kinds:
            # One call site warns about all scans without a valid range, throttled as one:
            # each kind is sent until its own warning arrives (NaN's and inf's only after
            # the period), which proves the node saw it.
            self.world.scan_override = override
            self.warned("/amcl", words, time.monotonic(), "amcl's warning about %s" % (words,))
        t1 = self.world.now()
        self.world.scan_override = None
        for words in (no_range, kinds[3][1], kinds[4][1]):
            self.assert_throttled_since("/amcl", words, since, t0, t1, "bad scans")
        self.assertEqual(len(self.log.matching(node="/amcl", level="warn", contains=no_range,
                                               since_wall_s=since)), 3)
        self.poses_keep_coming("bad scans")

        last = self.amcl.msg.header.stamp.to_sec()
        since = time.monotonic()
        self.world.jump_back(60.0)  # a bag loop
        wait_for(lambda: self.amcl.msg.header.stamp.to_sec() < last - 30.0, 30.0,
                 "amcl_pose stamped after the jump back")
        for node, pattern in (("/amcl", r"scan time went back by ([0-9.]+) s"),
                              ("/move_base", r"time went back by ([0-9.]+) s")):
            rec = self.warned(node, "time went back", since, "%s: time went back" % node)
            # by 60 s less the simulated time between the last scan (control cycle)
            # before and the first after the jump
            self.assertTrue(55.0 < first_number(pattern, rec.text) <= 60.001, rec.text)
            self.assertEqual(len(self.log.matching(node=node, level="warn",
                                                   contains="time went back",
                                                   since_wall_s=since)), 1, node)
        self.poses_keep_coming("the clock jumped back")

    def send_bad_goal(self, frame, x, words):
        g = MoveBaseGoal()
        g.target_pose.header.frame_id = frame
        g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, 2.0
        g.target_pose.pose.orientation.w = 1.0
        self.client.send_goal(g)
        wait_for(lambda: self.client.get_state() == GoalStatus.ABORTED, 20.0,
                 "goal in '%s' at x=%s aborted" % (frame, x))
        self.assertIn(words, self.client.get_goal_status_text())

    def test_2_move_base_rejects_bad_goals(self):
        self.assertTrue(self.client.wait_for_server(rospy.Duration(30.0)))
        since, t0 = time.monotonic(), self.world.now()
        # Each bad goal is aborted with its reason. The warning is throttled per call site:
        # a goal in an unknown frame twice in a row gives one warning; then goals with NaN
        # (one per 0.5 s of simulated time) until the period is over and theirs comes.
        for _ in range(2):
            self.send_bad_goal("no_such_frame", 3.0, "no_such_frame")
            self.warned("/move_base", ("aborting goal", "no_such_frame"), since,
                        "move_base's warning about a goal in an unknown frame")
        deadline = time.monotonic() + 60.0
        nan_words = ("aborting goal", "goal position has NaN")
        while not self.log.matching(node="/move_base", level="warn", contains=nan_words,
                                    since_wall_s=since):
            if time.monotonic() > deadline:
                self.fail("no warning about a NaN goal in 60 s")
            self.send_bad_goal("map", float("nan"), "NaN")
            t = self.world.now()
            wait_for(lambda t=t: self.world.now() > t + 0.5, 10.0, "0.5 s of simulated time")
        self.assert_throttled_since("/move_base", "aborting goal", since, t0,
                                    self.world.now(), "bad goals")
        # after all that, and after a jump back, a good goal is still served (stamped
        # before the bad ones, which actionlib's SimpleActionServer held against it)
        since = time.monotonic()
        self.world.jump_back(20.0)
        self.warned("/move_base", "time went back", since, "move_base: time went back")
        g = MoveBaseGoal()
        g.target_pose.header.frame_id = "map"
        g.target_pose.pose.position.x, g.target_pose.pose.position.y = 2.5, 2.0
        g.target_pose.pose.orientation.w = 1.0
        self.client.send_goal(g)
        wait_for(lambda: self.client.get_state() in (GoalStatus.ACTIVE, GoalStatus.SUCCEEDED),
                 20.0, "a valid goal to be accepted")
        self.client.cancel_goal()
        wait_for(lambda: self.client.get_state() == GoalStatus.PREEMPTED, 20.0, "PREEMPTED")
        # and move_base/status keeps coming without goal transitions (5 Hz, actionlib's)
        t = rospy.get_time()
        wait_for(lambda: self.status.msg.header.stamp.to_sec() > t + 1.0, 20.0,
                 "move_base/status 1 s after the goal ended")

    def test_3_move_base_simple_goal_and_stale_inputs(self):
        """move_base_simple/goal starts a goal as the action does; a stale scan, then a
        stale pose stop the robot with a warning and keep the goal, which resumes."""
        self.assertTrue(self.client.wait_for_server(rospy.Duration(30.0)))
        wait_for(lambda: self.simple_goal.get_num_connections() > 0, 30.0,
                 "move_base on move_base_simple/goal")
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.header.stamp = rospy.Time.now()
        goal.pose.position.x, goal.pose.position.y = 2.6, 2.1
        goal.pose.orientation.w = 1.0
        start = self.cmds.count()
        self.simple_goal.publish(goal)

        def started():
            g = self.current_goal.msg
            return g is not None and math.hypot(g.pose.position.x - 2.6,
                                                g.pose.position.y - 2.1) < 1e-6
        wait_for(started, 30.0, "move_base/current_goal (2.6, 2.1) from the simple goal")
        wait_for(lambda: self.status.msg is not None and any(
            s.status == GoalStatus.ACTIVE for s in self.status.msg.status_list), 30.0,
            "an ACTIVE goal on move_base/status")
        goal_id = [s.goal_id.id for s in self.status.msg.status_list
                   if s.status == GoalStatus.ACTIVE][0]
        self.wait_moving_since(start, "the simple goal drives the robot")

        # blind: no scan for longer than scan_timeout_s
        since, t0 = time.monotonic(), self.world.now()
        self.world.send_nav_scans = False
        words = ("no laser scan newer than %.1f s" % SCAN_TIMEOUT_S, "stopped")
        self.assert_stops(goal_id, words, "no scan arrives")
        self.assert_throttled_since("/move_base", words, since, t0, self.world.now(),
                                    "stale scan")
        start = self.cmds.count()
        self.world.send_nav_scans = True
        self.wait_moving_since(start, "scans are back")

        # lost: the pose (TF map -> base_link) stops being updated
        since, t0 = time.monotonic(), self.world.now()
        self.world.send_odom_tf = False
        words = ("robot pose is", "s old; stopped")
        rec = self.assert_stops(goal_id, words, "the pose is stale")
        self.assertGreater(first_number(r"robot pose is ([0-9.]+) s old", rec.text),
                           POSE_MAX_AGE_S - 0.05, rec.text)  # printed with one decimal
        self.assert_throttled_since("/move_base", words, since, t0, self.world.now(),
                                    "stale pose")
        start = self.cmds.count()
        self.world.send_odom_tf = True
        self.wait_moving_since(start, "the pose is back")

        self.client.cancel_all_goals()
        wait_for(lambda: self.goal_status(goal_id) == GoalStatus.PREEMPTED, 20.0,
                 "the simple goal PREEMPTED by a cancel")
        self.poses_keep_coming("stale inputs")

    def test_4_amcl_initialpose_reinitialises(self):
        self.amcl.wait(60.0)
        self.poses_keep_coming("test start")
        # invalid initial poses: warned and dropped
        since = time.monotonic()
        self.publish_initial_pose("odom", 3.5, 2.5, 0.3, 0.01, 0.003)
        self.warned("/amcl", ("ignoring initial pose in frame 'odom'",), since,
                    "amcl's warning about an initial pose in 'odom'")
        self.publish_initial_pose("map", float("nan"), 2.5, 0.3, 0.01, 0.003)
        self.warned("/amcl", ("ignoring initial pose with NaN",), since,
                    "amcl's warning about a NaN initial pose")
        self.poses_keep_coming("invalid initial poses")
        # a valid one 1.6 m from the truth: the particles are re-centred there. A no-motion
        # update only re-weights and resamples them, so the estimate stays inside the new
        # cloud: 0.25 m = 5 sigma of it
        target = (3.5, 2.5, 0.3)
        since = time.monotonic()
        self.publish_initial_pose("map", *target, 0.05 ** 2, 0.05 ** 2)
        self.log.wait_for(30.0, "amcl's log of the new initial pose", node="/amcl",
                          contains="initial pose (3.50, 2.50, 0.30)", since_wall_s=since)
        x, y, _ = self.wait_pose_near(target, 0.25, "initial pose at (3.5, 2.5)")
        rospy.loginfo("bad_input: amcl_pose after initialpose (3.5, 2.5): (%.3f, %.3f)", x, y)
        # and back at the truth
        self.publish_initial_pose("map", *POSE, 0.05 ** 2, 0.05 ** 2)
        x, y, _ = self.wait_pose_near(POSE, 0.25, "initial pose at the truth")
        rospy.loginfo("bad_input: amcl_pose after initialpose (2.0, 2.0): (%.3f, %.3f)", x, y)

    def test_5_amcl_global_localization(self):
        """global_localization spreads the particles over the free space. The cloud is
        published after a filter update only; so that this update cannot concentrate it,
        the scans then carry a single valid beam (one beam moves a particle's weight by a
        factor of 3 at most; 30 beams lock the sharp tracking model onto a few places)."""
        self.amcl.wait(60.0)
        self.poses_keep_coming("test start")
        wait_for(lambda: self.cloud.count > 0, 30.0, "a particle cloud")
        tracking = spread_m(self.cloud.msg)
        one_beam = [float("nan")] * self.world.spec.n
        mid = self.world.spec.n // 2
        one_beam[mid] = float(self.world.ranges[mid])
        self.world.scan_override = ("laser", one_beam)
        t = self.world.now()  # amcl's filter must have seen those scans before the call
        deadline = time.monotonic() + 30.0
        while self.amcl.msg.header.stamp.to_sec() <= t:
            if time.monotonic() > deadline:
                self.fail("no amcl_pose from the one-beam scans in 30 s")
            self.nomotion_pose("one-beam scans")
        since = time.monotonic()
        rospy.ServiceProxy("global_localization", Empty)()
        self.log.wait_for(30.0, "amcl's log of the global localization", node="/amcl",
                          contains="global localization", since_wall_s=since)
        count = self.cloud.count
        # the cloud comes with a filter update, at most every 1 / gui_publish_rate
        deadline = time.monotonic() + 30.0
        while self.cloud.count == count:
            if time.monotonic() > deadline:
                self.fail("no particle cloud after global_localization in 30 s")
            self.nomotion_pose("global localization")
        self.world.scan_override = None
        cloud = self.cloud.all[count]  # the first after global_localization
        grid, info = self.world.grid, self.world.info
        iy, ix = np.nonzero(grid == FREE)
        fx, fy = info.cell_to_world(ix, iy)
        free = float(np.sqrt(fx.var() + fy.var()))  # spread of the free space itself
        spread = spread_m(cloud)
        rospy.loginfo("bad_input: particle spread %.2f m tracking, %.2f m after "
                      "global_localization (%d particles), free space %.2f m", tracking,
                      spread, len(cloud.poses), free)
        self.assertLess(tracking, 0.5)
        self.assertGreater(spread, 0.8 * free, "particles not spread over the free space")
        ix, iy = info.world_to_cell([p.position.x for p in cloud.poses],
                                    [p.position.y for p in cloud.poses])
        inside = (ix >= 0) & (ix < info.width) & (iy >= 0) & (iy < info.height)
        self.assertTrue(inside.all(), "particles off the map")
        self.assertTrue((grid[iy, ix] == FREE).all(), "particles off the free space")
        # leave amcl localized
        self.publish_initial_pose("map", *POSE, 0.01, 0.003)
        self.wait_pose_near(POSE, 0.3, "initial pose at the truth")


if __name__ == "__main__":
    rostest.rosrun("ascc_navigation", "bad_input", BadInputTest, sys.argv)
