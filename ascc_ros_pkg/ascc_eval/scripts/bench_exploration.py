#!/usr/bin/env python3
"""Exploration benchmark in the simulator (Explore-Bench's metrics), for
docs/results/frontier_detector.md.

Runs `launch/explore_demo.launch` (simulator + driver + mapper + navigator + explorer +
monitor, each run its own roslaunch on its own master port) for every world x strategy x
seed, one after another, and prints per run and per (world, strategy) the final coverage of
the reachable area, the path length, the time to 90/95/99 % coverage (simulated s) and the
collisions (bumper hits). Writes every run's report to OUT/<world>_<strategy>_seed<n>/ and
a table to OUT/results.json. Runs already in OUT/results.json from an earlier call are kept
(a run with the same world, strategy and seed is replaced), so the benchmark can be run in
batches; `--report-only` only prints the table again and redraws the plots
(OUT/coverage_<world>.png: coverage vs time of every run, one colour per strategy).
Coverage alone cannot tell a broken SLAM map (one that maps a corridor twice still "knows"
the ground truth's cells), so every run's final map is also compared with the world's
ground truth (`map_ok`: known cells of the map, placed by the start pose, that agree with the
truth; ascc_navigation.grid.map_agreement; `placement`: the shift of the map's frame at
which it agrees best and the agreement there, ascc_eval.map_quality.best_placement, which
tells a map of the right shape whose frame ended up off from a misshapen one), and
coverage is reported twice: `coverage`, the share of the truth's reachable cells that the
SLAM map knows *at their true place* (map drift counts against it), and `seen`, the share
the laser has reached from the robot's true poses (ascc_eval.report.SeenArea: the
exploration alone). `--report-only` back-fills `seen` of runs from before the monitor
measured it from their run.bag, and the map figures of runs from before they existed.
The simulator's real-time factor cap is per world unless `--rtf` is given (DEFAULT_RTF):
4 everywhere (the corridor ran at 2 while its mapper and navigator needed more CPU than 2
cores give at 4; since the stack's CPU work, 4 runs there without a collision, see
docs/results/frontier_detector.md). Long: an office run takes 2-4 minutes of wall time, a
corridor run about 5. The simulated wheels have a scale error drawn per seed (an
uncalibrated robot); `--calibrate` first measures it once per seed with ascc_sim's
calibrate.launch (about a minute) and explores with the driver's correction loaded.

    python ascc_ros_pkg/ascc_eval/scripts/bench_exploration.py \
        [--worlds office lab corridor] [--strategies utility nearest] [--seeds 0 1 2 3 4]
        [--rtf R] [--max-time-s 4000] [--out output/bench_exploration] [--calibrate]
        [--report-only]
"""
import argparse
import json
import os
import sys

from ascc_common.ports import free_port
from ascc_eval.launching import run_launch

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.realpath(__file__)),
                                    "..", "..", ".."))
LEVELS = ("0.90", "0.95", "0.99")
# real-time factor cap per world
DEFAULT_RTF = {"office": "4", "lab": "4", "corridor": "4", "annex": "4"}


# The calibration's speed is fixed: a seed's factor is the same whichever --rtf explores.
CALIBRATION_RTF = 4


def calibrate(seed, out, port, timeout_s=600):
    """The driver's odom_linear_scale_correction for the robot of ``seed``, measured once by
    ascc_sim's calibrate.launch (irobot_create_2_1's calibrate_odometry at an office wall)
    and kept in OUT/calibration_seed<seed>.yaml; returns (path, factor), or (None, None)
    when the calibration wrote nothing (see its launch.log)."""
    import yaml

    path = os.path.join(out, "calibration_seed%d.yaml" % seed)
    if not os.path.exists(path):
        print("  calibrating the wheels of seed %d ..." % seed, flush=True)
        run_launch(os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "launch", "calibrate.launch"),
                   {"seed": seed, "output_file": path, "real_time_factor": CALIBRATION_RTF},
                   os.path.join(out, "calibration_seed%d" % seed), port, timeout_s,
                   "calibration seed %d" % seed)
    if not os.path.exists(path):
        return None, None
    with open(path) as f:
        return path, float(yaml.safe_load(f)["odom_linear_scale_correction"])


def run_one(world, strategy, seed, rtf, out, port, timeout_s, max_time_s, calibrated=False,
            frontend=""):
    run_dir = os.path.join(out, "%s_%s_seed%d" % (world, strategy, seed))
    launch_args = {"world": world, "strategy": strategy, "seed": seed,
                   "real_time_factor": rtf, "output_dir": run_dir, "max_time_s": max_time_s,
                   "slam_frontend": frontend}
    factor = None
    if calibrated:
        path, factor = calibrate(seed, out, port)
        if path is None:
            return {"world": world, "strategy": strategy, "seed": seed,
                    "error": "calibration failed"}
        launch_args["odom_calibration"] = path
    wall = run_launch(os.path.join(ROOT, "launch", "explore_demo.launch"), launch_args,
                      run_dir, port, timeout_s, "%s/%s/seed %d" % (world, strategy, seed))
    path = os.path.join(run_dir, "summary.json")
    if not os.path.exists(path):
        return {"world": world, "strategy": strategy, "seed": seed, "error": "no summary",
                "wall_s": wall}
    with open(path) as f:
        s = json.load(f)
    final = final_map(run_dir)
    return {"world": world, "strategy": strategy, "seed": seed, "wall_s": round(wall, 1),
            "odom_scale_correction": factor, "frontend": frontend or "config",
            "coverage": s.get("final_coverage"), "path_m": s.get("path_m"),
            "time_s": s.get("time_s"), "bumps": s.get("bumps"),
            "end": s.get("end_reason"), "map_ok": map_check(final, world),
            "placement": map_placement(final, world),
            "sides_pct": side_errors(final, world),
            "seen": s.get("seen_coverage"),
            "time_to": {lv: s.get("time_to_coverage_s", {}).get(lv) for lv in LEVELS}}


def final_map(run_dir):
    """The run's final SLAM map (grid, GridInfo), saved in the world's frame (map pose
    (0, 0, 0); report.compose); None without one."""
    from ascc_common.map_io import load_map

    explored = os.path.join(run_dir, "summary_explored.yaml")
    return load_map(explored) if os.path.exists(explored) else None


def world_truth(world):
    """The world's ground-truth grid and GridInfo."""
    from ascc_common.map_io import load_map

    return load_map(os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds", "maps",
                                 world + ".yaml"))


def map_check(final, world):
    """Share of the final SLAM map's (``final_map``) known cells that agree with the
    world's ground truth (cells off the truth's known area count as disagreeing,
    map_quality.agreed_share); None without a saved map."""
    from ascc_eval.map_quality import agreed_share
    from ascc_navigation.grid import map_agreement

    if final is None:
        return None
    est, est_info = final
    share = agreed_share(map_agreement(est, est_info, *world_truth(world)))
    return None if share != share else share


def map_placement(final, world):
    """The final SLAM map's best placement (ascc_eval.map_quality.best_placement): the
    shift of its frame [m, m, rad] at which the most of its known cells agree with the
    truth, and that share (``map_ok`` there): a map with the right shape whose frame ended
    up off agrees well there only. None without a saved map."""
    from ascc_eval.map_quality import best_placement

    if final is None:
        return None
    pl = best_placement(*final, *world_truth(world))
    return {"offset": [round(v, 4) for v in pl["offset"]], "map_ok": pl["agreed_share"]}


# Worlds whose outer wall is a few long straight sides (thesis 2.5.2 measures the corridor's
# and the lab's; the annex is the held-out loop whose walls are not all at right angles);
# the office's outline is doors and recesses, its sides are not reported.
SIDES_WORLDS = ("corridor", "lab", "annex")


def side_errors(final, world):
    """The final SLAM map's (``final_map``) outer sides (ascc_eval.map_quality): map minus
    floor-plan length of each, in % of the plan's; None for a world not in SIDES_WORLDS or
    without a map."""
    from ascc_eval.map_quality import measure
    from ascc_sim.world import load_world

    if world not in SIDES_WORLDS or final is None:
        return None
    w = load_world(os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds", world + ".yaml"))
    grid, info = final
    start = w.robots[0].pose
    q = measure(grid, info, w.map.occupancy, w.map.info, w.truth_map.occupancy,
                (start.x, start.y))
    return [None if e is None else round(e, 3) for e in q.outer_side_errors_pct()]


def worst_side(sides):
    """Largest |side error| [%] of a run's sides_pct; None when none was measured."""
    measured = [abs(e) for e in sides or [] if e is not None]
    return max(measured) if measured else None


def seen_from_bag(run_dir, clearance_m=0.18):
    """Seen coverage of a run from its run.bag (truth map, true poses, first scan, laser
    mount), for runs whose monitor did not measure it; None without a bag."""
    import math

    import rosbag

    from ascc_common.pose2d import yaw_of
    from ascc_eval.report import LaserGeometry, SeenArea, reachable_area
    from frontier_detector.rosmsg import grid_from_msg

    path = os.path.join(run_dir, "run.bag")
    if not os.path.exists(path):
        return None
    truth = area = None
    mounts, poses = {}, []
    scan = None
    with rosbag.Bag(path) as bag:
        for _topic, m, _t in bag.read_messages(topics=["/scan"]):
            scan = m
            break
        for topic, m, _t in bag.read_messages(
                topics=["/ground_truth/map", "/ground_truth/asccbot/pose", "/tf_static"]):
            if topic == "/ground_truth/map":
                truth = grid_from_msg(m)[:2]
            elif topic == "/tf_static":
                mounts.update({tr.child_frame_id: tr.transform.translation.x
                               for tr in m.transforms})
            else:
                p = m.pose
                poses.append((p.position.x, p.position.y, yaw_of(p.orientation)))
    if truth is None or scan is None or not poses:
        return None
    laser = LaserGeometry(range_m=float(scan.range_max),
                          fov_rad=float(scan.angle_max - scan.angle_min),
                          offset_x_m=float(mounts.get(scan.header.frame_id, 0.0)))
    reach = reachable_area(truth[0], truth[1], poses[0][:2], clearance_m)
    area = SeenArea(truth[0], truth[1], reach, laser)
    for x, y, yaw in poses:
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw):
            area.add(x, y, yaw)
    return area.coverage()


def fmt(v, spec="%.1f"):
    return "-" if v is None else spec % v


def mean(values):
    values = [v for v in values if v is not None]
    return sum(values) / len(values) if values else None


def group(results):
    groups = {}
    for r in results:
        groups.setdefault((r["world"], r["strategy"]), []).append(r)
    return sorted(groups.items())


def summarise(results):
    """Plain table and a markdown table (for docs/results/frontier_detector.md) of every
    (world, strategy)."""
    print("\n%-9s %-8s %5s %7s %7s %8s %8s %8s %8s %5s %7s %8s %9s" % (
        "world", "strategy", "runs", "cov_min", "cov>=95", "path_m", "t90_s", "t95_s",
        "t99_s", "hits", "map_ok", "seen_min", "side_max"))
    md = ["| world | strategy | runs | coverage min / mean | runs >= 95 % | path (mean ± sd) "
          "| time to 90 / 95 / 99 % (mean) | runs reaching 99 % | collisions "
          "| map agreement min | seen min / runs >= 95 % seen "
          "| worst side error / runs with all sides within 1 % |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (world, strategy), rs in group(results):
        ok = [r for r in rs if "error" not in r]
        cov = [r["coverage"] for r in ok]
        paths = [r["path_m"] for r in ok]
        n95 = sum(c >= 0.95 for c in cov)
        n99 = sum(r["time_to"]["0.99"] is not None for r in ok)
        t = [mean([r["time_to"][lv] for r in ok]) for lv in LEVELS]
        hits = sum(r["bumps"] or 0 for r in ok)
        maps = [r.get("map_ok") for r in ok if r.get("map_ok") is not None]
        map_min = fmt(100 * min(maps), "%.1f %%") if maps else "-"
        seen = [r.get("seen") for r in ok if r.get("seen") is not None]
        seen_min = fmt(100 * min(seen), "%.1f %%") if seen else "-"
        n95_seen = "%d/%d" % (sum(v >= 0.95 for v in seen), len(rs))
        worst = [worst_side(r.get("sides_pct")) for r in ok]
        worst = [w for w in worst if w is not None]
        side_max = fmt(max(worst), "%.2f %%") if worst else "-"
        n_sides = "%d/%d" % (sum(w <= 1.0 for w in worst), len(rs)) if worst else "-"
        print("%-9s %-8s %5d %7s %7s %8s %8s %8s %8s %5s %7s %8s %9s" % (
            world, strategy, len(rs), fmt(100 * min(cov) if cov else None, "%.1f%%"),
            "%d/%d" % (n95, len(rs)), fmt(mean(paths)), *(fmt(v) for v in t), hits,
            map_min.replace(" ", ""), seen_min.replace(" ", ""), side_max.replace(" ", "")))
        sd = (sum((p - mean(paths)) ** 2 for p in paths) / (len(paths) - 1)) ** 0.5 \
            if len(paths) > 1 else 0.0
        md.append("| %s | %s | %d | %s / %s | %d/%d | %s ± %.1f m | %s / %s / %s s | %d/%d | %d "
                  "| %s | %s / %s | %s / %s |"
                  % (world, strategy, len(rs),
                     fmt(100 * min(cov) if cov else None, "%.1f %%"),
                     fmt(100 * mean(cov) if cov else None, "%.1f %%"), n95, len(rs),
                     fmt(mean(paths)), sd, *(fmt(v, "%.0f") for v in t), n99, len(ok), hits,
                     map_min, seen_min, n95_seen if seen else "-", side_max, n_sides))
    print("\n" + "\n".join(md))


def plot(results, out):
    """OUT/coverage_<world>.png: coverage vs simulated time, every run, colour = strategy."""
    from ascc_eval.report import write_coverage_plot

    colours = {"utility": "tab:blue", "nearest": "tab:orange"}
    for world in sorted({r["world"] for r in results}):
        runs, styles = {}, {}
        for r in sorted(results, key=lambda r: (r["strategy"], r["seed"])):
            path = os.path.join(out, "%s_%s_seed%d" % (world, r["strategy"], r["seed"]),
                                "summary.json")
            if r["world"] != world or not os.path.exists(path):
                continue
            with open(path) as f:
                s = json.load(f)
            label = "%s seed %d" % (r["strategy"], r["seed"])
            t, c = s.get("times_s", []), s.get("coverage", [])
            n = min(len(t), len(c))  # summaries before the report.py fix could differ by one
            runs[label] = (t[:n], c[:n])
            first = not any(k.startswith(r["strategy"]) for k in styles)
            styles[label] = {"color": colours.get(r["strategy"]), "lw": 1.2, "alpha": 0.8,
                             "label": r["strategy"] if first else None}
        if runs:
            write_coverage_plot(os.path.join(out, "coverage_%s.png" % world), runs,
                                title="%s: coverage vs simulated time, %d runs"
                                % (world, len(runs)), styles=styles)
            print("wrote", os.path.join(out, "coverage_%s.png" % world))


def backfill(results, out):
    """The figures that runs from before the map check, the sides, the placement or the
    seen coverage lack, from their saved map and bag."""
    for r in results:
        if "error" in r:
            continue
        run_dir = os.path.join(out, "%s_%s_seed%d" % (r["world"], r["strategy"], r["seed"]))
        if not all(k in r for k in ("map_ok", "sides_pct", "placement")):
            final = final_map(run_dir)
            if "map_ok" not in r:
                r["map_ok"] = map_check(final, r["world"])
            if "sides_pct" not in r:
                r["sides_pct"] = side_errors(final, r["world"])
            if "placement" not in r:
                r["placement"] = map_placement(final, r["world"])
        if r.get("seen") is None:
            print("seen coverage of %s from its bag ..." % run_dir, flush=True)
            r["seen"] = seen_from_bag(run_dir)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", nargs="+", default=["office", "lab", "corridor"])
    ap.add_argument("--strategies", nargs="+", default=["utility", "nearest"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    ap.add_argument("--rtf", default=None, help="real_time_factor cap (0 = unlimited); "
                    "default per world: %s" % DEFAULT_RTF)
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "bench_exploration"))
    ap.add_argument("--timeout-s", type=int, default=3600, help="wall-clock limit per run")
    ap.add_argument("--max-time-s", type=float, default=4000.0,
                    help="simulated time after which a run gives up (the monitor ends it)")
    ap.add_argument("--port", type=int, default=0,
                    help="ROS master port of the runs (0: a free one)")
    ap.add_argument("--calibrate", action="store_true",
                    help="calibrate each seed's wheels first (ascc_sim calibrate.launch at "
                         "real-time factor %g whatever --rtf says, so a seed's factor does "
                         "not depend on the exploration's speed; kept in "
                         "OUT/calibration_seed<n>.yaml) and explore with the driver "
                         "corrected, as a lab runs a calibrated robot; default: uncalibrated"
                         % CALIBRATION_RTF)
    ap.add_argument("--frontend", default="", choices=["", "rbpf", "submap"],
                    help="the mapper stand-in's front end (its launch argument "
                         "slam_frontend); default: its config's (rbpf)")
    ap.add_argument("--report-only", action="store_true",
                    help="no runs: print the table of OUT/results.json and redraw the plots")
    args = ap.parse_args(argv)
    args.port = args.port or free_port()
    os.makedirs(args.out, exist_ok=True)
    table = os.path.join(args.out, "results.json")
    results = []
    if os.path.exists(table):
        with open(table) as f:
            results = json.load(f)
    if args.report_only:
        backfill(results, args.out)
        with open(table, "w") as f:
            json.dump(results, f, indent=1)
        summarise(results)
        plot(results, args.out)
        return 0
    n = len(args.worlds) * len(args.strategies) * len(args.seeds)
    i = 0
    for world in args.worlds:
        for seed in args.seeds:
            for strategy in args.strategies:
                i += 1
                print("[%d/%d] %s %s seed %d ..." % (i, n, world, strategy, seed), flush=True)
                rtf = args.rtf or DEFAULT_RTF.get(world, "4")
                r = run_one(world, strategy, seed, rtf, args.out, args.port,
                            args.timeout_s, args.max_time_s, args.calibrate, args.frontend)
                r["rtf"] = float(rtf)
                results = [o for o in results if (o["world"], o["strategy"], o["seed"])
                           != (world, strategy, seed)] + [r]
                print("  coverage %s  seen %s  path %s m  t90/95/99 %s/%s/%s s  hits %s  "
                      "(%s s wall)"
                      % (fmt(100 * r["coverage"] if r.get("coverage") is not None else None,
                             "%.1f%%"),
                         fmt(100 * r["seen"] if r.get("seen") is not None else None,
                             "%.1f%%"), fmt(r.get("path_m")),
                         *(fmt(r.get("time_to", {}).get(lv)) for lv in LEVELS),
                         r.get("bumps", "-"), fmt(r.get("wall_s"), "%.0f")), flush=True)
                if r.get("map_ok") is not None and r.get("placement"):
                    pl = r["placement"]
                    print("  map agreement %.1f %%; %.1f %% with the map moved by "
                          "(%+.2f, %+.2f) m, %+.2f deg (best placement)"
                          % (100 * r["map_ok"], 100 * pl["map_ok"], pl["offset"][0],
                             pl["offset"][1], pl["offset"][2] * 57.29577951308232),
                          flush=True)
                with open(table, "w") as f:
                    json.dump(results, f, indent=1)
    summarise(results)
    plot(results, args.out)
    return 0 if all("error" not in r for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
