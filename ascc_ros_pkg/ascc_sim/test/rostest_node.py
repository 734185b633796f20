#!/usr/bin/env python3
"""rostest: what the simulator node promises beyond the robots (package README, section
"Node simulator"): the latched ground-truth objects as the world file gives them, the
scripted people on ground_truth/people (20 Hz), the markers (2 Hz), the static
map -> odom at the start pose with ~publish_map_to_odom; and, each in a process of its
own, ~max_sim_time_s ending the launch at that simulated time, no base_link -> laser with
~publish_laser_mount false, the wall-clock mode
(use_sim_time:=false), and a bad world or parameter ending the node with one line that
names the file and the problem.

Expected values come from the world YAML (read here with PyYAML, not with ascc_sim) and
the defaults the README states, never from the simulator's own code."""
import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

import rospy
import rostest
import tf2_ros
import yaml
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import Marker, MarkerArray

from ascc_common.ports import free_port
from ascc_common.pose2d import wrap_angle, yaw_of
from ascc_sim.msg import SimObjectArray
from ascc_testing.waits import Latest, pose_of, wait_for

EPS = 1e-6  # float arithmetic [m, rad, s]
PHYSICS_DT_S = 0.01  # sim.launch default
# README defaults: cone radius 0.12 m, height 0.45 m; poster 0.6 m x 0.8 m, not solid;
# people radius 0.2 m, height 1.75 m.
CONE_RADIUS_M, CONE_HEIGHT_M = 0.12, 0.45
POSTER_WIDTH_M, POSTER_HEIGHT_M = 0.6, 0.8
PERSON_RADIUS_M, PERSON_HEIGHT_M = 0.2, 1.75
PROCESS_TIMEOUT_S = 120.0  # wall: a loaded machine starts a ROS process in seconds


def pose3(v):
    return float(v[0]), float(v[1]), float(v[2]) if len(v) > 2 else 0.0


def to_map(pose, pts):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return [(pose[0] + c * x - s * y, pose[1] + s * x + c * y) for x, y in pts]


def same_points(got, expected, tol=EPS):
    return len(got) == len(expected) and all(
        any(math.hypot(g[0] - e[0], g[1] - e[1]) <= tol for g in got) for e in expected)


def is_multiple(t, period):
    k = round(t / period)
    return k >= 0 and abs(t - k * period) <= EPS


class Script:
    """A person's scripted walk as the README describes it: stand at the first waypoint
    for start_delay_s, then walk each leg at speed_mps and wait wait_s at a waypoint
    doing its activity; loop: walk back to the first waypoint and repeat (the delay is
    not repeated). state(t) -> (x, y, speed, activity, heading or None, at_boundary)."""

    def __init__(self, spec):
        self.speed = float(spec.get("speed_mps", 0.5))
        wps = []
        for wp in spec["route"]:
            if isinstance(wp, dict):
                wps.append((float(wp["at"][0]), float(wp["at"][1]),
                            float(wp.get("wait_s", 0.0)), wp.get("activity", "")))
            else:
                wps.append((float(wp[0]), float(wp[1]), 0.0, ""))
        self.prefix = []  # (duration, x0, y0, x1, y1, activity or None while walking)
        delay = float(spec.get("start_delay_s", 0.0))
        x0, y0, wait0, act0 = wps[0]
        if delay > 0:
            self.prefix.append((delay, x0, y0, x0, y0, "stand"))
        if wait0 > 0:
            self.prefix.append((wait0, x0, y0, x0, y0, act0 or "stand"))
        legs = list(zip(wps, wps[1:])) + ([(wps[-1], wps[0])] if spec.get("loop") else [])
        self.cycle = []
        for a, b in legs:
            self.cycle.append((math.hypot(b[0] - a[0], b[1] - a[1]) / self.speed,
                               a[0], a[1], b[0], b[1], None))
            if b[2] > 0:
                self.cycle.append((b[2], b[0], b[1], b[0], b[1], b[3] or "stand"))
        self.loop = bool(spec.get("loop"))
        self.end = wps[-1]

    def state(self, t):
        phases = list(self.prefix)
        t_prefix = sum(p[0] for p in self.prefix)
        cycle_s = sum(p[0] for p in self.cycle)
        if t >= t_prefix and self.loop:
            t = t_prefix + math.fmod(t - t_prefix, cycle_s)
        phases += self.cycle
        t0 = 0.0
        for duration, x0, y0, x1, y1, activity in phases:
            if t <= t0 + duration:
                near = min(abs(t - t0), abs(t - t0 - duration)) < EPS
                if activity is not None:
                    return x0, y0, 0.0, activity, None, near
                f = (t - t0) / duration
                return (x0 + f * (x1 - x0), y0 + f * (y1 - y0), self.speed, "walk",
                        math.atan2(y1 - y0, x1 - x0), near)
            t0 += duration
        return self.end[0], self.end[1], 0.0, self.end[3] or "stand", None, False


def run(cmd, env=None, timeout_s=PROCESS_TIMEOUT_S):
    """Run a command; (returncode, stdout + stderr). Killed (and AssertionError) after
    timeout_s of wall time."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env,
                            universal_newlines=True, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, 15)
        out, _ = proc.communicate()
        raise AssertionError("%s still running after %.0f s; output:\n%s"
                             % (" ".join(cmd), timeout_s, out[-3000:])) from None
    return proc.returncode, out


@contextlib.contextmanager
def in_background(cmd, env):
    """Start ``cmd`` in a process group of its own (output discarded); on leaving, end it
    (SIGTERM to the group) unless it has ended already."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=env, start_new_session=True)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, 15)
            proc.wait(timeout=30)


class SimulatorNodeTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_node_test")
        cls.world_path = rospy.get_param("~world")
        with open(cls.world_path, encoding="utf-8") as f:
            cls.world = yaml.safe_load(f)
        cls.robot = cls.world["robots"][0]
        cls.objects = Latest("ground_truth/objects", SimObjectArray)
        cls.people = Latest("ground_truth/people", SimObjectArray, keep_all=True)
        cls.markers = Latest("ground_truth/markers", MarkerArray, keep_all=True)
        cls.truth = Latest("ground_truth/%s/pose" % cls.robot["name"], PoseStamped,
                           keep_all=True)
        cls.start = Latest("ground_truth/%s/start_pose" % cls.robot["name"], PoseStamped)
        cls.tf = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.tf)
        # The fixture holds the clock at 0 until the scan has a subscriber: subscribe it
        # once the others are connected, so the people are seen from t = 0 on.
        for sub in (cls.people, cls.markers, cls.truth, cls.objects):
            wait_for(lambda s=sub: s.sub.get_num_connections() > 0, 60.0,
                     "a publisher on %s" % sub.sub.resolved_name)
        cls.scan = Latest("scan", LaserScan)

    # --- ground truth ---------------------------------------------------------------------
    def test_objects(self):
        """ground_truth/objects (latched, published before this node subscribed): every
        object of the world YAML with its type, kind, pose, footprint, size, colour."""
        msg = self.objects.wait(60.0)
        self.assertEqual(msg.header.frame_id, "map")
        got = {o.name: o for o in msg.objects}
        self.assertEqual(sorted(got), sorted(o["name"] for o in self.world["objects"]))
        for spec in self.world["objects"]:
            o = got[spec["name"]]
            name, otype = spec["name"], spec["type"]
            self.assertEqual(o.type, otype, name)
            pose = pose3(spec["pose"])
            x, y, yaw = o.pose.position.x, o.pose.position.y, yaw_of(o.pose.orientation)
            self.assertLess(math.hypot(x - pose[0], y - pose[1]), EPS, name)
            self.assertLess(abs(wrap_angle(yaw - pose[2])), EPS, name)
            pts = [(p.x, p.y) for p in o.footprint.points]
            if "color" in spec and not isinstance(spec["color"], str):
                self.assertEqual([round(c, 6) for c in (o.color.r, o.color.g, o.color.b)],
                                 [round(float(c), 6) for c in spec["color"]], name)
            if otype == "cone":
                self.assertEqual(o.kind, "", name)
                self.assertEqual(pts, [], name)
                self.assertAlmostEqual(o.radius, spec.get("radius_m", CONE_RADIUS_M),
                                       delta=EPS, msg=name)
                self.assertAlmostEqual(o.height, spec.get("height_m", CONE_HEIGHT_M),
                                       delta=EPS, msg=name)
                self.assertEqual(o.solid, spec.get("solid", "outline") != "none", name)
            elif otype == "poster":
                self.assertEqual(o.kind, spec["logo"], name)
                self.assertAlmostEqual(o.height, spec.get("height_m", POSTER_HEIGHT_M),
                                       delta=EPS, msg=name)
                self.assertFalse(o.solid, name)
                # a plate across the facing direction, width_m wide
                across = [-(px - pose[0]) * math.sin(pose[2]) + (py - pose[1])
                          * math.cos(pose[2]) for px, py in pts]
                self.assertTrue(pts, name)
                self.assertAlmostEqual(max(across) - min(across),
                                       spec.get("width_m", POSTER_WIDTH_M), delta=EPS,
                                       msg=name)
            elif otype == "furniture":
                self.assertEqual(o.kind, spec["kind"], name)
                self.assertAlmostEqual(o.height, spec["height_m"], delta=EPS, msg=name)
                if "size_m" in spec:
                    hl, hw = spec["size_m"][0] / 2.0, spec["size_m"][1] / 2.0
                    local = [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
                else:
                    local = [tuple(p) for p in spec["footprint_m"]]
                self.assertTrue(same_points(pts, to_map(pose, local)),
                                "%s: footprint %s, expected %s"
                                % (name, pts, to_map(pose, local)))
                self.assertEqual(o.solid, spec.get("solid", "outline") != "none", name)
                self.assertEqual(o.radius, 0.0, name)
            else:  # landmark: a point
                self.assertEqual(o.kind, spec.get("kind", ""), name)
                self.assertEqual(pts, [], name)
                self.assertFalse(o.solid, name)

    def wait_people_until(self, t_end):
        wait_for(lambda: self.people.msg is not None
                 and self.people.msg.header.stamp.to_sec() >= t_end, 120.0,
                 "ground_truth/people up to t = %.1f s" % t_end)

    def test_people(self):
        """ground_truth/people at 20 Hz from t = 0: each person where the script puts it
        at the message's stamp, with its speed and activity."""
        spec = self.world["people"][0]
        script = Script(spec)
        t_loop = sum(p[0] for p in script.prefix) + sum(p[0] for p in script.cycle)
        self.wait_people_until(t_loop + 2.0)  # into the second round of the loop
        msgs = list(self.people.all)
        self.assertLess(msgs[0].header.stamp.to_sec(), EPS, "first people message")
        seen = set()
        last = -1.0
        for m in msgs:
            t = m.header.stamp.to_sec()
            self.assertTrue(is_multiple(t, 1 / 20.0), "stamp %.6f not on the 20 Hz grid" % t)
            self.assertGreater(t, last)
            last = t
            self.assertEqual(m.header.frame_id, "map")
            self.assertEqual([p.name for p in m.objects], [spec["name"]])
            p = m.objects[0]
            x, y, speed, activity, heading, boundary = script.state(t)
            where = "%s at t = %.2f s" % (spec["name"], t)
            self.assertLess(math.hypot(p.pose.position.x - x, p.pose.position.y - y), EPS,
                            "%s: at (%.4f, %.4f), the script says (%.4f, %.4f)"
                            % (where, p.pose.position.x, p.pose.position.y, x, y))
            self.assertEqual(p.type, "person")
            self.assertAlmostEqual(p.radius, spec.get("radius_m", PERSON_RADIUS_M),
                                   delta=EPS)
            self.assertAlmostEqual(p.height, spec.get("height_m", PERSON_HEIGHT_M),
                                   delta=EPS)
            if boundary:
                continue  # between two phases: either activity is right
            self.assertEqual(p.activity, activity, where)
            self.assertAlmostEqual(p.speed, speed, delta=EPS, msg=where)
            if heading is not None:
                self.assertLess(abs(wrap_angle(yaw_of(p.pose.orientation) - heading)), EPS, where)
            seen.add((activity, t > t_loop))
        # every phase was seen, and the walk again after the loop closed
        self.assertTrue({("stand", False), ("walk", False), ("read", False),
                         ("walk", True)} <= seen, seen)

    def test_markers(self):
        """ground_truth/markers at 2 Hz: every object, the robot and the person where the
        ground truth has them, with labels."""
        self.wait_people_until(3.0)
        self.markers.wait(60.0, count=3)
        msgs = list(self.markers.all)
        # the stamp of a marker array: its newest marker's (static ones may keep theirs)
        stamps = [max(m.header.stamp.to_sec() for m in a.markers) for a in msgs]
        for t in stamps:
            self.assertTrue(is_multiple(t, 0.5), "marker stamp %.6f not on the 2 Hz grid" % t)
        self.assertEqual(stamps, sorted(set(stamps)))
        msg = msgs[-1]
        t = stamps[-1]
        self.assertTrue(all(m.header.frame_id == "map" for m in msg.markers))
        shapes = [m for m in msg.markers if m.type != Marker.TEXT_VIEW_FACING]
        labels = [m.text for m in msg.markers if m.type == Marker.TEXT_VIEW_FACING]

        def at(x, y):
            return [m for m in shapes if math.hypot(m.pose.position.x - x,
                                                    m.pose.position.y - y) < EPS]

        for spec in self.world["objects"]:
            pose = pose3(spec["pose"])
            if spec["type"] in ("cone", "landmark"):
                self.assertTrue(at(pose[0], pose[1]), "no marker at %s" % spec["name"])
            else:
                strips = [[(p.x, p.y) for p in m.points[:-1]] for m in shapes
                          if m.type == Marker.LINE_STRIP]
                if spec["type"] == "furniture":
                    if "size_m" in spec:
                        hl, hw = spec["size_m"][0] / 2.0, spec["size_m"][1] / 2.0
                        local = [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
                    else:
                        local = [tuple(p) for p in spec["footprint_m"]]
                    ok = any(same_points(s, to_map(pose, local)) for s in strips)
                else:  # poster: a plate width_m wide, 2 cm thick, at its pose
                    reach = math.hypot(spec.get("width_m", POSTER_WIDTH_M) / 2, 0.02) + EPS
                    ok = any(s and all(math.hypot(px - pose[0], py - pose[1]) <= reach
                                       for px, py in s) for s in strips)
                self.assertTrue(ok, "no outline of %s in %s" % (spec["name"], strips))
            self.assertIn(spec["kind"] if spec["type"] == "furniture" else spec["name"],
                          labels)
            if spec.get("solid") == "legs":
                legs = [m for m in shapes if m.type == Marker.CYLINDER and math.hypot(
                    m.pose.position.x - pose[0], m.pose.position.y - pose[1]) < 0.5]
                self.assertEqual(len(legs), len(spec["footprint_m"]),
                                 "one leg marker per corner of %s" % spec["name"])
        # the robot at its true pose (it is never commanded here: the pose nearest in
        # time, in case a loaded machine dropped the one of the same stamp)
        truth = min(self.truth.all, key=lambda p: abs(p.header.stamp.to_sec() - t))
        rx, ry, ryaw = pose_of(truth)
        body = at(rx, ry)
        self.assertTrue(body, "no marker at the robot (%.3f, %.3f)" % (rx, ry))
        self.assertTrue(any(abs(wrap_angle(yaw_of(m.pose.orientation) - ryaw)) < EPS
                            for m in body), "robot marker heading")
        self.assertIn(self.robot["name"], labels)
        # the person where the script puts it, labelled with the activity
        spec = self.world["people"][0]
        x, y, _, activity, _, _ = Script(spec).state(t)
        self.assertTrue(at(x, y), "no marker at %s (%.3f, %.3f) at t = %.2f"
                        % (spec["name"], x, y, t))
        self.assertTrue(any(spec["name"] in s and activity in s for s in labels),
                        "no label '%s: %s' in %s" % (spec["name"], activity, labels))

    def test_map_to_odom(self):
        """~publish_map_to_odom: static map -> odom at the robot's start pose (the
        driver's odom starts there), also on ground_truth/<robot>/start_pose."""
        x, y, yaw = pose3(self.robot["pose"])
        wait_for(lambda: self.tf.can_transform("map", "odom", rospy.Time(0)), 60.0,
                 "TF map -> odom")
        tr = self.tf.lookup_transform("map", "odom", rospy.Time(0)).transform
        self.assertLess(math.hypot(tr.translation.x - x, tr.translation.y - y), EPS)
        self.assertLess(abs(wrap_angle(yaw_of(tr.rotation) - yaw)), EPS)
        sx, sy, syaw = pose_of(self.start.wait(60.0))
        self.assertLess(math.hypot(sx - x, sy - y), EPS)
        self.assertLess(abs(wrap_angle(syaw - yaw)), EPS)
        # with the driver's odom -> base_link, map -> base_link is the true pose (the
        # robot is never commanded here)
        wait_for(lambda: self.tf.can_transform("map", "base_link", rospy.Time(0)), 60.0,
                 "TF map -> base_link")
        tr = self.tf.lookup_transform("map", "base_link", rospy.Time(0)).transform
        tx, ty, tyaw = pose_of(self.truth.wait(60.0))
        self.assertLess(math.hypot(tr.translation.x - tx, tr.translation.y - ty), EPS)
        self.assertLess(abs(wrap_angle(yaw_of(tr.rotation) - tyaw)), EPS)

    # --- the node as a process ------------------------------------------------------------
    def test_max_sim_time_ends_the_launch(self):
        """sim.launch max_sim_time_s: the simulator stops at that simulated time and the
        launch (driver included) ends. Own master: a second /clock must not reach the
        fixture."""
        tmp = tempfile.mkdtemp(prefix="ascc_sim_max_time_")
        try:
            stats = os.path.join(tmp, "stats.json")
            env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % free_port())
            t0 = time.monotonic()
            rc, out = run(["roslaunch", "--skip-log-check", "ascc_sim", "sim.launch",
                           "world:=" + self.world_path, "max_sim_time_s:=3.0",
                           "real_time_factor:=0", "stats_file:=" + stats,
                           "link_dir:=" + os.path.join(tmp, "links")], env=env)
            rospy.loginfo("max_sim_time_s launch: rc %d after %.1f s wall", rc,
                          time.monotonic() - t0)
            self.assertEqual(rc, 0, out[-3000:])
            self.assertIn("reached ~max_sim_time_s 3.0 s", out)
            self.assertIn("[driver-", out)  # the driver ran ... and was ended with it
            with open(stats, encoding="utf-8") as f:
                sim_time = json.load(f)["sim_time_s"]
            self.assertAlmostEqual(sim_time, 3.0, delta=PHYSICS_DT_S / 2)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def test_wall_clock_mode(self):
        """sim.launch use_sim_time:=false (own master): no /clock, the scans stamped with
        the wall clock; a real-time factor other than 1 ends the simulator, naming it."""
        tmp = tempfile.mkdtemp(prefix="ascc_sim_wall_clock_")
        probe = ("import time, rospy\n"
                 "from sensor_msgs.msg import LaserScan\n"
                 "rospy.init_node('wall_clock_probe')\n"
                 "m = rospy.wait_for_message('scan', LaserScan, timeout=%.0f)\n"
                 "lag = time.time() - m.header.stamp.to_sec()\n"
                 "topics = [t for t, _ in rospy.get_published_topics()]\n"
                 "print('RESULT %%.3f %%s' %% (lag, '/clock' in topics))\n" % PROCESS_TIMEOUT_S)
        try:
            env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % free_port())
            base = ["roslaunch", "--skip-log-check", "ascc_sim", "sim.launch",
                    "world:=" + self.world_path, "use_sim_time:=false"]
            with in_background(base + ["max_sim_time_s:=60",
                                       "link_dir:=" + os.path.join(tmp, "links")],
                               env) as launch:
                rc, out = run([sys.executable, "-c", probe], env=env)
                self.assertEqual(rc, 0, out[-3000:])
                words = out.split("RESULT ")[-1].split()
                lag, clock = float(words[0]), words[1]
                rospy.loginfo("wall-clock mode: scan received %.3f s after its stamp", lag)
                self.assertEqual(clock, "False", "a /clock publisher in wall-clock mode")
                # a stamp on the wall clock, received at once (simulated time would be < 60 s)
                self.assertLess(abs(lag), 1.0, out[-3000:])
                os.killpg(launch.pid, 2)
                launch.wait(timeout=PROCESS_TIMEOUT_S)
            env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % free_port())
            rc, out = run(base + ["real_time_factor:=4", "drivers:=false",
                                  "link_dir:=" + os.path.join(tmp, "links4")], env=env)
            self.assertIn("~real_time_factor 4: with /use_sim_time false", out)
            self.assertIn("needs a real-time factor of 1", out)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def test_laser_mount_off(self):
        """sim.launch laser_mount:=false (own master): /tf_static carries map -> odom but
        no base_link -> laser, which a robot description gives instead."""
        tmp = tempfile.mkdtemp(prefix="ascc_sim_laser_mount_")
        probe = ("import rospy\n"
                 "from tf2_msgs.msg import TFMessage\n"
                 "rospy.init_node('tf_static_probe')\n"
                 "m = rospy.wait_for_message('/tf_static', TFMessage, timeout=%.0f)\n"
                 "print('RESULT ' + ' '.join(t.header.frame_id + '>' + t.child_frame_id\n"
                 "                           for t in m.transforms))\n" % PROCESS_TIMEOUT_S)
        try:
            env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % free_port())
            with in_background(["roslaunch", "--skip-log-check", "ascc_sim", "sim.launch",
                                "world:=" + self.world_path, "drivers:=false",
                                "map_to_odom:=true", "laser_mount:=false",
                                "max_sim_time_s:=60",
                                "link_dir:=" + os.path.join(tmp, "links")], env):
                rc, out = run([sys.executable, "-c", probe], env=env)
            self.assertEqual(rc, 0, out[-3000:])
            pairs = out.split("RESULT ")[-1].split()
            self.assertEqual(pairs, ["map>odom"], out[-3000:])
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    def test_bad_input_ends_the_node_with_one_line(self):
        """A malformed world or a bad parameter: exit status non-zero, one line naming the
        file (or parameter) and what is wrong, no traceback."""
        tmp = tempfile.mkdtemp(prefix="ascc_sim_bad_world_")
        office_map = os.path.join(os.path.dirname(self.world_path), "..", "..", "worlds",
                                  "maps", "office.yaml")
        missing = os.path.join(tmp, "missing.yaml")
        broken = os.path.join(tmp, "broken.yaml")
        with open(broken, "w", encoding="utf-8") as f:
            f.write("name: broken\nmap: %s\nrobots:\n  - {name: a, pose: [2.0, 5.5, 0]\n"
                    % office_map)
        on_wall = os.path.join(tmp, "on_wall.yaml")
        with open(on_wall, "w", encoding="utf-8") as f:  # the corridor's south wall
            f.write("name: on_wall\nmap: %s\nrobots:\n  - {name: r, pose: [2.0, 4.4, 0]}\n"
                    % office_map)
        procs = []
        cases = [  # (private params, words the line must contain)
            ({"world": missing}, [missing, "cannot read", "no such file"]),
            ({"world": broken}, [broken, "syntax error", "line 5"]),
            ({"world": on_wall}, [on_wall, "robots[0].pose", "overlaps"]),
            ({"world": self.world_path, "robots": "robotX"},
             [self.world_path, "no robot with namespace robotX"]),
            ({"world": self.world_path, "physics_dt_s": "0"}, ["~physics_dt_s", "> 0"]),
        ]
        try:
            for i, (params, _) in enumerate(cases):
                cmd = ["rosrun", "ascc_sim", "simulator", "__name:=bad_input_sim%d" % i,
                       "_link_dir:=" + os.path.join(tmp, "links%d" % i),
                       "_wait_for_drivers_s:=0"]
                cmd += ["_%s:=%s" % kv for kv in params.items()]
                procs.append((cmd, subprocess.Popen(
                    cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                    universal_newlines=True, start_new_session=True)))
            deadline = time.monotonic() + PROCESS_TIMEOUT_S
            for (cmd, proc), (_, words) in zip(procs, cases):
                try:
                    out, _ = proc.communicate(timeout=max(1.0, deadline - time.monotonic()))
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, 15)
                    out, _ = proc.communicate()
                    self.fail("%s did not end: %s" % (" ".join(cmd), out[-2000:]))
                lines = [ln for ln in out.splitlines() if ln.strip()]
                what = "%s -> rc %s, output %r" % (" ".join(cmd[3:]), proc.returncode, out)
                self.assertNotEqual(proc.returncode, 0, what)
                self.assertNotIn("Traceback", out, what)
                self.assertEqual(len(lines), 1, what)
                self.assertIn("ascc_sim: ", lines[0], what)
                for w in words:
                    self.assertIn(w.lower(), lines[0].lower(), what)
        finally:
            for _, proc in procs:
                if proc.poll() is None:
                    os.killpg(proc.pid, 15)
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "simulator_node", SimulatorNodeTest, sys.argv)
