#!/usr/bin/env python3
"""Is the mapper's along-motion error a bias or a random walk? (issue 24; no ROS master)

Drives ``bench_mapper.py``'s route through a simulator world (same seeds, laser and odometry
models) and measures the scan matcher's correction along the robot's true heading in every
translating filter update, in two settings:

  * ``true-map``: one particle whose map is built from the scans at the TRUE poses; before
    each update the particle is put at the true pose, then matched (with the motion prior,
    as in the filter). Nonzero mean = a bias of the matcher and the map model themselves.
  * ``exact-odom``: the filter run on its own map, one particle, exact odometry and no
    motion noise; the correction is matched minus predicted pose. Its mean is what would
    add up to a drift, its std the random walk.
  * ``selection``: the whole filter (its particles and motion noise) with exact
    odometry; per update the particles' position along the heading weighted by that
    update's likelihood minus their plain mean: the pull of the choice among the
    particles, which one particle does not have.

Prints per setting the mean, its standard error and the std [mm], and the share of beams
the matcher used. ``--set`` overrides parameters as in ``bench_mapper.py`` (e.g.
``--set seen_margin_m=0.2``).

``--bag RUN.bag`` takes the scans, the odometry and the true poses of a recorded run
instead (``bench_exploration.py``'s run bags, read by ``replay_mapper.RunBag``): the
exploration's own route, driver and timing. Its updates are those of the shipped mapper
fed with the bag's odometry; the true poses are the simulator's at each scan's stamp.

    python3 scripts/mapper_along_bias.py [--world corridor] [--seed 1] [--set NAME=VALUE]
    python3 scripts/mapper_along_bias.py --bag RUN.bag [--set NAME=VALUE]
"""
import argparse
import math
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "ascc_navigation", "src"))

import bench_mapper as B  # noqa: E402

from ascc_common.params import from_params  # noqa: E402
from ascc_common.pose2d import compose, relative  # noqa: E402
from ascc_navigation import mapper as M  # noqa: E402
from ascc_navigation import synthetic as S  # noqa: E402
from ascc_navigation.rbpf import RbpfSlam, normalized_weights  # noqa: E402

MIN_STEP_M = 0.2  # translating updates only


def record(world, params, seed):
    """Scans (prepared) and true poses of the filter updates of the benchmark's run."""
    rng = np.random.default_rng(seed)
    traj = S.waypoint_trajectory(world.route, v=0.3, w=0.8, dt=B.SCAN_PERIOD_S)
    odom = B.odometry("sim", traj, rng)
    mapper = M.SlamMapper(from_params(M.MapperConfig, params.get), seed=seed)
    spec = world.spec
    scans, truth = [], []
    for k in range(0, traj.shape[0], B.FEED_EVERY):
        scan = M.ScanInput(k * B.SCAN_PERIOD_S, world.scan(traj[k]), spec.angle_min,
                           spec.angle_increment, spec.range_min, spec.range_max)
        if mapper.handle_scan(scan, odom[k], world.mount).map_changed:
            scans.append(mapper._prepare(scan, world.mount))
            truth.append(traj[k].copy())
    return scans, np.array(truth)


def record_bag(path, params):
    """Scans (prepared) and true poses [world frame] of the filter updates of a recorded
    run, the mapper fed with the bag's odometry as ``replay_mapper.py`` feeds it."""
    from replay_mapper import RunBag
    run = RunBag(path)
    if run.truth is None:
        raise SystemExit("%s: no /ground_truth/<robot>/pose" % path)
    mapper = M.SlamMapper(from_params(M.MapperConfig, params.get), seed=0)
    scans, truth = [], []
    for stamp, scan, odom in run.mapper_inputs():
        if mapper.handle_scan(scan, odom, run.mount).map_changed:
            scans.append(mapper._prepare(scan, run.mount))
            truth.append(run.truth_at(stamp))
    return scans, np.array(truth)


def along(pose_a, pose_b, heading):
    """Component [m] of pose_b - pose_a along ``heading``."""
    return (math.cos(heading) * (pose_b[0] - pose_a[0])
            + math.sin(heading) * (pose_b[1] - pose_a[1]))


def true_map(cfg, scans, truth):
    """Matcher correction along (matched - true) on the map at the true poses."""
    slam = RbpfSlam(cfg, seed=0)
    slam.start(truth[0], scans[0])
    out, used = [], []
    for k in range(1, len(scans)):
        t = truth[k]
        step = relative(truth[k - 1], t)
        maps = slam.maps
        hits, visits, info = maps.hits.copy(), maps.visits.copy(), maps.info
        if math.hypot(step[0], step[1]) > MIN_STEP_M:
            slam.poses[:] = truth[k - 1]  # the update from the true previous pose
            stats = slam.update(step, scans[k])
            out.append(along(t, slam.poses[0], t[2]))
            used.append(stats.beams / max(scans[k].match.shape[0], 1))
        # the map gets the scan at the true pose, whatever the matcher did
        maps.hits, maps.visits, maps.info = hits, visits, info
        slam.poses[:] = t
        slam._register(scans[k])
        slam._previous = scans[k]
    return np.array(out), float(np.mean(used))


def exact_odometry(cfg, scans, truth):
    """Matcher correction along (matched - predicted), filter on its own map."""
    slam = RbpfSlam(cfg, seed=0)
    slam.start(truth[0], scans[0])
    out, used = [], []
    for k in range(1, len(scans)):
        step = relative(truth[k - 1], truth[k])
        predicted = compose(slam.poses[0], step)
        stats = slam.update(step, scans[k])
        if math.hypot(step[0], step[1]) > MIN_STEP_M:
            out.append(along(predicted, slam.poses[0], truth[k, 2]))
            used.append(stats.beams / max(scans[k].match.shape[0], 1))
    return np.array(out), float(np.mean(used))


def selection(cfg, scans, truth):
    """The weighting's pull along the travel: in each translating update of the whole
    filter (exact odometry; the particles and motion noise as configured), the particles'
    mean position along the true heading weighted by that update's likelihood alone,
    minus their plain mean. What the choice among the particles adds per update."""
    slam = RbpfSlam(cfg, seed=0)
    slam.start(truth[0], scans[0])
    out, used = [], []
    for k in range(1, len(scans)):
        step = relative(truth[k - 1], truth[k])
        stats = slam.update(step, scans[k])
        if stats.log_gain is not None and math.hypot(step[0], step[1]) > MIN_STEP_M:
            w = normalized_weights(stats.log_gain)
            poses = stats.weighed_poses
            h = truth[k, 2]
            a = math.cos(h) * poses[:, 0] + math.sin(h) * poses[:, 1]
            out.append(float(w @ a - a.mean()))
            used.append(stats.beams / max(scans[k].match.shape[0], 1))
    return np.array(out), float(np.mean(used))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", default="corridor", choices=sorted(B.ROUTES))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bag", default="", help="a recorded run instead of the world's route")
    B.add_parameter_arguments(ap)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    params = B.parameters_from_arguments(ap, args)
    if args.bag:
        scans, truth = record_bag(args.bag, params)
        source = args.bag
    else:
        world = B.SimWorld(args.world, np.random.default_rng(1000 + args.seed))
        scans, truth = record(world, params, args.seed)
        source = "%s seed %d" % (args.world, args.seed)
    print("%s, %d updates; matcher correction along the true heading [mm]"
          % (source, len(scans)))
    one = dict(params, particles=1, srr=0.0, srt=0.0, str=0.0, stt=0.0)
    for name, fn, p in (("true-map", true_map, one), ("exact-odom", exact_odometry, one),
                        ("selection", selection, params)):
        cfg = from_params(M.MapperConfig, p.get).rbpf
        c, used = fn(cfg, scans, truth)
        c = 1e3 * c
        print("%-10s mean %+.2f (se %.2f) std %.2f  quartiles %+.1f %+.1f  |c|>10: %.1f %%  "
              "beams used %.1f %%" % (name, c.mean(), c.std() / math.sqrt(c.size), c.std(),
                                      np.percentile(c, 25), np.percentile(c, 75),
                                      100.0 * np.mean(np.abs(c) > 10.0), 100.0 * used))


if __name__ == "__main__":
    main()
