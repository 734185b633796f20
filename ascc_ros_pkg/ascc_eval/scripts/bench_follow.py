#!/usr/bin/env python3
"""Following benchmark in the simulator (target_follower's issue goals; thesis 5.3).

Runs `launch/sim/follow.launch monitor:=true` (simulator + Create driver + simulated Q24
served as MJPEG over HTTP + q24_camera + target_detector + target_follower, measured by
follow_monitor on ground truth) once per seed, one after another, each its own roslaunch
on its own master port, and prints per run and over all runs: the distance error on
straight segments (mean, 95th percentile, share within the band), the minimum distance,
bumper hits, corners and how many the follower re-acquired after, the person's path.
The goals: error within +-0.3 m of the set point on straight segments, no collision,
re-acquired after every corner, over 5 seeds. Seeds change every noise source (laser,
encoders, camera noise and drift); `--world` runs another world with a person (held out:
ascc_sim/worlds/<name>.yaml). Each run's report (JSON + PNG) goes to OUT/<world>_seed<n>/,
the table to OUT/results.json. About 2.5 minutes of wall time per office run.

    python ascc_ros_pkg/ascc_eval/scripts/bench_follow.py [--seeds 0 1 2 3 4]
        [--world office_follow] [--rtf 1] [--out output/bench_follow] [--report-only]
        [--follower-params FILE.yaml] [--record]

`--record`: each run also writes OUT/<world>_seed<n>/run.bag (the follower's target, odom,
scan, cmd_vel, state, trail and the simulator's ground truth) for `plot_follow_run.py`.
"""
import argparse
import json
import os
import sys

from ascc_common.ports import free_port
from ascc_eval.launching import run_launch

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.realpath(__file__)),
                                    "..", "..", ".."))
KEYS = ("straight_error_mean_m", "straight_error_p95_m", "straight_error_max_m",
        "straight_within_band", "distance_min_m", "bumps", "corners_reacquired",
        "person_path_m", "end_reason", "detection_fraction", "detected_range_error_p95_m",
        "followed_range_error_p95_m")


def run_one(world, seed, rtf, out, port, timeout_s, max_time_s, follower_params="",
            record=False, http_port=18080):
    run_dir = os.path.join(out, "%s_seed%d" % (world, seed))
    wall = run_launch(os.path.join(ROOT, "launch", "sim", "follow.launch"),
                      {"world": os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds",
                                             world + ".yaml"),
                       "seed": seed, "real_time_factor": rtf, "monitor": "true",
                       "output_dir": run_dir, "label": "%s seed %d" % (world, seed),
                       "max_time_s": max_time_s, "follower_params": follower_params,
                       "record": "true" if record else "false", "http_port": http_port},
                      run_dir, port, timeout_s, "%s/seed %d" % (world, seed))
    path = os.path.join(run_dir, "%s_seed_%d.json" % (world, seed))
    row = {"world": world, "seed": seed, "wall_s": round(wall, 1)}
    if not os.path.exists(path):
        row["error"] = "no summary (see %s/launch.log)" % run_dir
        return row
    with open(path) as f:
        s = json.load(f)
    row.update({k: s.get(k) for k in KEYS})
    row["corners"] = len(s.get("corners", []))
    return row


def fmt(v, spec="%.2f"):
    return "-" if v is None else spec % v


def summarise(rows):
    print("\n%-14s %4s %7s %7s %7s %7s %6s %5s %8s %7s %6s %7s %7s" % (
        "world", "seed", "mean", "p95", "max", "in band", "min d", "bumps", "corners",
        "path", "seen", "det p95", "fol p95"))
    for r in rows:
        if "error" in r:
            print("%-14s %4d  %s" % (r["world"], r["seed"], r["error"]))
            continue
        print("%-14s %4d %6sm %6sm %6sm %6s%% %5sm %5d %4d/%-3d %6sm %5s%% %6sm %6sm" % (
            r["world"], r["seed"], fmt(r["straight_error_mean_m"]),
            fmt(r["straight_error_p95_m"]), fmt(r["straight_error_max_m"]),
            fmt(100 * r["straight_within_band"] if r["straight_within_band"] is not None
                else None, "%.0f"), fmt(r["distance_min_m"]), r["bumps"],
            r["corners_reacquired"], r["corners"], fmt(r["person_path_m"], "%.1f"),
            fmt(100 * r["detection_fraction"] if r.get("detection_fraction") is not None
                else None, "%.0f"),
            fmt(r.get("detected_range_error_p95_m")), fmt(r.get("followed_range_error_p95_m"))))
    ok = [r for r in rows if "error" not in r and r["straight_error_mean_m"] is not None]
    if ok:
        def mean(k):
            return sum(r[k] for r in ok) / len(ok)
        print("%-14s %4s %6sm %6sm %6sm %6s%% %5sm %5d %4d/%-3d" % (
            "all", len(ok), fmt(mean("straight_error_mean_m")),
            fmt(max(r["straight_error_p95_m"] for r in ok)),
            fmt(max(r["straight_error_max_m"] for r in ok)),
            fmt(100 * mean("straight_within_band"), "%.0f"),
            fmt(min(r["distance_min_m"] for r in ok)), sum(r["bumps"] for r in ok),
            sum(r["corners_reacquired"] for r in ok), sum(r["corners"] for r in ok)))
        print("(mean: mean over runs of each run's mean error; p95, max: the worst run's; "
              "in band: mean share of straight samples within +-band; seen: share of "
              "samples with a detection; det / fol p95: 95th percentile of the detector's / "
              "the followed point's range error against the true distance)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--world", default="office_follow")
    ap.add_argument("--rtf", default="1.0", help="real-time factor cap")
    ap.add_argument("--max-time-s", type=float, default=400.0)
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "bench_follow"))
    ap.add_argument("--port", type=int, default=0, help="ROS master port (0: a free one)")
    ap.add_argument("--http-port", type=int, default=18080,
                    help="loopback port of the simulated camera's MJPEG stream")
    ap.add_argument("--follower-params", default="",
                    help="YAML of target_follower ~parameters over the defaults")
    ap.add_argument("--record", action="store_true",
                    help="record a bag of each run (run.bag in its directory)")
    ap.add_argument("--report-only", action="store_true")
    args = ap.parse_args(argv)
    args.port = args.port or free_port()
    os.makedirs(args.out, exist_ok=True)
    table = os.path.join(args.out, "results.json")
    rows = []
    if os.path.exists(table):
        with open(table) as f:
            rows = json.load(f)
    params = os.path.abspath(args.follower_params) if args.follower_params else ""
    if not args.report_only:
        for seed in args.seeds:
            print("[bench_follow] %s seed %d ..." % (args.world, seed), flush=True)
            row = run_one(args.world, seed, args.rtf, args.out, args.port, 900,
                          args.max_time_s, params, args.record, args.http_port)
            rows = [r for r in rows if (r["world"], r["seed"]) != (args.world, seed)]
            rows.append(row)
            with open(table, "w") as f:
                json.dump(rows, f, indent=1)
            print("[bench_follow]   %s" % json.dumps(row), flush=True)
    summarise(sorted(rows, key=lambda r: (r["world"], r["seed"])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
