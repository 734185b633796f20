#!/usr/bin/env python3
"""Replay a recorded exploration run through the navigator offline and measure its CPU.

Reads a ROS bag of a run (``bench_cpu.py`` / ``bench_exploration.py`` record one: /map,
/move_base/goal, /scan, /tf, /tf_static) and drives ``navigation.Navigator`` (the
move_base stand-in's core, ``config/move_base.yaml``) with the run's inputs at their
recorded times: every map message (deserialised as the node does), every goal, and a
control step at ``controller_frequency`` with the robot pose from TF (map -> odom ->
base_link) and the newest scan's points. Plans are made inside the step (no planner
thread), so all the navigator's work is on one thread and counted.

The robot in the bag drove by the recorded commands, not by these: the replay measures the
work the navigator does for the inputs it had, which is what its CPU share is made of.
Prints the number of plans and a digest of their paths (two versions of the navigator that
plan alike give the same digest), the process CPU time split into map handling
(deserialisation, grid conversion, ``set_map``) and control steps (with re-plans), per
minute of the run, and the whole run's share of one core at real time; ``--profile N``
prints cProfile's N heaviest functions.

    python3 ascc_eval/scripts/replay_navigator.py RUN.bag [--until-s 600] [--profile 25]
"""
import argparse
import cProfile
import hashlib
import os
import pstats
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the node runs

import numpy as np  # noqa: E402
import yaml  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NAV = os.path.join(HERE, "..", "..", "ascc_navigation")   # the package measured
sys.path.insert(0, os.path.join(NAV, "src"))

from ascc_common.grid import map_from_msg  # noqa: E402
from ascc_common.params import from_params  # noqa: E402
from ascc_common.pose2d import compose, yaw_of  # noqa: E402
from ascc_navigation import navigation as nav  # noqa: E402
from ascc_navigation.laser import LaserMount  # noqa: E402


def load_params():
    """MoveBaseParams from config/move_base.yaml (as the node reads them)."""
    with open(os.path.join(NAV, "config", "move_base.yaml")) as f:
        tree = yaml.safe_load(f)

    def get(name, default=None):
        node = tree
        for part in name.lstrip("~").split("/"):
            if not isinstance(node, dict) or part not in node:
                return default
            node = node[part]
        return node
    return from_params(nav.MoveBaseParams, get, "~")


def read_bag(path, until_s):
    """Time-ordered events (t [s], kind, payload) and the laser mount."""
    from move_base_msgs.msg import MoveBaseActionGoal
    from rosbags.rosbag1 import Reader
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage

    events, mount = [], None
    with Reader(path) as reader:
        topics = ("/map", "/move_base/goal", "/scan", "/tf", "/tf_static")
        wanted = [c for c in reader.connections if c.topic in topics]
        for conn, t_ns, raw in reader.messages(connections=wanted):
            t = t_ns * 1e-9
            if t > until_s and conn.topic != "/tf_static":
                break
            if conn.topic == "/map":
                events.append((t, "map", raw))      # deserialised in the timed replay
            elif conn.topic == "/move_base/goal":
                p = MoveBaseActionGoal().deserialize(raw).goal.target_pose.pose
                events.append((t, "goal", (p.position.x, p.position.y, yaw_of(p.orientation))))
            elif conn.topic == "/scan":
                m = LaserScan().deserialize(raw)
                events.append((t, "scan", (np.asarray(m.ranges, float), m.angle_min,
                                           m.angle_increment, m.range_min, m.range_max)))
            else:
                for tr in TFMessage().deserialize(raw).transforms:
                    p, q = tr.transform.translation, tr.transform.rotation
                    if tr.child_frame_id == "laser" and mount is None:
                        mount = LaserMount.from_transform(p.x, p.y, q.x, q.y, q.z, q.w)
                    elif (tr.header.frame_id, tr.child_frame_id) in (("map", "odom"),
                                                                    ("odom", "base_link")):
                        events.append((t, tr.child_frame_id, (p.x, p.y, yaw_of(q))))
    events.sort(key=lambda e: e[0])
    return events, mount


def scan_points(scan, mount, range_max):
    r, angle_min, inc, rmin, rmax = scan
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r >= rmin) & (r < min(rmax, range_max))
    a = mount.beam_angles(r.size, angle_min, inc)[ok]
    return np.column_stack([mount.x + r[ok] * np.cos(a), mount.y + r[ok] * np.sin(a)])


def replay(events, mount, params, numpy_maps):
    """Returns per-minute CPU [s] of map handling and of steps, plans made, map updates."""
    from nav_msgs.msg import OccupancyGrid
    from rospy.numpy_msg import numpy_msg
    msg_class = numpy_msg(OccupancyGrid) if numpy_maps else OccupancyGrid
    navigator = nav.Navigator(params.planner, params.controller, params.nav)
    period = 1.0 / params.controller_frequency
    map_odom = odom_base = scan = None
    minutes = {}
    plans = maps = 0
    digest = hashlib.sha1()  # of every plan made: equal digests, equal plans
    next_step = None
    for t, kind, data in events:
        while next_step is not None and next_step <= t:
            if map_odom is not None and odom_base is not None and scan is not None:
                pose = np.array(compose(map_odom, odom_base))
                c0 = time.process_time()
                pts = scan_points(scan, mount, params.raytrace_range)
                step = navigator.step(next_step, pose, pts, period)
                minutes.setdefault(int(next_step // 60), [0.0, 0.0])[1] += \
                    time.process_time() - c0
                if step.new_path is not None:
                    plans += 1
                    digest.update(np.ascontiguousarray(step.new_path, dtype=float).tobytes())
            next_step += period
        if kind == "map":
            c0 = time.process_time()
            grid, info = map_from_msg(msg_class().deserialize(data))
            navigator.set_map(grid, info)
            minutes.setdefault(int(t // 60), [0.0, 0.0])[0] += time.process_time() - c0
            maps += 1
        elif kind == "goal":
            navigator.set_goal(data[0], data[1], data[2], t)
            if next_step is None:
                next_step = t
        elif kind == "scan":
            scan = data
        elif kind == "odom":
            map_odom = data
        elif kind == "base_link":
            odom_base = data
    return minutes, plans, maps, digest.hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--until-s", type=float, default=1e9, help="replay this much of the bag")
    ap.add_argument("--profile", type=int, default=0, metavar="N",
                    help="print cProfile's N heaviest functions (cumulative)")
    ap.add_argument("--list-maps", action="store_true",
                    help="deserialise maps into lists as plain rospy does (the node before "
                         "it used numpy_msg)")
    args = ap.parse_args()
    events, mount = read_bag(args.bag, args.until_s)
    params = load_params()
    prof = cProfile.Profile() if args.profile else None
    if prof:
        prof.enable()
    minutes, plans, maps, digest = replay(events, mount, params, not args.list_maps)
    if prof:
        prof.disable()
    total_map = sum(v[0] for v in minutes.values())
    total_step = sum(v[1] for v in minutes.values())
    span = events[-1][0] - events[0][0]
    print("%s: %.0f s replayed, %d map updates, %d plans (sha1 of the paths %s)"
          % (os.path.basename(args.bag), span, maps, plans, digest[:12]))
    print("%6s %12s %12s %10s" % ("minute", "map_cpu_s", "step_cpu_s", "core_%"))
    for m in sorted(minutes):
        a, b = minutes[m]
        print("%6d %12.2f %12.2f %10.1f" % (m, a, b, 100.0 * (a + b) / 60.0))
    print("total: maps %.1f s, steps %.1f s: %.1f %% of one core at real time"
          % (total_map, total_step, 100.0 * (total_map + total_step) / max(span, 1e-9)))
    if prof:
        pstats.Stats(prof).sort_stats("cumulative").print_stats(args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())
