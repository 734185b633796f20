#!/usr/bin/env python3
"""How well amcl (the ascc_navigation stand-in) localises the benchmark's robots, which
stand still: offline, no ROS (colloc_fusion.still_localization).

    python ascc_ros_pkg/colloc_fusion/scripts/bench_still_localization.py [--seed 1]
        [--trials 20] [--nomotion-updates 10 50]

Placements as bench_colloc.py's (trial 0: the world's, then ``--trials`` random ones from
``--seed``); for each number of no-motion updates, the pose error of the cloud's mean
(what amcl publishes) and of the scan-matched refinement (``refine_estimate``), over all
robots: mean, median and max of the position error [m], mean and max |yaw error| [deg],
and how many robots ended more than 0.3 m off (a wrong convergence the refinement, which
is local, cannot repair).

``--slam-map SEED``: amcl uses a map built by the SLAM stand-in (colloc_fusion.slam_map:
one drive through the office, mapper seed SEED, the map frame where that drive started)
instead of the simulator's grid. The four desk corners are measured in it (landmarks.py;
rough guesses: the corners moved by the exact transform), the truth -> map transform is
fitted to them (its residual printed) and used to place the robots' initial poses and to
compare with the truth (thesis 3.4.1); the fit's own error is printed against the exact
transform (known here: where the drive started), and the map is written to
``--map-out`` + .yaml/.pgm (map_server format).
"""
import argparse
import os
import sys
import tempfile

import numpy as np
import yaml

from ascc_common import map_io
from ascc_common.params import from_params
from ascc_navigation import mcl
from ascc_sim.world import load_world
from colloc_fusion import slam_map
from colloc_fusion.bench import Placement, random_placement, write_placement_world
from colloc_fusion.still_localization import still_robot_errors

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
WORLD = os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds", "three_robots.yaml")
AMCL_YAML = os.path.join(ROOT, "ascc_ros_pkg", "ascc_navigation", "config", "amcl.yaml")
GMAPPING_YAML = os.path.join(ROOT, "ascc_ros_pkg", "ascc_navigation", "config", "gmapping.yaml")
BOUNDS = (0.3, 0.3, 8.2, 6.7)  # as bench_colloc.py
WRONG_M = 0.3


def slam_calibration(world, seed, map_out):
    """The SLAM map and the truth -> map transform fitted to the desk corners in it."""
    with open(GMAPPING_YAML) as f:
        grid, info, fit, exact, failed = slam_map.calibrated_map(world, yaml.safe_load(f),
                                                                 seed=seed)
    map_io.save_map(map_out + ".yaml", grid, info, comment="SLAM stand-in, seed %d" % seed)
    print(slam_map.describe(seed, fit, exact, failed, world, map_out + ".yaml"))
    return (grid, info), fit, exact


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--nomotion-updates", type=int, nargs="+", default=[10, 50])
    ap.add_argument("--selective-resampling", action="store_true",
                    help="amcl's selective_resampling (resample only when ESS < N/2)")
    ap.add_argument("--slam-map", type=int, metavar="SEED", default=None,
                    help="amcl on a map built by the SLAM stand-in with this seed")
    ap.add_argument("--map-out", default="/tmp/still_loc_slam_map",
                    help="--slam-map: the map is saved as this .pgm/.yaml")
    args = ap.parse_args()
    with open(AMCL_YAML) as f:
        cfg = yaml.safe_load(f)
    if args.selective_resampling:
        cfg["selective_resampling"] = True
    params = from_params(mcl.MclParams, cfg.get)
    world = load_world(WORLD)
    rng = np.random.default_rng(args.seed)
    cone = next(o for o in world.objects if o.type == "cone")
    placements = [Placement((cone.pose.x, cone.pose.y),
                            {r.name: (r.pose.x, r.pose.y, r.pose.yaw) for r in world.robots})]
    placements += [random_placement(world.grid, rng, BOUNDS) for _ in range(args.trials)]
    tmp = tempfile.mkdtemp(prefix="still_loc_")
    worlds = [load_world(write_placement_world(os.path.join(tmp, "w%02d.yaml" % k), p, WORLD))
              for k, p in enumerate(placements)]
    amcl_map, to_map, exact = None, None, None
    if args.slam_map is not None:
        amcl_map, to_map, exact = slam_calibration(world, args.slam_map, args.map_out)
    print("| no-motion updates | pose | position error mean / median / max [m] | "
          "|yaw error| mean / max [deg] | > %.1f m off |" % WRONG_M)
    print("|---|---|---|---|---|")
    judges = [("", None)] if exact is None else [(", vs calibrated truth", None),
                                                  (", vs exact transform", exact)]
    for n in args.nomotion_updates:
        for label, judge in judges:
            errs = {"mcl": [], "refined": []}
            for k, (w, p) in enumerate(zip(worlds, placements)):
                for e in still_robot_errors(w, p, params, n, seed=k, amcl_map=amcl_map,
                                            to_map=to_map, judge_map=judge).values():
                    for key in errs:
                        errs[key].append(e[key])
            for key, v in errs.items():
                v = np.array(v)
                d, a = np.hypot(v[:, 0], v[:, 1]), np.degrees(np.abs(v[:, 2]))
                print("| %d | %s%s | %.4f / %.4f / %.3f | %.2f / %.2f | %d of %d |"
                      % (n, "cloud mean (amcl)" if key == "mcl" else "refined", label,
                         d.mean(), np.median(d), d.max(), a.mean(), a.max(),
                         int(np.sum(d > WRONG_M)), len(d)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
