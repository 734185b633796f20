#!/usr/bin/env python3
"""Accuracy benchmark of collaborative localization in the simulator (thesis 3.5).

    python ascc_ros_pkg/colloc_fusion/scripts/bench_colloc.py [--trials 20] [--seed 1]
        [--settle-s 15] [--record-s 20] [--out DIR]

Trial 0 is the placement of worlds/three_robots.yaml; trials 1..N place the cone and the
three robots at random (colloc_fusion.bench.random_placement, seeded). Each trial runs
launch/sim/colloc.launch (centralized, thesis method without the gate: gate_chi2:=0; own
master on its own port) in a child process that records every robot's target_estimate
and the node's fused_target between sim time settle_s and settle_s + record_s, and the
cone's true position
(ground_truth/objects: evaluation only). The errors of each robot alone and of each fusion
method, without and with the consistency gate (``gate_chi2`` 13.8), are then replayed
offline on the same estimates (colloc_fusion.bench.replay_errors) and summarised: per
trial the mean error of each; over the trials the mean and the maximum of those means,
and in how many trials each fusion beat the best single robot.
Writes DIR/summary.json and DIR/summary.md (default DIR: /tmp/bench_colloc).

``--slam-map SEED``: amcl uses a map of the office built beforehand by the SLAM stand-in
(colloc_fusion.slam_map, mapper seed SEED, its map frame where that drive started),
saved to DIR/slam_map.yaml and served latched on /slam_map; the desk corners measured in
it give the truth -> map transform (residual printed), which places the robots' initial
poses in that map and moves the truth into it.

The truth is calibrated into map as in thesis 3.4.1: the desk corners are measured in
the map the robots' amcl uses (colloc_fusion.landmarks; here the simulator's ground-truth
grid, so the transform comes out as the identity) and the truth -> map transform fitted to
them is applied to the cone's true position. ``--reanalyse`` recomputes the summary from
the recordings already in DIR.
"""
import argparse
import json
import math
import os
import platform
import signal
import subprocess
import sys
import time

import numpy as np
import yaml

from ascc_common import map_io
from ascc_common.grid import grid_to_msg_data
from ascc_sim.world import load_world
from colloc_fusion import slam_map
from colloc_fusion.bench import (
    ROBOTS,
    Placement,
    beats_counts,
    best_on_average,
    error_split,
    pooled_error_correlation,
    random_placement,
    replay_errors,
    write_placement_world,
)
from colloc_fusion.calibration import Rigid2D
from colloc_fusion.estimate import TargetEstimate
from colloc_fusion.fusion import METHODS
from colloc_fusion.landmarks import calibrate, measure
from colloc_fusion.win_rates import p_majority, rayleigh_sigma, win_rates

SLAM_MAP_TOPIC = "/slam_map"  # --slam-map: where the saved map is served
GATE_CHI2 = 13.8  # chi-square 99.9 % for 2 dof: the consistency gate's variants
VARIANTS = dict([(m, {"method": m}) for m in METHODS]
                + [(m + "+gate", {"method": m, "gate_chi2": GATE_CHI2}) for m in METHODS])
HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
WORLD = os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds", "three_robots.yaml")
LAUNCH = os.path.join(ROOT, "launch", "sim", "colloc.launch")
GMAPPING_YAML = os.path.join(ROOT, "ascc_ros_pkg", "ascc_navigation", "config", "gmapping.yaml")
BOUNDS = (0.3, 0.3, 8.2, 6.7)  # [m] the office's inside (three_robots map: 8.5 x 7 m)


def world_placement(world) -> Placement:
    cone = next(o for o in world.objects if o.type == "cone")
    return Placement((cone.pose.x, cone.pose.y),
                     {r.name: (r.pose.x, r.pose.y, r.pose.yaw) for r in world.robots})


def write_world(path, placement, src=WORLD):
    return write_placement_world(path, placement, src)


# -- child: one trial under ROS ------------------------------------------------------------
def wait_for_sim_time(master, timeout_s):
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            if master.hasParam("/use_sim_time"):
                return
        except OSError:
            pass
        if time.monotonic() > deadline:
            raise RuntimeError("no master / use_sim_time after %.0f s" % timeout_s)
        time.sleep(0.5)


def record(args):
    import rosgraph
    import rospy
    from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped

    from ascc_sim.msg import SimObjectArray

    with open(args.placement) as f:
        p = json.load(f)
    to_map = Rigid2D(*args.calib, np.zeros(0))  # truth -> amcl's map (identity: its grid)
    cmd = ["roslaunch", "-p", str(args.port), LAUNCH, "world:=" + args.world,
           "seed:=%d" % args.sim_seed,
           "truth_xy_m:=[%.4f, %.4f]" % tuple(to_map.apply(p["cone"])),
           "refine_pose:=%s" % ("true" if args.refine == "on" else "false"),
           "gate_chi2:=0.0",  # the node records the thesis rule; the gate is replayed
           "map_topic:=" + (SLAM_MAP_TOPIC if args.map_yaml else "/ground_truth/map")]
    cmd += ["%s_pose:=%.4f %.4f %.4f" % ((r,) + tuple(to_map.apply_pose(p["robots"][r])))
            for r in ROBOTS]
    log = open(args.output + ".launch.log", "w")
    launch = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    try:
        wait_for_sim_time(rosgraph.Master("/bench_colloc"), 120.0)
        rospy.init_node("bench_colloc_recorder", disable_signals=True)
        # --slam-map: the saved map, served as map_server would (latched; kept alive)
        map_pub = serve_map(args.map_yaml) if args.map_yaml else None  # noqa: F841
        ests, fused, truth = [], [], []
        amcl = {r: [] for r in ROBOTS}  # [stamp, x, y, yaw] of each amcl_pose
        true_pose = {}  # robot -> [x, y, yaw], newest from the simulator

        def yaw(q):
            return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y ** 2 + q.z ** 2))

        def on_amcl(msg, robot):
            p = msg.pose.pose
            amcl[robot].append([msg.header.stamp.to_sec(), p.position.x, p.position.y,
                                yaw(p.orientation)])

        def on_truth(msg, robot):
            p = msg.pose
            true_pose[robot] = [p.position.x, p.position.y, yaw(p.orientation)]

        def on_est(msg, robot):
            c = msg.pose.covariance
            ests.append([robot, msg.header.stamp.to_sec(), msg.pose.pose.position.x,
                         msg.pose.pose.position.y, [[c[0], c[1]], [c[6], c[7]]]])

        subs = [rospy.Subscriber(r + "/target_estimate", PoseWithCovarianceStamped, on_est,
                                 callback_args=r, queue_size=50) for r in ROBOTS]
        subs += [rospy.Subscriber(r + "/amcl_pose", PoseWithCovarianceStamped, on_amcl,
                                  callback_args=r, queue_size=20) for r in ROBOTS]
        subs += [rospy.Subscriber("ground_truth/%s/pose" % r, PoseStamped, on_truth,
                                  callback_args=r, queue_size=2) for r in ROBOTS]
        subs.append(rospy.Subscriber("fused_target", PoseWithCovarianceStamped,
                                     lambda m: fused.append([m.header.stamp.to_sec(),
                                                             m.pose.pose.position.x,
                                                             m.pose.pose.position.y]),
                                     queue_size=50))
        subs.append(rospy.Subscriber(
            "ground_truth/objects", SimObjectArray,
            lambda m: truth.extend((o.pose.position.x, o.pose.position.y)
                                   for o in m.objects if o.type == "cone"), queue_size=2))
        end = args.settle_s + args.record_s
        deadline = time.monotonic() + args.timeout_s
        while rospy.get_time() < end:
            if time.monotonic() > deadline or launch.poll() is not None:
                raise RuntimeError("sim time %.1f s of %.1f after %.0f s wall (launch %s)"
                                   % (rospy.get_time(), end, args.timeout_s, launch.poll()))
            time.sleep(0.2)
        out = {"estimates": ests, "fused": fused, "truth": truth[0] if truth else None,
               "settle_s": args.settle_s, "end_s": end, "amcl": amcl,
               "robot_truth": true_pose, "refine": args.refine}
        with open(args.output, "w") as f:
            json.dump(out, f)
        rospy.signal_shutdown("done")
    finally:
        if launch.poll() is None:
            os.killpg(launch.pid, signal.SIGINT)
            try:
                launch.wait(30.0)
            except subprocess.TimeoutExpired:
                os.killpg(launch.pid, signal.SIGKILL)
                launch.wait()
        log.close()
    return 0


def serve_map(path, topic=None, frame="map"):
    import rospy
    from nav_msgs.msg import OccupancyGrid

    grid, info = map_io.load_map(path)
    msg = OccupancyGrid()
    msg.header.frame_id = frame
    msg.header.stamp = rospy.Time.now()
    msg.info.resolution = info.resolution
    msg.info.width, msg.info.height = info.width, info.height
    msg.info.origin.position.x, msg.info.origin.position.y = info.origin_x, info.origin_y
    msg.info.origin.orientation.w = 1.0
    msg.data = grid_to_msg_data(grid)
    pub = rospy.Publisher(topic or SLAM_MAP_TOPIC, OccupancyGrid, queue_size=1, latch=True)
    pub.publish(msg)
    return pub


# -- parent: trials and summary ------------------------------------------------------------
def calibration(world_path):
    """The truth -> map transform from the desk corners in the grid amcl uses."""
    world = load_world(world_path)
    truth = {o.name: (o.pose.x, o.pose.y) for o in world.objects if o.type == "landmark"}
    found, _ = measure(world.truth_map.occupancy, world.truth_map.info, truth)
    return calibrate(truth, found)[0]


def recorded(path):
    """True if the recording holds the truth and estimates (not so when another master
    answered on the port, or the clock jumped past the window)."""
    with open(path) as f:
        rec = json.load(f)
    return rec.get("truth") is not None and bool(rec.get("estimates"))


def analyse(path, world_path, fit=None):
    with open(path) as f:
        rec = json.load(f)
    fit = fit if fit is not None else calibration(world_path)
    truth = tuple(fit.apply(np.array(rec["truth"], dtype=float)))
    ests = [TargetEstimate(r, x, y, np.array(c), t) for r, t, x, y, c in rec["estimates"]]
    left = {}
    errs = replay_errors(ests, truth, rec["settle_s"], rec["end_s"], variants=VARIANTS,
                         left_out=left)
    node = [math.hypot(x - truth[0], y - truth[1])
            for t, x, y in rec["fused"] if t >= rec["settle_s"]]
    row = {k: (float(np.mean(v)) if v else None) for k, v in errs.items()}
    row["calibration"] = {"theta_rad": fit.theta, "t_m": [fit.tx, fit.ty],
                          "rms_m": fit.rms_m}
    row["node_thesis"] = float(np.mean(node)) if node else None
    if rec.get("amcl"):
        robots_truth = {r: fit.apply_pose(np.array(v, dtype=float))
                        for r, v in rec["robot_truth"].items()}
        row["split"] = error_split(ests, rec["amcl"], robots_truth, truth,
                                   rec["settle_s"], rec["end_s"])
    row["samples"] = {k: len(v) for k, v in errs.items()}
    # each robot's mean error vector over the recording (its bias in this placement)
    vec = {}
    for e in ests:
        if rec["settle_s"] <= e.stamp_s <= rec["end_s"]:
            vec.setdefault(e.robot, []).append((e.x - truth[0], e.y - truth[1]))
    row["error_vector"] = {r: np.mean(v, axis=0).tolist() for r, v in vec.items()}
    # the robots each variant left out: fusion steps in all, of them as inconsistent with
    # the others (the gate), and the first such reason the status gave (else the first)
    row["left_out"] = {}
    for v, d in left.items():
        row["left_out"][v] = {}
        for r, why in d.items():
            gated = [w for w in why if "inconsistent" in w]
            row["left_out"][v][r] = [len(why), len(gated), (gated or why)[0]]
    return row


def summarise(rows, advance_robot=None, theory_trials=200000):
    """Over the random placements (trial >= 1; trial 0, the world's placement, apart):
    each estimate's mean / median / max of the per-trial errors; in how many trials each
    variant beats the best robot chosen afterwards with the truth, the median robot and
    ``advance_robot`` (chosen in advance on another set); the ideal fusion's expected
    shares (colloc_fusion.win_rates) for robots with this set's error statistics; the
    robots the gate left out."""
    keys = list(ROBOTS) + ["best_robot"] + list(VARIANTS) + ["node_thesis"]
    for r in rows:
        singles = [r[k] for k in ROBOTS if r.get(k) is not None]
        r["best_robot"] = min(singles) if singles else None
    trial0 = [r for r in rows if r["trial"] == 0]
    rows = [r for r in rows if r["trial"] > 0]
    summ = {}
    for k in keys:
        vals = [r[k] for r in rows if r.get(k) is not None]
        summ[k] = {"mean_m": float(np.mean(vals)) if vals else None,
                   "median_m": float(np.median(vals)) if vals else None,
                   "max_m": float(np.max(vals)) if vals else None, "trials": len(vals)}
    summ["best_on_average_here"] = best_on_average(rows) if rows else None
    summ["advance_robot"] = advance_robot
    summ["beats"] = beats_counts(rows, list(VARIANTS) + ["node_thesis"],
                                 advance_robot=advance_robot)
    if rows:  # what an ideal fusion could do with robots like these (Gaussian, unbiased)
        sig = {r: rayleigh_sigma([row[r] for row in rows if row.get(r) is not None])
               for r in ROBOTS}
        th = win_rates([sig[r] for r in ROBOTS], trials=theory_trials)
        th["p_most"] = {k: p_majority(len(rows), th[k]) for k in
                        ("per_trial_best", "best_on_average", "median_robot")}
        summ["theory"] = dict(th, sigma_m=sig, n_trials=len(rows))
    # the robots' error vectors' correlation, wrong convergences (> 0.3 m) left out
    vecs = [r["error_vector"] for r in rows if "error_vector" in r and all(
        math.hypot(*v) <= 0.3 for v in r["error_vector"].values())]
    summ["error_correlation"] = {"pooled": pooled_error_correlation(vecs),
                                 "trials": len(vecs)}
    drops = []  # robots a gated variant left out as inconsistent with the others
    for r in rows + trial0:
        for v, d in r.get("left_out", {}).items():
            for robot, (_, n, why) in d.items():
                if n:
                    drops.append({"trial": r["trial"], "variant": v, "robot": robot,
                                  "steps": n, "of_steps": r["samples"].get(v, 0),
                                  "robot_error_m": r.get(robot), "reason": why})
    summ["gate_drops"] = drops
    summ["trial0"] = {k: trial0[0].get(k) for k in keys} if trial0 else None
    splits = [v for r in rows for v in r.get("split", {}).values()]
    if splits:  # each robot's error: its pose estimate's share and its measurement's
        summ["split"] = {k: {"mean": float(np.mean([v[k] for v in splits])),
                             "max": float(np.max([v[k] for v in splits]))}
                         for k in splits[0]}
        summ["split"]["robot_trials"] = len(splits)
    return summ


def advance_choice(path):
    """The robot best on average (smallest mean error) on the random placements of the
    benchmark run whose summary.json is ``path`` (or its directory)."""
    if os.path.isdir(path):
        path = os.path.join(path, "summary.json")
    with open(path) as f:
        rows = [r for r in json.load(f)["trials"] if not r.get("failed")
                and r.get("trial", 0) > 0]
    return best_on_average(rows)


def report(summ):
    """The summary as Markdown."""
    adv = summ.get("advance_robot")
    f3 = lambda v: "-" if v is None else "%.3f" % v  # noqa: E731
    lines = ["Random placements (trial 0 apart). Beats: in how many trials the error is "
             "below the best robot chosen afterwards with the truth (per trial) / %s / "
             "the median robot." % ("the robot chosen in advance, %s" % adv if adv else
                                    "(no --advance-from: no robot chosen in advance)"),
             "",
             "| estimate | mean / median / max [m] | trials | beats per-trial best | "
             "beats %s | beats median robot |" % ("%s (chosen in advance)" % adv if adv else "-"),
             "|---|---|---|---|---|---|"]
    for k, v in summ.items():
        if not isinstance(v, dict) or "mean_m" not in v or v["mean_m"] is None:
            continue
        b = summ["beats"].get(k)
        cells = ["", "", ""]
        if b:
            cells = ["%d of %d" % (b["per_trial_best"], b["trials"]),
                     "%d of %d" % (b["advance_robot"], b["advance_trials"]) if adv else "-",
                     "%d of %d" % (b["median_robot"], b["trials"])]
        lines.append("| %s | %s / %s / %s | %d | %s |" % (
            k, f3(v["mean_m"]), f3(v["median_m"]), f3(v["max_m"]), v["trials"],
            " | ".join(cells)))
    lines.append("")
    lines.append("Best on average on this set (chosen afterwards): %s. Against each robot "
                 "as if fixed in advance (wins of trials): %s." % (
                     summ.get("best_on_average_here"), "; ".join(
                         "%s %s" % (m, ", ".join("%s %d/%d" % (r, w, n) for r, (w, n) in
                                                 summ["beats"][m]["each_robot"].items()))
                         for m in ("thesis", "thesis+gate", "information+gate"))))
    th = summ.get("theory")
    if th:
        lines += ["", "Theory (colloc_fusion.win_rates, %d Monte Carlo trials): robots "
                  "unbiased 2D Gaussian, Rayleigh scales from this set's median errors %s; "
                  "an ideal fusion is below the per-trial best in %.1f %%, below the robot "
                  "best on average in %.1f %% (closed form %.1f %%), below the median robot "
                  "in %.1f %% of trials." % (
                      th["trials"], ", ".join("%s %.4f m" % kv for kv in
                                              sorted(th["sigma_m"].items())),
                      100 * th["per_trial_best"], 100 * th["best_on_average"],
                      100 * th["closed_form_b"], 100 * th["median_robot"]),
                  "Chance that the ideal fusion wins in more than half of these %d trials: "
                  "%.2f / %.2f / %.2f (per-trial best / best on average / median robot)."
                  % (th["n_trials"], th["p_most"]["per_trial_best"],
                     th["p_most"]["best_on_average"], th["p_most"]["median_robot"])]
    ec = summ.get("error_correlation") or {}
    if ec.get("pooled") is not None:
        lines += ["Correlation of the robots' error vectors (pooled over pairs and axes, "
                  "%d trials without a robot > 0.3 m off): %.2f (0: independent, as the "
                  "theory assumes)." % (ec["trials"], ec["pooled"])]
    if summ.get("gate_drops"):
        lines += ["", "Left out by the gate (the status's reason):"]
        lines += ["- trial %d, %s: %s in %d of %d steps (its own error %s m): %s"
                  % (d["trial"], d["variant"], d["robot"], d["steps"], d["of_steps"],
                     f3(d["robot_error_m"]), d["reason"]) for d in summ["gate_drops"]]
    t0 = summ.get("trial0")
    if t0:
        lines += ["", "Trial 0 (the world's placement): " + ", ".join(
            "%s %s" % (k, f3(v)) for k, v in t0.items() if v is not None)]
    if "split" in summ:
        sp = summ["split"]
        lines += ["", "Each robot's error (%d robot-trials), mean / max [m; pose_yaw rad]: "
                  % sp["robot_trials"] + "; ".join(
                      "%s %.4f / %.4f" % (k, sp[k]["mean"], sp[k]["max"])
                      for k in ("total", "pose", "measurement", "pose_xy", "pose_yaw"))]
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20, help="random placements")
    ap.add_argument("--seed", type=int, default=1, help="seed of the placements")
    ap.add_argument("--settle-s", type=float, default=15.0, help="[s sim] localising")
    ap.add_argument("--record-s", type=float, default=20.0, help="[s sim] recorded")
    ap.add_argument("--timeout-s", type=float, default=400.0, help="[s wall] per trial")
    ap.add_argument("--port", type=int, default=11611, help="first master port")
    ap.add_argument("--out", default="/tmp/bench_colloc")
    ap.add_argument("--refine", choices=("on", "off"), default="on",
                    help="amcl's refine_estimate (scan match of the pose; off: as before)")
    ap.add_argument("--slam-map", type=int, metavar="SEED", default=None,
                    help="amcl on a map built by the SLAM stand-in (colloc_fusion.slam_map, "
                    "mapper seed SEED; its own frame, calibrated from the desk corners)")
    ap.add_argument("--advance-from", metavar="DIR", default=None,
                    help="another run's --out: its robot best on average is the robot "
                    "chosen in advance that this set's fusions are compared with")
    ap.add_argument("--theory-trials", type=int, default=200000,
                    help="Monte Carlo draws of the theory section")
    ap.add_argument("--reanalyse", action="store_true",
                    help="only recompute the summary from the recordings in --out")
    ap.add_argument("--record", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--world", help=argparse.SUPPRESS)
    ap.add_argument("--placement", help=argparse.SUPPRESS)
    ap.add_argument("--sim-seed", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--output", help=argparse.SUPPRESS)
    ap.add_argument("--calib", type=float, nargs=3, default=[0.0, 0.0, 0.0],
                    help=argparse.SUPPRESS)
    ap.add_argument("--map-yaml", default="", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.record:
        return record(args)
    os.makedirs(args.out, exist_ok=True)
    world = load_world(WORLD)
    rng = np.random.default_rng(args.seed)
    placements = [world_placement(world)] + [random_placement(world.grid, rng, BOUNDS)
                                             for _ in range(args.trials)]
    fit, map_yaml, child = None, "", []
    if args.slam_map is not None:
        map_yaml = os.path.join(args.out, "slam_map.yaml")
        with open(GMAPPING_YAML) as f:
            grid, info, fit, exact, failed = slam_map.calibrated_map(
                world, yaml.safe_load(f), seed=args.slam_map)
        map_io.save_map(map_yaml, grid, info, comment="SLAM stand-in, seed %d"
                        % args.slam_map)
        print(slam_map.describe(args.slam_map, fit, exact, failed, world, map_yaml),
              flush=True)
        child = ["--map-yaml", map_yaml, "--calib", repr(fit.theta), repr(fit.tx),
                 repr(fit.ty)]
    rows = []
    for k, p in enumerate(placements):
        stem = os.path.join(args.out, "trial_%02d" % k)
        with open(stem + "_placement.json", "w") as f:
            json.dump({"cone": p.cone, "robots": p.robots}, f)
        if args.reanalyse:
            if not os.path.isfile(stem + ".json") or not recorded(stem + ".json"):
                print("trial %d: no recording" % k, flush=True)
                rows.append({"trial": k, "failed": True})
                continue
            row = analyse(stem + ".json", stem + "_world.yaml", fit)
            row.update(trial=k, cone=p.cone)
            rows.append(row)
            continue
        write_world(stem + "_world.yaml", p)
        port = args.port + k
        env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % port)
        t0 = time.monotonic()
        res = subprocess.run([sys.executable, os.path.abspath(__file__), "--record",
                              "--world", stem + "_world.yaml", "--placement",
                              stem + "_placement.json", "--sim-seed", str(k), "--port",
                              str(port), "--output", stem + ".json", "--settle-s",
                              str(args.settle_s), "--record-s", str(args.record_s),
                              "--timeout-s", str(args.timeout_s), "--refine", args.refine]
                             + child, env=env)
        if res.returncode != 0 or not os.path.isfile(stem + ".json") or not recorded(
                stem + ".json"):
            print("trial %d failed (see %s.json.launch.log)" % (k, stem), flush=True)
            rows.append({"trial": k, "failed": True})
            continue
        row = analyse(stem + ".json", stem + "_world.yaml", fit)
        row.update(trial=k, wall_s=round(time.monotonic() - t0, 1), cone=p.cone)
        rows.append(row)
        print("trial %d: %s" % (k, ", ".join("%s %.3f" % (m, row[m]) for m in
                                             list(ROBOTS) + list(VARIANTS)
                                             if row.get(m) is not None)), flush=True)
    ok = [r for r in rows if not r.get("failed")]
    adv = advance_choice(args.advance_from) if args.advance_from else None
    summ = summarise(ok, adv, args.theory_trials)
    machine = "%s, %s, %d cores, Python %s" % (platform.node(), platform.processor() or
                                               platform.machine(), os.cpu_count(),
                                               platform.python_version())
    if fit is not None:
        summ["slam_calibration"] = {"theta_rad": fit.theta, "t_m": [fit.tx, fit.ty],
                                    "residuals_m": fit.residuals_m.tolist(),
                                    "rms_m": fit.rms_m}
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump({"summary": summ, "trials": rows, "machine": machine,
                   "args": vars(args)}, f, indent=1)
    text = report(summ)
    with open(os.path.join(args.out, "summary.md"), "w") as f:
        f.write(text + "\n")
    print(text)
    print("%d of %d trials ran; machine: %s" % (len(ok), len(rows), machine))
    return 0 if len(ok) == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
