#!/usr/bin/env python3
"""rostest: the real driver node against the virtual Create on a pseudo-terminal.

Checks cmd_vel -> wheel speeds, odometry against the emulator's ground truth (1 m forward
within 2 %, 90 deg turns within 2 deg), the watchdog, NaN and saturated twists, the bump
rule, hazards / battery / diagnostics, every service (and that service motions go through
the watchdog), recovery from a stalled stream (robot power-cycled), garbage on the line,
an unplugged-and-replugged port, and - on a second pair in full mode without TF - the
mode, the missing TF and that shutting the driver down stops the wheels.

Timing is measured on stamps: the virtual Create stamps every ~wheel_speeds message with
the time it read the commanded speeds, so a property like "stopped cmd_timeout_s after the
command" is checked between the command's publication time and that stamp, or between two
stamps of the same stream, never against when this (possibly starved) process woke up.
Every warning the README promises is checked on /rosout: it names what was wrong and comes
at most once per throttle period (WARN_PERIOD_S in nodes/driver).
"""
import glob
import json
import math
import os
import threading
import unittest

import rosgraph
import rosnode
import rospkg
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Twist, Vector3Stamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState
from std_srvs.srv import SetBool, Trigger
from tf2_msgs.msg import TFMessage

from ascc_common.pose2d import wrap_angle, yaw_of
from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import Latest, wait_for
from irobot_create_2_1.models import model
from irobot_create_2_1.msg import Hazards, LightBumper, SensorPacket
from irobot_create_2_1.srv import Brake, Circle, Dock, Leds, Song, Tank, Turn

WARN_PERIOD_S = 5.0              # the driver's throttle period for each kind of warning
CMD_PERIOD_S = 1.0 / 20.0        # driver ~cmd_rate_hz (default)
WHEEL_PUB_PERIOD_S = 1.0 / 50.0  # virtual_create ~publish_rate_hz (default)
STEP_PERIOD_S = 1.0 / 200.0      # virtual_create ~rate_hz (default)
# One late timer tick of the driver on a loaded 2-core machine; added once to bounds that
# are otherwise sums of the periods above.
SCHEDULING_S = 0.1
SENSOR_TIMEOUT_S = 1.0           # driver ~sensor_timeout_s (default)
DRIVER = "/driver"
OPT = "/opt"                     # the second pair: mode full, publish_tf false


def stamp(msg):
    return msg.header.stamp.to_sec()


def stopped(m):
    return m.vector.x == 0 and m.vector.y == 0


def twist(v, w=0.0):
    msg = Twist()
    msg.linear.x, msg.angular.z = v, w
    return msg


class Driving:
    """Publishes a twist at 20 Hz from a thread (a controller that keeps the watchdog fed)
    until the block ends; ``set`` changes the twist."""

    def __init__(self, pub, v, w=0.0):
        self.pub, self.msg = pub, twist(v, w)
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def set(self, v, w=0.0):
        self.msg = twist(v, w)

    def _run(self):
        while not self.done.is_set() and not rospy.is_shutdown():
            self.pub.publish(self.msg)
            self.done.wait(CMD_PERIOD_S)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.done.set()
        self.thread.join(1.0)


def first(latest, predicate, after=None):
    """Oldest kept message of ``latest`` stamped after ``after`` that satisfies predicate
    (messages arrive in stamp order; the scan starts from the newest)."""
    msgs = list(latest.all)
    i = len(msgs) if after is not None else 0
    while i > 0 and stamp(msgs[i - 1]) > after:
        i -= 1
    for m in msgs[i:]:
        if predicate(m):
            return m
    return None


def wait_msg(latest, predicate, timeout_s, what, after=None):
    """Wait for, and return, the oldest message stamped after ``after`` satisfying
    ``predicate`` (AssertionError quoting the newest message otherwise)."""
    try:
        wait_for(lambda: first(latest, predicate, after) is not None, timeout_s, what)
    except AssertionError as exc:
        raise AssertionError("%s (newest on %s: %s)" % (exc, latest.topic, latest.msg)) \
            from None
    return first(latest, predicate, after)


def statuses(diag_array, node_name):
    """{short name: (level, message, {key: value}, hardware_id)} of one node's
    diagnostic statuses."""
    prefix = node_name.lstrip("/") + ": "
    out = {}
    for s in diag_array.status:
        if s.name.startswith(prefix):
            out[s.name[len(prefix):]] = (s.level, s.message,
                                         {kv.key: kv.value for kv in s.values},
                                         s.hardware_id)
    return out


class DriverTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("driver_test")
        cls.rosout = RosoutWatcher()
        cls.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        cls.odom = Latest("odom", Odometry)
        cls.truth = Latest("virtual_create/ground_truth", Odometry)
        cls.wheels = Latest("virtual_create/wheel_speeds", Vector3Stamped, keep_all=True)
        cls.packet = Latest("sensorPacket", SensorPacket, keep_all=True)
        cls.hazards = Latest("hazards", Hazards, keep_all=True)
        cls.battery = Latest("battery", BatteryState, keep_all=True)
        cls.diag = Latest("/diagnostics", DiagnosticArray, keep_all=True)
        cls.tf = Latest("/tf", TFMessage, keep_all=True)
        cls.opt_cmd = rospy.Publisher(OPT + "/cmd_vel", Twist, queue_size=1)
        cls.opt_odom = Latest(OPT + "/odom", Odometry, keep_all=True)
        cls.opt_wheels = Latest(OPT + "/virtual_create/wheel_speeds", Vector3Stamped,
                                keep_all=True)
        cls.cmd_timeout_s = rospy.get_param(DRIVER + "/cmd_timeout_s")
        cls.robot = model(rospy.get_param(DRIVER + "/robot_model", "create_1"))
        cls.create2 = cls.robot.encoder_odometry
        cls.wheel_base_m = cls.robot.wheel_base_m
        cls.port = rospy.get_param(DRIVER + "/port")
        wait_for(lambda: cls.odom.msg is not None, 30.0, "first odom from the driver")
        wait_for(lambda: cls.truth.msg is not None, 30.0, "ground truth")
        wait_for(lambda: cls.cmd.get_num_connections() > 0
                 and cls.opt_cmd.get_num_connections() > 0, 10.0, "cmd_vel subscribers")
        cls.wait_rosout_from([DRIVER, OPT + "/driver"])
        for name in ("set_bump", "inject_garbage", "close_link", "power_cycle", "state"):
            rospy.wait_for_service("virtual_create/" + name, 10.0)
        # the second pair's emulator may register its services after its driver is up
        rospy.wait_for_service(OPT + "/virtual_create/state", 10.0)
        cls.set_bump = rospy.ServiceProxy("virtual_create/set_bump", SetBool)
        cls.vc_state = rospy.ServiceProxy("virtual_create/state", Trigger)
        cls.opt_state = rospy.ServiceProxy(OPT + "/virtual_create/state", Trigger)

    @classmethod
    def wait_rosout_from(cls, nodes):
        """Block until /rosout records of ``nodes`` reach the watcher (a warning logged
        before the connection exists would be lost and a test would fail wrongly)."""
        master = rosgraph.Master(rospy.get_name())
        uris = {master.lookupNode(n) for n in nodes}

        def connected():
            return uris <= {c[1] for c in cls.rosout.sub.impl.get_stats_info()}
        wait_for(connected, 10.0, "/rosout connections from %s" % nodes)

    def tearDown(self):
        self.stop()

    # --- helpers ---------------------------------------------------------------------------
    def stop(self):
        t = rospy.get_time()
        self.cmd.publish(Twist())
        wait_msg(self.wheels, stopped, 5.0, "wheels stop", after=t)

    def state(self, proxy=None):
        return json.loads((proxy or self.vc_state)().message)

    def drive_until(self, v, w, done, timeout_s):
        """Publish (v, w) at 20 Hz until done() is true."""
        with Driving(self.cmd, v, w):
            wait_for(done, timeout_s, "motion to finish")

    def settled(self, what):
        """Robot stopped and the odometry caught up with it: (odom pose, truth pose), both
        from after the stop."""
        t = rospy.get_time()
        self.cmd.publish(Twist())
        stop = wait_msg(self.wheels, stopped, 5.0, what + ": wheels stop", after=t)
        # an odom stamped 20 stream frames (0.3 s) after the stop has integrated them all
        wait_for(lambda: stamp(self.odom.msg) > stamp(stop) + 0.3
                 and stamp(self.truth.msg) > stamp(stop), 5.0, what)
        return self.odom.msg.pose.pose, self.truth.msg.pose.pose

    def diag_after(self, t, what="diagnostics", timeout_s=10.0):
        """The driver's diagnostics from the first /diagnostics message stamped after t."""
        msg = wait_msg(self.diag, lambda m: "serial link" in statuses(m, DRIVER), timeout_s,
                       what, after=t)
        return statuses(msg, DRIVER), stamp(msg)

    def counter(self, st, status, key):
        return int(st[status][2][key])

    def assert_warned(self, t_event, *contains, node=DRIVER, timeout_s=10.0):
        """``node`` warned about an event at ROS time ``t_event`` (text containing every
        string of ``contains``): a new record, or one less than a throttle period before it
        (which covers this event); and no two such records within one period."""
        def records():
            return self.rosout.matching(node=node, level="warn", contains=contains)
        wait_for(lambda: any(r.stamp_s >= t_event - WARN_PERIOD_S for r in records()),
                 timeout_s, "a warning from %s containing %s (its records: %s)"
                 % (node, contains, [r.text for r in self.rosout.matching(node=node)][-5:]))
        stamps = sorted(r.stamp_s for r in records())
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        # 0.1 s: the record's stamp is taken a little after the throttle's clock reading
        self.assertTrue(all(g > WARN_PERIOD_S - 0.1 for g in gaps),
                        "warning %s repeated within the throttle period %.1f s: gaps %s"
                        % (contains, WARN_PERIOD_S, ["%.2f" % g for g in gaps]))
        return [r for r in records() if r.stamp_s >= t_event - WARN_PERIOD_S][0]

    # --- the second pair (full mode, publish_tf false), then its shutdown ------------------
    def test_a1_mode_full(self):
        wait_for(lambda: self.state(self.opt_state)["streaming"], 10.0, "opt stream")
        self.assertEqual(self.state(self.opt_state)["mode"], "full")
        self.assertEqual(self.state()["mode"], "safe")  # the default, on the main pair

    def test_a2_publish_tf_false(self):
        # Both drivers' /tf publishers connected: a transform from either would reach us.
        master = rosgraph.Master(rospy.get_name())
        uris = {master.lookupNode(n) for n in (DRIVER, OPT + "/driver")}
        wait_for(lambda: uris <= {c[1] for c in self.tf.sub.impl.get_stats_info()}, 10.0,
                 "/tf connections from both drivers")
        t = rospy.get_time()
        wait_for(lambda: len([m for m in list(self.opt_odom.all) if stamp(m) > t]) >= 20
                 and any(tr.child_frame_id == "base_link" and stamp(tr) > t
                         for m in list(self.tf.all) for tr in m.transforms),
                 10.0, "20 opt/odom messages and the main driver's TF")
        opt_tf = [(tr.header.frame_id, tr.child_frame_id) for m in list(self.tf.all)
                  for tr in m.transforms if tr.child_frame_id.startswith("opt/")
                  or tr.header.frame_id.startswith("opt/")]
        self.assertEqual(opt_tf, [], "publish_tf:=false but the driver broadcast TF")
        odom = self.opt_odom.msg
        self.assertEqual((odom.header.frame_id, odom.child_frame_id),
                         ("opt/odom", "opt/base_link"))

    def test_a3_shutdown_stops_the_wheels(self):
        with Driving(self.opt_cmd, 0.1):  # commands stay fresh: the watchdog cannot stop it
            wait_msg(self.opt_wheels, lambda m: abs(m.vector.x - 0.1) < 1e-3, 5.0,
                     "opt wheels at 0.1 m/s")
            t_kill = rospy.get_time()
            killed, failed = rosnode.kill_nodes([OPT + "/driver"])
            self.assertEqual((killed, failed), ([OPT + "/driver"], []))
            # The virtual Create has no watchdog: only the driver's last words stop it.
            wait_msg(self.opt_wheels, stopped, 10.0, "opt wheels stopped by the shutdown",
                     after=t_kill)
            wait_for(lambda: not rosnode.rosnode_ping(OPT + "/driver", max_count=1), 10.0,
                     "the opt driver to exit")
            last = self.opt_wheels.msg
        self.assertTrue(stopped(last), "wheels moving again after the shutdown: %s" % last)
        # Stopping must not look like a lost port: the reader thread, blocked in a read,
        # used to see the port closed under it, warn "lost <port> (... 'NoneType' object
        # cannot be interpreted as an integer)" and try to reopen it. Records logged while
        # a node shuts down rarely reach /rosout; its log file has them all.
        logs = [f for f in glob.glob(os.path.join(rospkg.get_log_dir(),
                                                  rospy.get_param("/run_id"),
                                                  "opt-driver-*.log"))
                if not f.endswith("-stdout.log")]
        self.assertEqual(len(logs), 1, "the opt driver's log file: %s" % logs)
        with open(logs[0]) as f:
            lost = [line for line in f if "lost" in line or "NoneType" in line]
        self.assertEqual(lost, [], "the driver took its own shutdown for a lost port")
        rosnode.kill_nodes([OPT + "/virtual_create"])  # done with the pair: free the CPU

    # --- commands and odometry -------------------------------------------------------------
    def test_cmd_vel_sets_wheel_speeds(self):
        t = rospy.get_time()
        self.cmd.publish(twist(0.2))
        wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.2) < 1e-3
                 and abs(m.vector.y - 0.2) < 1e-3, 3.0, "wheels at 0.2 m/s", after=t)
        self.cmd.publish(twist(0.0, 1.0))
        half = 0.5 * self.wheel_base_m
        wait_msg(self.wheels, lambda m: abs(m.vector.x + half) < 2e-3
                 and abs(m.vector.y - half) < 2e-3, 3.0, "spin in place", after=t)

    def test_odometry_one_metre_forward(self):
        odom0, truth0 = self.settled("odom before")
        self.drive_until(0.25, 0.0, lambda: math.hypot(
            self.truth.msg.pose.pose.position.x - truth0.position.x,
            self.truth.msg.pose.pose.position.y - truth0.position.y) >= 1.0, 15.0)
        odom1, truth1 = self.settled("odom after")
        d_truth = math.hypot(truth1.position.x - truth0.position.x,
                             truth1.position.y - truth0.position.y)
        d_odom = math.hypot(odom1.position.x - odom0.position.x,
                            odom1.position.y - odom0.position.y)
        rospy.loginfo("%s: 1 m forward: odometry %.4f m, truth %.4f m, error %.2f %%",
                      self.robot.name, d_odom, d_truth, 100.0 * (d_odom - d_truth) / d_truth)
        self.assertGreater(d_truth, 0.99)
        self.assertLess(abs(d_odom - d_truth), 0.02 * d_truth,
                        "odometry %.4f m vs truth %.4f m" % (d_odom, d_truth))
        # x grows when driving forward (the old driver had it backwards)
        heading = yaw_of(odom0.orientation)
        progress = ((odom1.position.x - odom0.position.x) * math.cos(heading)
                    + (odom1.position.y - odom0.position.y) * math.sin(heading))
        self.assertGreater(progress, 0.98)

    def _turn(self, w, angle):
        odom0, truth0 = self.settled("odom before turn")
        yaw0 = yaw_of(truth0.orientation)
        turned = [0.0]
        last = [yaw0]

        def done():
            yaw = yaw_of(self.truth.msg.pose.pose.orientation)
            turned[0] += wrap_angle(yaw - last[0])
            last[0] = yaw
            return abs(turned[0]) >= angle
        self.drive_until(0.0, w, done, 20.0)
        odom1, truth1 = self.settled("odom after turn")
        d_truth = wrap_angle(yaw_of(truth1.orientation) - yaw0)
        d_odom = wrap_angle(yaw_of(odom1.orientation) - yaw_of(odom0.orientation))
        rospy.loginfo("%s: turn: odometry %.2f deg, truth %.2f deg, error %.2f deg",
                      self.robot.name, math.degrees(d_odom), math.degrees(d_truth),
                      math.degrees(d_odom - d_truth))
        self.assertGreater(abs(d_truth), math.radians(85))
        self.assertLess(abs(math.degrees(d_odom - d_truth)), 2.0,
                        "odometry turn %.2f deg vs truth %.2f deg"
                        % (math.degrees(d_odom), math.degrees(d_truth)))

    def test_odometry_turn_90_left(self):
        self._turn(0.6, math.pi / 2)

    def test_odometry_turn_90_right(self):
        self._turn(-0.6, math.pi / 2)

    # --- safety and bad input --------------------------------------------------------------
    def _watchdog_stop(self, start, what):
        """Start a motion with ``start()`` (called once, never repeated) and check that the
        watchdog stops it: not before cmd_timeout_s, at most one command period after.
        Returns the stamp of the stop."""
        t_cmd = rospy.get_time()
        start()
        move = wait_msg(self.wheels, lambda m: not stopped(m), 3.0, what + ": moving",
                        after=t_cmd)
        stop = wait_msg(self.wheels, stopped, 3.0, what + ": watchdog stop",
                        after=stamp(move))
        # Causal, so independent of load: the driver got the command after t_cmd and the
        # virtual Create read the zero speeds before stamping them.
        self.assertGreaterEqual(stamp(stop) - t_cmd, self.cmd_timeout_s,
                                "%s: stopped %.3f s after the command, before the timeout"
                                % (what, stamp(stop) - t_cmd))
        # Between two stamps of the virtual Create's stream, so the delivery of the command
        # and this process's wake-ups cancel out. The motion starts at a driver command
        # tick at or after the command arrived and stops at the first tick more than
        # cmd_timeout_s after it: at most one command period more, plus one emulator step,
        # one publish period of ~wheel_speeds and one late tick.
        rospy.loginfo("%s: stop stamped %.3f s after the command (%.3f s after the timeout; "
                      "the stamp comes up to one ~wheel_speeds period late), %.3f s after the "
                      "first moving stamp", what, stamp(stop) - t_cmd,
                      stamp(stop) - t_cmd - self.cmd_timeout_s, stamp(stop) - stamp(move))
        bound = (self.cmd_timeout_s + CMD_PERIOD_S + STEP_PERIOD_S + WHEEL_PUB_PERIOD_S
                 + SCHEDULING_S)
        self.assertLess(stamp(stop) - stamp(move), bound,
                        "%s: moved %.3f s (stamps %.3f..%.3f), watchdog bound %.3f s"
                        % (what, stamp(stop) - stamp(move), stamp(move), stamp(stop), bound))
        return stamp(stop)

    def test_watchdog_stops_robot(self):
        st0, t0 = self.diag_after(rospy.get_time(), "diagnostics before")
        stops0 = self.counter(st0, "safety", "watchdog stops")
        # Twice within one throttle period: two stops, one warning.
        t_stop = [self._watchdog_stop(lambda: self.cmd.publish(twist(0.15)), "cmd_vel %d" % i)
                  for i in range(2)]
        for t in t_stop:
            self.assert_warned(t, "no cmd_vel for 0.50 s", "robot stopped")
        st1, _ = self.diag_after(t_stop[1], "diagnostics after")
        self.assertEqual(self.counter(st1, "safety", "watchdog stops"), stops0 + 2)

    def test_nan_twist_stops_robot(self):
        st0, _ = self.diag_after(rospy.get_time(), "diagnostics before")
        # Too fast at first: the saturation warning must not hide the NaN's.
        with Driving(self.cmd, 0.6) as drive:
            wait_msg(self.wheels, lambda m: m.vector.x > 0.45, 3.0, "moving",
                     after=rospy.get_time())
            t_nan = rospy.get_time()
            drive.set(float("nan"))  # and it keeps coming at 20 Hz
            stop = wait_msg(self.wheels, stopped, 3.0, "stop after a NaN twist", after=t_nan)
            st1, _ = self.diag_after(stamp(stop), "diagnostics after the NaN")
            last = self.wheels.msg
        self.assertTrue(stopped(last), "moving again under NaN twists: %s" % last)
        # Refused and stopped at once, not left to time out: the stop is not the watchdog's.
        self.assertEqual(self.counter(st1, "safety", "watchdog stops"),
                         self.counter(st0, "safety", "watchdog stops"),
                         "the NaN twist was left to the watchdog")
        self.assertGreater(self.counter(st1, "safety", "rejected commands"),
                           self.counter(st0, "safety", "rejected commands") + 1)
        self.assert_warned(t_nan, "cmd_vel rejected", "robot stopped", "linear.x=nan")

    def test_saturated_twist_keeps_turn_ratio(self):
        t = rospy.get_time()
        with Driving(self.cmd, 1.0, 2.0):  # many saturated commands: one warning
            m = wait_msg(self.wheels, lambda m: m.vector.y > 0.45, 3.0, "saturated drive",
                         after=t)
            self.assertAlmostEqual(m.vector.y, 0.5, places=3)
            v = 0.5 * (m.vector.x + m.vector.y)
            w = (m.vector.y - m.vector.x) / self.wheel_base_m
            self.assertAlmostEqual(w / v, 2.0, delta=0.05)
            st, _ = self.diag_after(stamp(m), "diagnostics after saturation")
            self.assertGreater(self.counter(st, "safety", "saturated commands"), 1)
            self.assert_warned(t, "cmd_vel (1.000 m/s, 2.000 rad/s)", "exceeds the wheel "
                               "limit 0.500 m/s", "scaled down keeping the turn ratio")

    def test_bump_stops_forward_motion(self):
        half = 0.5 * self.wheel_base_m
        try:
            with Driving(self.cmd, 0.2) as drive:
                wait_msg(self.wheels, lambda m: m.vector.x > 0.1, 3.0, "moving",
                         after=rospy.get_time())
                t_bump = rospy.get_time()
                self.set_bump(True)
                hz = wait_msg(self.hazards, lambda m: m.bump_left and m.bump_right, 3.0,
                              "bump on hazards", after=t_bump)
                self.assertFalse(any([hz.cliff_left, hz.cliff_front_left, hz.wheeldrop_left,
                                      hz.cliff_front_right, hz.cliff_right, hz.wall,
                                      hz.wheeldrop_right, hz.wheeldrop_caster,
                                      hz.virtual_wall]))
                self.assertEqual(hz.header.frame_id, "base_link")
                stop = wait_msg(self.wheels, stopped, 3.0, "stop on the bump", after=t_bump)
                # Forward commands keep coming; the wheels stay stopped for 5 command
                # periods of the virtual Create's stream.
                t_stop = stamp(stop)
                wait_msg(self.wheels, lambda m: True, 5.0, "wheel stream",
                         after=t_stop + 5 * CMD_PERIOD_S)
                # Turning stays allowed: the same forward command with a turn spins in
                # place, which shows the forward commands are still being processed.
                drive.set(0.2, 1.0)
                wait_msg(self.wheels, lambda m: abs(m.vector.x + half) < 2e-3
                         and abs(m.vector.y - half) < 2e-3, 3.0, "spin while bumped",
                         after=t_stop)
                forward = [m for m in list(self.wheels.all) if stamp(m) >= t_stop
                           and m.vector.x + m.vector.y > 1e-6]
                self.assertEqual(forward, [], "forward motion while bumped")
                drive.set(-0.1)  # backing away is allowed
                wait_msg(self.wheels, lambda m: m.vector.x < -0.05 and m.vector.y < -0.05,
                         3.0, "reverse while bumped", after=t_stop)
                msg = wait_msg(self.diag, lambda m: statuses(m, DRIVER).get(
                    "safety", (None,))[0] == DiagnosticStatus.WARN, 5.0,
                    "safety diagnostics with the bump", after=t_bump)
                self.assertEqual(statuses(msg, DRIVER)["safety"][1], "bump_left, bump_right")
        finally:
            self.set_bump(False)
        t_release = rospy.get_time()
        wait_msg(self.hazards, lambda m: not (m.bump_left or m.bump_right), 3.0,
                 "bump released on hazards", after=t_release)

    def test_stalled_stream_is_restarted(self):
        power_cycle = rospy.ServiceProxy("virtual_create/power_cycle", Trigger)
        t0 = rospy.get_time()
        self.assertTrue(power_cycle().success)  # OI off: only Start is heard, no stream
        self.assert_warned(t0, "no sensor frame from %s for > %.1f s" % (self.port,
                                                                        SENSOR_TIMEOUT_S),
                           "re-sent start/stream")
        wait_for(lambda: self.state()["mode"] == "safe" and self.state()["streaming"], 10.0,
                 "Start, Safe and Stream re-sent to the robot")
        # The stream really stopped, and came back.
        after = wait_msg(self.packet, lambda m: True, 5.0, "sensorPacket after the restart",
                         after=t0 + SENSOR_TIMEOUT_S)
        before = [m for m in list(self.packet.all) if stamp(m) < stamp(after)][-1]
        self.assertGreater(stamp(after) - stamp(before), SENSOR_TIMEOUT_S,
                           "no gap in the stream: the robot was not stalled")
        t1 = rospy.get_time()
        self.cmd.publish(twist(0.1))
        wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.1) < 1e-3, 5.0,
                 "driving after the restart", after=t1)

    # --- Create 2: light bumper, motors, stasis ---------------------------------------------
    def test_create2_light_bumper_slows_forward_motion(self):
        if not self.create2:
            self.skipTest("Create 2 only")
        light = Latest("light_bumper", LightBumper, keep_all=True)
        set_light = rospy.ServiceProxy("virtual_create/set_light_bump", SetBool)
        speed = rospy.get_param(DRIVER + "/light_bump_speed_m_s")
        self.assertGreater(speed, 0.0)
        try:
            with Driving(self.cmd, 0.3) as drive:
                wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.3) < 1e-3, 3.0,
                         "free at 0.3 m/s", after=rospy.get_time())
                t = rospy.get_time()
                self.assertTrue(set_light(True).success)
                msg = wait_msg(light, lambda m: m.center_left and m.right, 3.0,
                               "light bumper sees something", after=t)
                self.assertEqual(list(msg.signals), [1000] * 6)
                slow = wait_msg(self.wheels, lambda m: abs(m.vector.x - speed) < 1e-3
                                and abs(m.vector.y - speed) < 1e-3, 3.0,
                                "slowed to light_bump_speed_m_s", after=t)
                drive.set(-0.2)  # backing away is not slowed
                wait_msg(self.wheels, lambda m: abs(m.vector.x + 0.2) < 1e-3, 3.0,
                         "reversing at full speed", after=stamp(slow))
                drive.set(0.3)
                t = rospy.get_time()
                self.assertTrue(set_light(False).success)
                wait_msg(light, lambda m: not any(m.signals), 3.0, "light bumper clear",
                         after=t)
                wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.3) < 1e-3, 3.0,
                         "full speed again", after=t)
        finally:
            set_light(False)
        st, _ = self.diag_after(rospy.get_time(), "diagnostics after the slow-down")
        self.assertGreaterEqual(self.counter(st, "motors", "light bump slowdowns"), 1)

    def test_create2_stuck_warning_and_motor_currents(self):
        if not self.create2:
            self.skipTest("Create 2 only")
        set_stuck = rospy.ServiceProxy("virtual_create/set_stuck", SetBool)
        try:
            with Driving(self.cmd, 0.2):
                wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.2) < 1e-3, 3.0,
                         "driving at 0.2 m/s", after=rospy.get_time())
                st, _ = self.diag_after(rospy.get_time() + 0.5, "motors while driving")
                level, message, values, _ = st["motors"]
                self.assertEqual((level, message), (DiagnosticStatus.OK, "ok"))
                # the virtual Create's motor model: 1 A per m/s of wheel speed
                self.assertAlmostEqual(float(values["left_wheel_a"]), 0.2, delta=0.002)
                self.assertAlmostEqual(float(values["right_wheel_a"]), 0.2, delta=0.002)
                self.assertEqual(values["stasis_toggling"], "True")
                t = rospy.get_time()
                self.assertTrue(set_stuck(True).success)
                self.assert_warned(t, "wheels driven forward for > 1.0 s but the stasis "
                                   "sensor sees no progress", "stuck")
                msg = wait_msg(self.diag, lambda m: statuses(m, DRIVER).get(
                    "motors", (None,))[0] == DiagnosticStatus.WARN, 5.0,
                    "motors status WARN", after=t)
                self.assertEqual(statuses(msg, DRIVER)["motors"][1],
                                 "stuck: wheels turning, stasis still")
        finally:
            set_stuck(False)

    # --- state topics ----------------------------------------------------------------------
    def test_battery(self):
        t = rospy.get_time()
        b = wait_msg(self.battery, lambda m: True, 5.0, "battery", after=t)
        p = wait_msg(self.packet, lambda m: True, 5.0, "sensorPacket", after=t)
        # SI from the raw OI units (mV, mA, mAh) of the same robot
        self.assertAlmostEqual(b.voltage, p.voltage / 1000.0, delta=0.01)
        self.assertAlmostEqual(b.charge, p.batteryCharge / 1000.0, delta=0.002)
        self.assertAlmostEqual(b.capacity, p.batteryCapacity / 1000.0, places=6)
        # the virtual Create: 2700 mAh, starts full, 12.0..16.5 V, draws 150 mA standing
        self.assertAlmostEqual(b.capacity, 2.7, places=6)
        self.assertAlmostEqual(b.design_capacity, 2.7, places=6)
        self.assertGreater(b.percentage, 0.95)
        self.assertLessEqual(b.percentage, 1.0)
        self.assertAlmostEqual(b.percentage, b.charge / b.capacity, places=6)
        self.assertGreater(b.voltage, 16.0)
        self.assertLessEqual(b.voltage, 16.5)
        self.assertLess(b.current, 0.0)
        self.assertEqual(b.temperature, 25.0)
        self.assertEqual(b.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        self.assertEqual(b.power_supply_technology,
                         BatteryState.POWER_SUPPLY_TECHNOLOGY_NIMH)
        self.assertTrue(b.present)

    def test_diagnostics(self):
        st, t = self.diag_after(rospy.get_time())
        self.assertEqual(set(st), {"serial link", "battery", "safety"}
                         | ({"motors"} if self.create2 else set()))
        level, message, values, _ = st["serial link"]
        self.assertEqual((level, message), (DiagnosticStatus.OK, "streaming"))
        self.assertEqual(values["port"], self.port)
        self.assertGreaterEqual(int(values["opens"]), 1)
        for key in ("failures", "bad checksum", "bad body", "dropped bytes"):
            self.assertIn(key, values)
        level, message, values, _ = st["battery"]
        self.assertEqual((level, message), (DiagnosticStatus.OK, "ok"))
        self.assertGreater(float(values["voltage_v"]), 16.0)
        self.assertAlmostEqual(float(values["capacity_ah"]), 2.7, places=3)
        level, message, values, _ = st["safety"]
        self.assertEqual((level, message), (DiagnosticStatus.OK, "no hazard"))
        for key in ("watchdog stops", "rejected commands", "saturated commands"):
            self.assertGreaterEqual(int(values[key]), 0)
        # frames keep being counted
        st2, _ = self.diag_after(t)
        self.assertGreater(int(st2["serial link"][2]["frames ok"]),
                           int(st["serial link"][2]["frames ok"]))
        self.assertEqual({v[3] for v in st.values()}, {"iRobot %s @ %s" % (
            "Create 2" if self.create2 else "Create", self.port)})

    # --- services --------------------------------------------------------------------------
    def test_services_tank_and_brake(self):
        tank = rospy.ServiceProxy("tank", Tank)
        brake = rospy.ServiceProxy("brake", Brake)
        tank.wait_for_service(10.0)
        t = rospy.get_time()
        self.assertTrue(tank(False, -100, 150).success)
        wait_msg(self.wheels, lambda m: abs(m.vector.x + 0.1) < 1e-3
                 and abs(m.vector.y - 0.15) < 1e-3, 2.0, "tank speeds", after=t)
        t = rospy.get_time()
        self.assertTrue(brake(True).success)
        wait_msg(self.wheels, stopped, 1.0, "brake", after=t)

    def test_services_turn_and_circle_go_through_the_watchdog(self):
        turn = rospy.ServiceProxy("turn", Turn)
        circle = rospy.ServiceProxy("circle", Circle)
        turn.wait_for_service(10.0)
        st0, _ = self.diag_after(rospy.get_time(), "diagnostics before")
        t = rospy.get_time()
        self._watchdog_stop(lambda: self.assertTrue(turn(False, 100).success), "turn")
        spin = first(self.wheels, lambda m: not stopped(m), after=t)
        self.assertEqual((round(spin.vector.x, 3), round(spin.vector.y, 3)), (-0.1, 0.1))
        # 200 mm/s on a 500 mm radius to the left: v = 0.2 m/s, w = 0.4 rad/s
        t = rospy.get_time()
        t_stop = self._watchdog_stop(lambda: self.assertTrue(circle(False, 200, 500).success),
                                     "circle")
        arc = first(self.wheels, lambda m: not stopped(m), after=t)
        self.assertAlmostEqual(arc.vector.x, 0.2 - 0.2 * self.wheel_base_m, delta=1.5e-3)
        self.assertAlmostEqual(arc.vector.y, 0.2 + 0.2 * self.wheel_base_m, delta=1.5e-3)
        st1, _ = self.diag_after(t_stop, "diagnostics after")
        self.assertEqual(self.counter(st1, "safety", "watchdog stops"),
                         self.counter(st0, "safety", "watchdog stops") + 2)
        self.assertFalse(circle(False, 200, 0).success)  # radius 0 is refused

    def test_services_leds_and_song(self):
        leds = rospy.ServiceProxy("leds", Leds)
        song = rospy.ServiceProxy("song", Song)
        leds.wait_for_service(10.0)
        self.assertTrue(leds(True, False, 200, 100).success)  # advance, play, colour, level
        wait_for(lambda: self.state()["leds"] == {"play": False, "advance": True,
                                                  "power_color": 200,
                                                  "power_intensity": 100},
                 5.0, "LEDs set on the robot (last: %s)" % self.state()["leds"])
        t = rospy.get_time()
        self.assertTrue(song([60, 64, 67], [16, 16, 32]).success)  # 1 s
        wait_for(lambda: self.state()["songs"].get("0") == [[60, 16], [64, 16], [67, 32]]
                 and 0 in self.state()["songs_played"], 5.0, "song 0 defined and played")
        wait_msg(self.packet, lambda m: m.songPlaying == 1 and m.songNumber == 0, 3.0,
                 "songPlaying in sensorPacket", after=t)
        self.assertFalse(song([60, 64], [16]).success)  # notes and durations differ

    def test_services_dock_then_clear(self):
        dock = rospy.ServiceProxy("dock", Dock)
        tank = rospy.ServiceProxy("tank", Tank)
        dock.wait_for_service(10.0)
        try:
            self.assertTrue(dock(True).success)
            wait_for(lambda: self.state()["docking_requested"], 5.0, "Cover-and-Dock")
            self.assertEqual(self.state()["mode"], "passive")  # the robot docks by itself
            # clear=true stops the demo and gives the driver the wheels back
            t = rospy.get_time()
            self.assertTrue(tank(True, 100, 100).success)
            wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.1) < 1e-3
                     and abs(m.vector.y - 0.1) < 1e-3, 3.0, "driving after clear", after=t)
            self.assertEqual(self.state()["mode"], "safe")
            self.assertFalse(self.state()["docking_requested"])
        finally:
            if self.state()["mode"] != "safe":  # leave the robot usable for the next test
                rospy.ServiceProxy("virtual_create/power_cycle", Trigger)()
                wait_for(lambda: self.state()["mode"] == "safe", 10.0, "driver re-init")

    # --- the serial line -------------------------------------------------------------------
    def test_z_garbage_and_reconnect_do_not_kill_the_driver(self):
        garbage = rospy.ServiceProxy("virtual_create/inject_garbage", Trigger)
        close = rospy.ServiceProxy("virtual_create/close_link", Trigger)
        odom_before, truth_before = self.settled("odom before garbage")
        st0, t0 = self.diag_after(rospy.get_time(), "diagnostics before garbage")
        # Garbage over two diagnostics periods after the first warning: one warning.
        t_garbage = rospy.get_time()
        state = {}

        def garbage_for_a_while():
            self.assertTrue(garbage().success)
            warned = [r for r in self.rosout.matching(node=DRIVER, level="warn",
                                                      contains="corrupt data")
                      if r.stamp_s >= t_garbage]
            if warned and "t_warn" not in state:
                state["t_warn"] = warned[0].stamp_s
            return "t_warn" in state and rospy.get_time() > state["t_warn"] + 1.5
        wait_for(garbage_for_a_while, 15.0, "garbage, a warning and 1.5 s more garbage")
        rec = self.assert_warned(t_garbage, "corrupt data from %s dropped" % self.port)
        self.assertRegex(rec.text, r"\d+ frame\(s\) with a bad checksum, \d+ with a bad "
                                   r"header or body, [1-9]\d* byte\(s\) in all")
        st1, _ = self.diag_after(rospy.get_time(), "diagnostics after garbage")
        self.assertGreater(self.counter(st1, "serial link", "dropped bytes"),
                           self.counter(st0, "serial link", "dropped bytes"))
        self.assertGreater(self.counter(st1, "serial link", "frames ok"),
                           self.counter(st0, "serial link", "frames ok"))
        odom_after, truth_after = self.settled("odom after garbage")
        # garbage must not have been integrated into odometry
        self.assertAlmostEqual(odom_after.position.x, odom_before.position.x, delta=0.005)
        self.assertAlmostEqual(odom_after.position.y, odom_before.position.y, delta=0.005)

        t_close = rospy.get_time()
        self.assertTrue(close().success)
        self.assert_warned(t_close, "lost %s" % self.port, "reopening with back-off")
        after = wait_msg(self.packet, lambda m: True, 20.0,
                         "sensor packets after the port came back", after=t_close + 0.5)
        n = self.packet.count
        wait_for(lambda: self.packet.count > n + 10, 5.0, "10 more sensor packets")
        st2, _ = self.diag_after(stamp(after), "diagnostics after the reconnect")
        self.assertEqual(st2["serial link"][:2], (DiagnosticStatus.OK, "streaming"))
        self.assertEqual(self.counter(st2, "serial link", "opens"),
                         self.counter(st0, "serial link", "opens") + 1)
        self.assertGreater(self.counter(st2, "serial link", "failures"),
                           self.counter(st0, "serial link", "failures"))
        t = rospy.get_time()
        self.cmd.publish(twist(0.1))
        wait_msg(self.wheels, lambda m: abs(m.vector.x - 0.1) < 1e-3, 5.0,
                 "driving after the reconnect", after=t)


if __name__ == "__main__":
    rostest.rosrun("irobot_create_2_1", "driver_against_virtual_create", DriverTest)
