#!/usr/bin/env python3
"""Replay a recorded run through the mapper offline and score it against the ground truth.

Reads a ROS bag of a simulated run (``make demo`` / ``bench_exploration.py`` record one: /scan,
/tf, /tf_static, /ground_truth/<robot>/pose and /ground_truth/map), feeds every scan with the
odometry from TF (odom -> base_link, interpolated at the scan's stamp) to ``SlamMapper`` (the
node's core, the shipped ``config/gmapping.yaml`` plus ``--set`` overrides) and prints per
filter seed:
  * updates and CPU ms per update;
  * pose error of the mapper's estimate against the simulator's ground truth (max / mean /
    at the end, position [m]; max heading [deg]), in the world frame (the map frame is the
    odometry frame at the first scan, placed in the world by the ground truth there);
  * map accuracy (``grid.map_agreement``: known cells that agree with the truth) and the
    share of the truth's free cells the map knows;
  * with ``--set loop_closure=true``: what the pose graph's loop searches did (closed,
    kept as an edge, rejected: how many, and the last reason of each);
  * odometry timing glitches: the heading of odom -> base_link against the ground truth at
    the same stamp, minus its slow drift (running median over 5 s). Wheel odometry drifts
    slowly; a glitch of several degrees that comes and goes means odometry stamped at the
    wrong time while the robot turned (a driver starved of CPU reads a backlog late).

With ``--start-turn`` it prints how the recorded mapper went through the run's first turn on
the spot (the explorer's look round): radians turned, filter updates in the turn (changes of
``map -> odom``) and the estimate's error just after it. A CPU-starved mapper updates
rarely there (docs/results/ascc_navigation.md, "The start turn moves the frame").

With ``--online-every-s S`` it also prints the recorded run's own mapper (``map -> odom`` in
the bag, composed with the odometry) against the truth every S seconds: position and heading
error beside the odometry's alone, to see where and when an online map went wrong.

With ``--track-every-s S`` each replay prints its own estimate against the truth every S
seconds of the run (at the first filter update after each mark): the best particle's position
and heading error and the range of all particles' heading errors. Two groups of particles
whose headings differ by a few hundredths of a radian, each consistent with its own map, are
how a corridor map breaks: the resampling keeps one of them by chance
(docs/results/ascc_navigation.md, "How a corridor map breaks").

With ``--lineage`` each replay prints how far the map's own path (the final best particle's
lineage, the poses its map was built from) travelled along its heading beyond the odometry,
and where that came from: the motion model's draws that survived the resampling (the
weights' preference) and the matcher's corrections to them, per kind of update (straight or
turning; with the pull along the travel on or off; with the heading along the walls or
oblique to them, by the wall-axis prior's reference). A map whose sides come out long has a
lineage that went further than the wheels; this tells the filter's two steps apart
(docs/results/ascc_navigation.md, "Every part of the map is right").

The online mapper sees the same data but has to keep up with the clock: it drops scans whose
TF arrives more than ``tf_wait_s`` late. ``--drop-late-s`` emulates that from the bag's receive
times. So a map that is bad online and good in the replay points at the load, not at the
filter.

    python3 scripts/replay_mapper.py RUN.bag [--seeds 0 1] [--set lskip=0] [--drop-late-s 0.5]
        [--out DIR]  (writes the replayed maps as map_server YAML + PGM)
        [--online-every-s 40] [--start-turn] [--seeds]  (no --seeds value: no replay)
        [--track-every-s 10]  (the replay's own error and its particles' heading spread)
        [--lineage]  (the map's path beyond the odometry: surviving draws and the matcher)
"""
import argparse
import math
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the node runs

import cv2  # noqa: E402
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NAV = os.path.join(HERE, "..", "..", "ascc_navigation")   # the package measured
sys.path.insert(0, os.path.join(NAV, "src"))

from bench_mapper import add_parameter_arguments, parameters_from_arguments  # noqa: E402

from ascc_common.grid import FREE, UNKNOWN, map_from_msg  # noqa: E402
from ascc_common.map_io import save_map  # noqa: E402
from ascc_common.params import from_params  # noqa: E402
from ascc_common.pose2d import (  # noqa: E402
    compose,
    inverse,
    wrap_angle,
    yaw_of,
)
from ascc_navigation import mapper as M  # noqa: E402
from ascc_navigation.grid import map_agreement  # noqa: E402
from ascc_navigation.laser import LaserMount  # noqa: E402
from ascc_navigation.wall_axes import wrap_right_angle  # noqa: E402

GLITCH_WINDOW_S = 5.0  # running median window of the odometry's slow heading drift
START_TURN_WITHIN_S = 25.0  # [s] --start-turn looks for the turn this long from the start


class RunBag:
    """What the replay needs from a run bag, as numpy arrays (times in seconds)."""

    def __init__(self, path, scan_topic="/scan", odom_frame="odom", base_frame="base_link",
                 map_frame="map"):
        from geometry_msgs.msg import PoseStamped
        from nav_msgs.msg import OccupancyGrid
        from rosbags.rosbag1 import Reader
        from sensor_msgs.msg import LaserScan
        from tf2_msgs.msg import TFMessage

        self.scans = []      # (stamp, ranges float32)
        self.scan_meta = None  # angle_min, angle_increment, range_min, range_max
        odom, received, truth, map_odom = [], [], [], []
        self.mount = None
        self.truth_map = None
        with Reader(path) as reader:
            wanted = [c for c in reader.connections
                      if c.topic in (scan_topic, "/tf", "/tf_static", "/ground_truth/map")
                      or (c.topic.startswith("/ground_truth/") and c.topic.endswith("/pose"))]
            for conn, t_ns, raw in reader.messages(connections=wanted):
                if conn.topic == scan_topic:
                    m = LaserScan().deserialize(raw)
                    self.scan_meta = (m.angle_min, m.angle_increment, m.range_min, m.range_max)
                    self.scans.append((m.header.stamp.to_sec(), np.asarray(m.ranges, np.float32)))
                    self.laser_frame = m.header.frame_id
                elif conn.topic in ("/tf", "/tf_static"):
                    for tr in TFMessage().deserialize(raw).transforms:
                        p = tr.transform.translation
                        if tr.header.frame_id == odom_frame and tr.child_frame_id == base_frame:
                            odom.append((tr.header.stamp.to_sec(), p.x, p.y,
                                         yaw_of(tr.transform.rotation)))
                            received.append(t_ns * 1e-9)
                        elif tr.header.frame_id == map_frame and tr.child_frame_id == odom_frame:
                            map_odom.append((tr.header.stamp.to_sec(), p.x, p.y,
                                             yaw_of(tr.transform.rotation)))
                        elif tr.header.frame_id == base_frame and self.mount is None \
                                and "laser" in tr.child_frame_id:
                            self.mount = LaserMount.from_transform(
                                p.x, p.y, *(getattr(tr.transform.rotation, k) for k in "xyzw"))
                elif conn.topic == "/ground_truth/map":
                    m = OccupancyGrid().deserialize(raw)
                    self.truth_map = map_from_msg(m)
                else:
                    m = PoseStamped().deserialize(raw)
                    truth.append((m.header.stamp.to_sec(), m.pose.position.x, m.pose.position.y,
                                  yaw_of(m.pose.orientation)))
        if not self.scans or not odom or self.mount is None:
            raise SystemExit("%s: needs %s, odom -> base_link TF and a base -> laser TF"
                             % (path, scan_topic))
        order = np.argsort(np.asarray(odom)[:, 0], kind="stable")
        self.odom = np.asarray(odom)[order]
        self.odom_received = np.asarray(received)[order]
        self.truth = np.asarray(truth) if truth else None
        # the recorded mapper's map -> odom (stamp order; post-dated as gmapping does)
        self.map_odom = None
        if map_odom:
            m = np.asarray(map_odom)
            self.map_odom = m[np.argsort(m[:, 0], kind="stable")]

    def odom_at(self, t, max_gap_s=0.5):
        """Odometry pose (x, y, theta) interpolated at t, or None outside / across a gap."""
        o = self.odom
        i = int(np.searchsorted(o[:, 0], t))
        if i <= 0 or i >= len(o) or o[i, 0] - o[i - 1, 0] > max_gap_s:
            return None
        a, b = o[i - 1], o[i]
        f = (t - a[0]) / max(b[0] - a[0], 1e-9)
        return np.array([a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]),
                         a[3] + f * float(wrap_angle(b[3] - a[3]))])

    def mapper_inputs(self, skip=None):
        """What the mapper is fed, in the bag's order: (stamp, ``M.ScanInput``, odometry pose
        at the stamp) of each scan with odometry there (``odom_at``); ``skip``: per scan,
        true to leave it out (as the online node drops late ones)."""
        for k, (stamp, ranges) in enumerate(self.scans):
            if skip is not None and skip[k]:
                continue
            odom = self.odom_at(stamp)
            if odom is not None:
                yield stamp, M.ScanInput(stamp, ranges, *self.scan_meta), odom

    def truth_at(self, t):
        g = self.truth
        i = int(np.clip(np.searchsorted(g[:, 0], t), 1, len(g) - 1))
        a, b = g[i - 1], g[i]
        f = float(np.clip((t - a[0]) / max(b[0] - a[0], 1e-9), 0.0, 1.0))
        return np.array([a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]),
                         a[3] + f * float(wrap_angle(b[3] - a[3]))])

    def world_from_map(self, t, odom):
        """The map frame (the odometry frame) in the world, placed by the truth at t where
        the odometry read ``odom``."""
        return compose(self.truth_at(t), inverse(odom))

    def map_odom_at(self, t):
        """The recorded map -> odom in force at t (the last one stamped at or before it;
        the first before any), or None if the bag has none."""
        m = self.map_odom
        if m is None:
            return None
        return m[max(int(np.searchsorted(m[:, 0], t, side="right")) - 1, 0), 1:]

    def map_frame(self):
        """(stamp of the first scan with odometry, the map frame in the world): the map frame
        is the odometry frame there, placed by the truth (as for the replay); (None, None)
        without such a scan."""
        t0 = next((s for s, _ in self.scans if self.odom_at(s) is not None), None)
        if t0 is None:
            return None, None
        return t0, self.world_from_map(t0, self.odom_at(t0))

    def online_track(self, every_s):
        """The recorded run's own estimate against the truth every ``every_s`` [s] from the
        first scan: rows (t, true x, y, theta in the map frame, odometry position error [m],
        odometry heading error [rad], mapper position error [m], mapper heading error [rad]).
        The map frame is the odometry frame at the first scan with odometry (as for the
        replay), placed in the world by the truth there."""
        if self.truth is None or self.map_odom is None:
            return []
        t0, world_from_map = self.map_frame()
        if t0 is None:
            return []
        map_from_world = inverse(world_from_map)
        rows = []
        for t in np.arange(t0, min(self.odom[-1, 0], self.truth[-1, 0]), every_s):
            odom = self.odom_at(t)
            if odom is None:
                continue
            true = compose(map_from_world, self.truth_at(t))
            est = compose(self.map_odom_at(t), odom)
            rows.append((t - t0, true[0], true[1], true[2],
                         math.hypot(odom[0] - true[0], odom[1] - true[1]),
                         float(wrap_angle(odom[2] - true[2])),
                         math.hypot(est[0] - true[0], est[1] - true[1]),
                         float(wrap_angle(est[2] - true[2]))))
        return rows

    def start_turn(self, within_s=START_TURN_WITHIN_S, moving_rad=0.05, settled_radps=0.1,
                   after_s=1.0):
        """The recorded mapper through the run's first turn on the spot (the explorer's look
        round at the start), or None without one, a map -> odom or the truth. The turn starts
        where the odometry's heading first differs by ``moving_rad`` from the first scan's,
        within ``within_s`` of it, and ends where the heading rate (over 0.5 s) stays below
        ``settled_radps`` for two steps. Returns a dict: ``start_s`` (from the first scan),
        ``duration_s``, ``turned_rad``, ``updates`` (changes of the recorded map -> odom in
        the turn: one per filter update), ``rad_per_update`` and ``error_after`` (x, y [m]:
        the recorded estimate minus the truth in the world, ``after_s`` after the turn; the
        map frame placed by the truth at the first scan, as for the replay)."""
        if self.truth is None or self.map_odom is None:
            return None
        t0, world_from_map = self.map_frame()
        if t0 is None:
            return None
        o = self.odom
        sel = (o[:, 0] >= t0) & (o[:, 0] <= t0 + within_s)
        t, yaw = o[sel, 0], np.unwrap(o[sel, 3])
        moved = np.abs(yaw - yaw[0]) > moving_rad
        if t.size < 2 or not moved.any():
            return None
        start = t[np.argmax(moved)]
        grid = np.arange(start, t[-1], 0.5)
        rate = np.abs(np.diff(np.interp(grid, t, yaw))) / 0.5
        calm = np.nonzero((rate[1:] < settled_radps) & (rate[:-1] < settled_radps))[0]
        end = grid[calm[0] + 1] if calm.size else grid[-1]
        turned = abs(float(np.interp(end, t, yaw) - np.interp(start, t, yaw)))
        m = self.map_odom
        changed = np.nonzero(np.any(np.abs(np.diff(m[:, 1:], axis=0)) > 1e-9, axis=1))[0] + 1
        updates = int(np.count_nonzero((m[changed, 0] >= start) & (m[changed, 0] <= end)))
        at = end + after_s
        odom = self.odom_at(at)
        error = (math.nan, math.nan)
        if odom is not None:
            est = compose(world_from_map, compose(self.map_odom_at(at), odom))
            true = self.truth_at(at)
            error = (float(est[0] - true[0]), float(est[1] - true[1]))
        return {"start_s": float(start - t0), "duration_s": float(end - start),
                "turned_rad": turned, "updates": updates,
                "rad_per_update": turned / updates if updates else math.inf,
                "error_after": error}

    def tf_lateness(self):
        """Per scan: how long after its stamp the first odometry TF at or after the stamp was
        received [s] (inf if never)."""
        stamps = np.array([s for s, _ in self.scans])
        first = np.minimum.accumulate(self.odom_received[::-1])[::-1]
        i = np.searchsorted(self.odom[:, 0], stamps)
        late = np.full(stamps.size, np.inf)
        ok = i < len(first)
        late[ok] = first[i[ok]] - stamps[ok]
        return late

    def odometry_glitches(self):
        """|heading of odometry - truth - slow drift| [deg] at every odometry sample, and the
        time [s] each sample stands for."""
        o, g = self.odom, self.truth
        gyaw = np.interp(o[:, 0], g[:, 0], np.unwrap(g[:, 3]))
        diff = np.degrees(np.unwrap(o[:, 3]) - gyaw)
        rate = len(o) / max(o[-1, 0] - o[0, 0], 1e-9)
        k = int(GLITCH_WINDOW_S * rate) | 1
        windows = np.lib.stride_tricks.sliding_window_view(np.pad(diff, k // 2, mode="edge"), k)
        slow = np.median(windows[:, :: max(1, k // 50)], axis=1)
        return np.abs(diff - slow), np.diff(o[:, 0], append=o[-1, 0])


def track_row(t, true, best, particles):
    """One row of the replay's track at ``t`` [s]: the true pose (x, y, theta) and the best
    particle's pose ``best`` in the map frame, all particles' poses ``particles`` (N, 3).
    Returns (t, true x, y, theta, best's position error [m], its heading error [rad], the
    particles' smallest and largest heading error [rad])."""
    head = np.asarray(wrap_angle(np.asarray(particles)[:, 2] - true[2]))
    return (t, float(true[0]), float(true[1]), float(true[2]),
            math.hypot(best[0] - true[0], best[1] - true[1]),
            float(wrap_angle(best[2] - true[2])), float(head.min()), float(head.max()))


TURNING_RAD = 0.05  # lineage_travel: an update whose odometry turned more is "turning"
OBLIQUE_RAD = 0.4   # lineage_travel: a heading this far off the walls' axes is "oblique"


def lineage_travel(steps, best, wall_reference=None):
    """Where the travel of particle ``best``'s lineage along its heading beyond the odometry
    came from. ``steps``: per filter update, in order, (poses before it (N, 3), odometry
    increment (dx, dy, dtheta), the motion model's draws (N, 3), the matched poses (N, 3),
    each particle's index before the resampling (N,) or None, the along pull used). Going
    back from ``best`` after the last update through the resamplings, each update adds to
    its kind ("straight" / "turning" by TURNING_RAD, "pull" / "no pull"): the odometry's
    forward step [m], the draw's offset from the odometry's prediction along the previous
    heading ("noise": the draws that survived), and the matcher's correction along it
    ("matcher"). With ``wall_reference`` (the filter's wall-axis reference direction
    [rad]), each update also adds to "aligned" or "oblique": its heading within or beyond
    OBLIQUE_RAD of the walls' axes (modulo a right angle). Returns {kind: {"updates",
    "odometry_m", "noise_m", "matcher_m"}} plus the same summed under "all"."""
    kinds = {}
    b = best
    for prev, delta, sampled, matched, came_from, pull in reversed(steps):
        j = b if came_from is None else int(came_from[b])
        p0 = prev[j]
        c, s = math.cos(p0[2]), math.sin(p0[2])
        pred = compose(p0, delta)
        noise = (sampled[j, 0] - pred[0]) * c + (sampled[j, 1] - pred[1]) * s
        match = (matched[j, 0] - sampled[j, 0]) * c + (matched[j, 1] - sampled[j, 1]) * s
        kind = "%s, %s" % ("turning" if abs(delta[2]) > TURNING_RAD else "straight",
                           "pull" if pull > 0.0 else "no pull")
        keys = [kind, "all"]
        if wall_reference is not None:
            off = abs(float(wrap_right_angle(p0[2] - wall_reference)))
            keys.append("oblique" if off >= OBLIQUE_RAD else "aligned")
        for k in keys:
            d = kinds.setdefault(k, {"updates": 0, "odometry_m": 0.0, "noise_m": 0.0,
                                     "matcher_m": 0.0})
            d["updates"] += 1
            d["odometry_m"] += float(delta[0])
            d["noise_m"] += float(noise)
            d["matcher_m"] += float(match)
        b = j
    return kinds


def replay(run, params, seed, drop_late_s, late, track_every_s=0.0, on_track=None,
           lineage=False):
    """One replay with filter ``seed``; ``late`` = run.tf_lateness() (used if drop_late_s > 0).
    With ``track_every_s`` > 0, ``on_track(row)`` gets a ``track_row`` at the first filter
    update after every ``track_every_s`` [s] of the run (from the first scan). With
    ``lineage``, the result's "lineage" is ``lineage_travel`` of the final best particle."""
    mapper = M.SlamMapper(from_params(M.MapperConfig, params.get), seed=seed)
    world_from_map = None
    map_from_world = None
    first_stamp = None
    next_track = 0.0
    errors = []
    cpu = 0.0
    updates = 0
    skip = np.asarray(late) > drop_late_s if drop_late_s > 0 else None
    dropped = 0 if skip is None else int(skip.sum())
    loops = {}  # the pose graph's loop searches (loop_closure on): status -> count
    last_loop = {}  # status -> the reason of its last one
    steps = []
    for stamp, scan, odom in run.mapper_inputs(skip):
        prev = mapper.slam.poses.copy() if lineage and mapper.slam.initialized else None
        c0 = time.process_time()
        out = mapper.handle_scan(scan, odom, run.mount)
        cpu += time.process_time() - c0
        if prev is not None and out.status == M.UPDATED and out.stats.sampled_poses is not None:
            st = out.stats
            matched = st.sampled_poses if st.weighed_poses is None else st.weighed_poses
            steps.append((prev, np.asarray(st.odom_delta, float), st.sampled_poses, matched,
                          st.resampled_from, st.along_pull))
        if out.loop is not None and out.loop.status != "none":
            loops[out.loop.status] = loops.get(out.loop.status, 0) + 1
            last_loop[out.loop.status] = out.loop.reason
        if out.status in (M.STARTED, M.RESET) and run.truth is not None:
            # the map frame is the odometry frame at the first scan
            world_from_map = run.world_from_map(stamp, odom)
            map_from_world = inverse(world_from_map)
            first_stamp = stamp if first_stamp is None else first_stamp
        if out.status == M.UPDATED:
            updates += 1
            if world_from_map is not None:
                est = compose(world_from_map, mapper.robot_pose())
                true = run.truth_at(stamp)
                errors.append((math.hypot(est[0] - true[0], est[1] - true[1]),
                               abs(math.degrees(float(wrap_angle(est[2] - true[2]))))))
                elapsed = stamp - first_stamp
                if track_every_s > 0 and elapsed >= next_track:
                    next_track = track_every_s * (math.floor(elapsed / track_every_s) + 1)
                    on_track(track_row(elapsed, compose(map_from_world, true),
                                       mapper.robot_pose(), mapper.slam.poses))
    grid, info = mapper.occupancy()
    result = {"seed": seed, "updates": updates, "dropped": dropped,
              "ms": 1e3 * cpu / max(updates, 1), "grid": grid, "info": info,
              "loop_closure": mapper.cfg.loop.enabled, "loops": loops, "last_loop": last_loop}
    if lineage:
        result["lineage"] = lineage_travel(steps, mapper.slam.best, mapper.slam.wall_reference)
    if errors:
        e = np.asarray(errors)
        result.update(max_err=float(e[:, 0].max()), mean_err=float(e[:, 0].mean()),
                      end_err=float(e[-1, 0]), max_head=float(e[:, 1].max()))
    if run.truth_map is not None and world_from_map is not None:
        truth, tinfo = run.truth_map
        result["acc"] = map_agreement(grid, info, truth, tinfo, world_from_map)["accuracy"]
        result["known_free"] = known_share(grid, info, truth, tinfo, world_from_map)
    return result


def known_share(grid, info, truth, tinfo, world_from_map):
    """Share of the truth's free cells whose place the map knows (free or occupied)."""
    ty, tx = np.nonzero(truth == FREE)
    wx, wy = tinfo.cell_to_world(tx, ty)
    mx, my = compose(inverse(world_from_map), np.stack([wx, wy, np.zeros_like(wx)], 1))[:, :2].T
    ix, iy = info.world_to_cell(mx, my)
    inside = info.contains(ix, iy)
    known = np.zeros(tx.size, bool)
    known[inside] = grid[iy[inside], ix[inside]] != UNKNOWN
    return float(known.mean()) if known.size else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bag")
    ap.add_argument("--seeds", type=int, nargs="*", default=[0],
                    help="filter seeds (none: no replay)")
    add_parameter_arguments(ap)
    ap.add_argument("--drop-late-s", type=float, default=0.0,
                    help="skip scans whose odometry TF was received later than this after "
                         "the scan's stamp, as the online node does (its tf_wait_s); 0: off")
    ap.add_argument("--out", default="", help="write each replayed map here (YAML + PGM)")
    ap.add_argument("--online-every-s", type=float, default=0.0,
                    help="print the recorded mapper's pose error against the truth every "
                         "this many seconds of the run; 0: off")
    ap.add_argument("--track-every-s", type=float, default=0.0,
                    help="print each replay's estimate against the truth every this many "
                         "seconds of the run, with its particles' heading spread; 0: off")
    ap.add_argument("--lineage", action="store_true",
                    help="print how far each replay's map path went along its heading beyond "
                         "the odometry: surviving motion draws and matcher corrections")
    ap.add_argument("--start-turn", action="store_true",
                    help="print how the recorded mapper went through the run's first turn "
                         "on the spot: filter updates per radian and its error after it")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    params = parameters_from_arguments(ap, args)
    t0 = time.perf_counter()
    run = RunBag(args.bag)
    print("%s: %d scans, %d odometry TFs, read in %.0f s; overrides: %s"
          % (args.bag, len(run.scans), len(run.odom), time.perf_counter() - t0,
             " ".join(args.set) or "none"))
    if run.truth is not None:
        glitch, dur = run.odometry_glitches()
        print("odometry timing glitches (heading vs truth minus drift): p99 %.1f deg, max %.1f "
              "deg; time above 5 deg %.1f s, above 10 deg %.1f s (of %.0f s)"
              % (np.percentile(glitch, 99), glitch.max(), dur[glitch > 5].sum(),
                 dur[glitch > 10].sum(), run.odom[-1, 0] - run.odom[0, 0]))
    late = run.tf_lateness()
    print("odometry TF received after the scan's stamp: p50 %.2f s, p99 %.2f s; %.1f %% of "
          "scans later than 0.5 s" % (np.median(late), np.percentile(late, 99),
                                      100.0 * np.mean(late > 0.5)))
    if args.online_every_s > 0:
        rows = run.online_track(args.online_every_s)
        if not rows:
            print("online track: the bag has no map -> odom or no ground truth")
        else:
            print("the recorded mapper (map -> odom * odometry) against the truth, map frame:")
            print("%7s %19s %18s %18s" % ("t [s]", "true x, y [m], th", "odometry err",
                                          "mapper err"))
            for t, x, y, th, oe, oh, me, mh in rows:
                print("%7.0f %7.1f %6.1f %5.2f %9.2fm %7.3f %9.2fm %7.3f"
                      % (t, x, y, th, oe, oh, me, mh))
    if args.start_turn:
        turn = run.start_turn()
        if turn is None:
            print("start turn: none in the first %.0f s, or the bag has no map -> odom or "
                  "truth" % START_TURN_WITHIN_S)
        else:
            print("start turn at %.1f s: %.2f rad in %.1f s, %d filter updates (%.2f rad "
                  "each); the recorded estimate 1 s after it: (%+.2f, %+.2f) m off the truth"
                  % (turn["start_s"], turn["turned_rad"], turn["duration_s"], turn["updates"],
                     turn["rad_per_update"], *turn["error_after"]))
    if args.seeds:
        replay_seeds(run, params, args, late)


def replay_seeds(run, params, args, late):
    """Replay ``run`` once per filter seed in ``args.seeds``; print each one's summary row
    (and its track with ``args.track_every_s``), write its map to ``args.out``."""
    header = "%4s %7s %7s %6s %8s %8s %8s %8s %8s %10s" % (
        "seed", "updates", "dropped", "ms", "max_err", "mean_err", "end_err", "max_head",
        "accuracy", "known_free")
    if args.track_every_s <= 0:
        print(header)
    for seed in args.seeds:
        if args.track_every_s > 0:
            print("replay, filter seed %d, against the truth (map frame; particles: the range "
                  "of their heading errors [rad]):" % seed)
            print("%7s %19s %18s %16s" % ("t [s]", "true x, y [m], th", "best particle err",
                                          "particles"))
        r = replay(run, params, seed, args.drop_late_s, late, args.track_every_s,
                   lambda row: print("%7.0f %7.1f %6.1f %5.2f %9.2fm %7.3f %7.3f ..%6.3f"
                                     % row, flush=True), lineage=args.lineage)
        if args.track_every_s > 0:
            print(header)
        print("%4d %7d %7d %6.1f %7.2fm %7.2fm %7.2fm %7.1fd %7.2f%% %9.2f%%" % (
            seed, r["updates"], r["dropped"], r["ms"], r.get("max_err", math.nan),
            r.get("mean_err", math.nan), r.get("end_err", math.nan),
            r.get("max_head", math.nan), 100 * r.get("acc", math.nan),
            100 * r.get("known_free", math.nan)))
        if r["loop_closure"]:  # as the mapper's config resolved it, default included
            print("     loop closure: %s" % (", ".join(
                "%s %d (last: %s)" % (k, v, r["last_loop"][k])
                for k, v in sorted(r["loops"].items())) or "no loop found"))
        for kind, d in sorted(r.get("lineage", {}).items()):
            print("     lineage beyond the odometry, %-18s %5d updates, odometry %7.1f m: "
                  "surviving draws %+.3f m, matcher %+.3f m"
                  % (kind + ":", d["updates"], d["odometry_m"], d["noise_m"], d["matcher_m"]))
        sys.stdout.flush()
        if args.out:
            os.makedirs(args.out, exist_ok=True)
            save_map(os.path.join(args.out, "replay_seed%d.yaml" % seed), r["grid"], r["info"])


if __name__ == "__main__":
    main()
