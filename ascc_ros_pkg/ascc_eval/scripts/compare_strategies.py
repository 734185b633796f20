#!/usr/bin/env python3
"""Offline comparison of the `utility` and `nearest` strategies (ascc_eval.offline).

Explores the simulator's building maps (ascc_sim/worlds/maps: office, lab, corridor loop;
walls only, furniture objects are not in those maps) from several start poses per world
(seed 0: the world file's robot pose, others: random reachable free cells), with the
idealised robot/laser model of offline.py, and prints per world and strategy the mean path
length, the mean time to 90/95/99 % coverage of the reachable area, final coverage, goals
and bad goals. With --out DIR it also writes map+path+goals PNGs and coverage-vs-time plots.

    rosrun ascc_eval compare_strategies.py [--worlds office lab corridor]
        [--seeds 5] [--out DIR]
"""

import argparse
import copy
import os
import sys

import numpy as np
import yaml

from ascc_common.map_io import load_map
from ascc_eval import offline
from ascc_eval.report import (
    reachable_area,
    time_to_coverage,
    write_coverage_plot,
    write_map_png,
)
from frontier_detector.frontiers import traversable_mask
from frontier_detector.goal_selection import PlannerParams

LEVELS = (0.90, 0.95, 0.99)


def worlds_dir() -> str:
    here = os.path.dirname(os.path.realpath(__file__))
    path = os.path.join(here, "..", "..", "ascc_sim", "worlds")
    if os.path.isdir(path):
        return os.path.abspath(path)
    import rospkg

    return os.path.join(rospkg.RosPack().get_path("ascc_sim"), "worlds")


def starts(name: str, truth, info, seeds: int, clearance: float):
    with open(os.path.join(worlds_dir(), name + ".yaml"), encoding="utf-8") as f:
        world = yaml.safe_load(f)
    first = tuple(world["robots"][0]["pose"][:2])
    out = [first]
    reach = reachable_area(truth, info, first, clearance)
    ok = reach & (traversable_mask(truth, clearance / info.resolution) > 0)
    rows, cols = np.nonzero(ok)
    for seed in range(1, seeds):
        k = np.random.default_rng(seed).integers(rows.size)
        out.append(info.cell_to_world(int(cols[k]), int(rows[k])))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worlds", nargs="+", default=["office", "lab", "corridor"])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--strategies", nargs="+", default=["utility", "nearest"])
    ap.add_argument("--out", default="", help="directory for PNGs (optional)")
    ap.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE",
                    help="override UtilityParams / FrontierParams fields, e.g. w_nav=2")
    args = ap.parse_args()
    planner = PlannerParams()
    for item in args.set:
        key, value = item.split("=", 1)
        for part in (planner.utility, planner.frontier, planner.scenario):
            if hasattr(part, key):
                setattr(part, key, type(getattr(part, key))(value))
                break
        else:
            ap.error(f"unknown parameter {key}")
    if args.out:
        os.makedirs(args.out, exist_ok=True)
    print("world     strategy  runs  path_m  p90_m  p95_m  p99_m  t90_s  t95_s  t99_s  final%"
          "  goals  bad")
    for name in args.worlds:
        truth, info = load_map(os.path.join(worlds_dir(), "maps", name + ".yaml"))
        poses = starts(name, truth, info, args.seeds, 0.18)
        curves = {}
        for strategy in args.strategies:
            runs = [offline.run(truth, info, p, strategy, planner=copy.deepcopy(planner))
                    for p in poses]
            t = {lv: [time_to_coverage(r.times_s, r.coverage, LEVELS)[lv] for r in runs]
                 for lv in LEVELS}
            # Path length when each level is reached (same first-crossing rule as time).
            pth = {lv: [time_to_coverage(r.path_at, r.coverage, LEVELS)[lv] for r in runs]
                   for lv in LEVELS}

            def mean(v):
                v = [x for x in v if x is not None]
                return f"{np.mean(v):6.0f}" if v else "   n/a"

            never = {lv: sum(x is None for x in t[lv]) for lv in LEVELS}
            print(f"{name:9s} {strategy:8s} {len(runs):5d} "
                  f"{np.mean([r.path_m for r in runs]):7.1f} "
                  + " ".join(mean(pth[lv]) for lv in LEVELS) + " "
                  + " ".join(mean(t[lv]) for lv in LEVELS)
                  + f" {100 * np.mean([r.coverage[-1] for r in runs]):7.1f}"
                  f" {np.mean([r.goals for r in runs]):6.1f} {sum(r.bad_goals for r in runs):4d}"
                  + ("" if not any(never.values()) else
                     f"   (never reached: {never[0.90]}/{never[0.95]}/{never[0.99]})"))
            for i, r in enumerate(runs):
                curves[f"{strategy} seed {i}"] = (r.times_s, r.coverage)
                if args.out:
                    write_map_png(os.path.join(args.out, f"{name}_{strategy}_seed{i}.png"),
                                  r.known, info, r.trajectory, r.goals_xy,
                                  robot_xy=r.trajectory[-1],
                                  title=f"{name} {strategy} seed {i}: {r.path_m:.1f} m")
        if args.out:
            write_coverage_plot(os.path.join(args.out, f"{name}_coverage.png"), curves,
                                title=name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
