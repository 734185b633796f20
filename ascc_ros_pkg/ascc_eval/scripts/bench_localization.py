#!/usr/bin/env python3
"""Benchmark of the MCL localizer on synthetic office drives (no ROS master needed).

For each run: the robot tours the office loop (``synthetic.office_world``, 14 m x 10 m) with
drifting odometry and a ray-cast URG-04LX scan at 10 Hz; the filter starts from amcl's default
initial covariance around the true start. Printed per run and overall:
  * mean / max position error [m] of every published estimate (amcl_pose),
  * 2-sigma containment: share of estimates whose 2-D position covariance ellipse at
    Mahalanobis distance 2 contains the true position (a calibrated Gaussian gives 86.5 %),
  * yaw error [rad], particle count, and the time of one filter update [ms].

    python3 scripts/bench_localization.py [--runs 5] [--seed 1]
"""
import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the node runs

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
NAV = os.path.join(HERE, "..", "..", "ascc_navigation")   # the package measured
sys.path.insert(0, os.path.join(NAV, "src"))

from ascc_common.grid import OCCUPIED  # noqa: E402
from ascc_common.params import from_params  # noqa: E402
from ascc_common.pose2d import wrap_angle  # noqa: E402
from ascc_navigation import mcl  # noqa: E402
from ascc_navigation import synthetic as syn  # noqa: E402
from ascc_navigation.laser import LaserMount  # noqa: E402


def run_once(seed: int, params: mcl.MclParams, odom_noise: float):
    rng = np.random.default_rng(seed)
    grid, info = syn.office_world()
    occupied = grid == OCCUPIED
    truth = syn.waypoint_trajectory(syn.office_loop_waypoints(), v=0.3, dt=0.1)
    odom = syn.noisy_odometry(truth, rng, trans_noise=odom_noise, rot_noise=odom_noise)
    spec = syn.LaserSpec()
    mount = LaserMount(0.1, 0.0, 0.0)  # laser 10 cm ahead of base_link
    field = mcl.LikelihoodField(grid, info, params.laser_sigma_hit, params.laser_z_hit,
                                params.laser_z_rand, params.laser_likelihood_max_dist,
                                spec.range_max)
    loc = mcl.MonteCarloLocalizer(field, params, np.random.default_rng(seed + 1000))
    loc.initialize_gaussian(truth[0], np.diag([0.25, 0.25, (np.pi / 12) ** 2]))  # amcl's
    errors, inside, yaw_err, counts, times, sigma = [], [], [], [], [], []
    for k in range(len(truth)):
        ranges = syn.simulate_scan(occupied, info, truth[k], mount, spec, rng)
        pts = mcl.scan_endpoints(ranges, spec.angle_min, spec.angle_increment, mount,
                                 spec.range_min, spec.range_max, params.laser_max_beams)
        t0 = time.perf_counter()
        updated = loc.process(odom[k], pts)
        if not updated:
            continue
        times.append(time.perf_counter() - t0)
        mean, cov = loc.estimate()
        d = truth[k, :2] - mean[:2]
        errors.append(float(np.hypot(*d)))
        inside.append(float(d @ np.linalg.solve(cov[:2, :2], d)) <= 4.0)
        yaw_err.append(abs(float(wrap_angle(truth[k, 2] - mean[2]))))
        counts.append(len(loc.poses))
        sigma.append(float(np.sqrt(0.5 * (cov[0, 0] + cov[1, 1]))))
    return (np.array(errors), np.array(inside), np.array(yaw_err), np.array(counts),
            np.array(times), np.array(sigma), 0.1 * (len(truth) - 1))


def time_updates(params: mcl.MclParams, repeats: int = 30) -> None:
    """Time [ms] of one full filter update (motion, scan, resample) per particle count."""
    grid, info = syn.office_world()
    spec = syn.LaserSpec()
    mount = LaserMount(0.1, 0.0, 0.0)
    rng = np.random.default_rng(0)
    ranges = syn.simulate_scan(grid == OCCUPIED, info, (2.0, 2.0, 0.0), mount, spec, rng)
    pts = mcl.scan_endpoints(ranges, spec.angle_min, spec.angle_increment, mount,
                             spec.range_min, spec.range_max, params.laser_max_beams)
    field = mcl.LikelihoodField(grid, info, params.laser_sigma_hit, params.laser_z_hit,
                                params.laser_z_rand, params.laser_likelihood_max_dist,
                                spec.range_max)
    print("particles  update_ms (motion + %d beams + resample, median of %d)"
          % (len(pts), repeats))
    for n in (500, 1000, 2000, 5000):
        p = mcl.MclParams(**{**params.__dict__, "min_particles": n, "max_particles": n})
        loc = mcl.MonteCarloLocalizer(field, p, np.random.default_rng(1))
        loc.initialize_gaussian((2.0, 2.0, 0.0), np.diag([0.01, 0.01, 0.01]))
        times = []
        for k in range(repeats):
            t0 = time.perf_counter()
            loc.predict((0.1 * k, 0.0, 0.0), (0.1 * k + 0.1, 0.0, 0.0))
            loc.update_sensor(pts)
            loc.resample()
            times.append(time.perf_counter() - t0)
        print("%9d  %9.1f" % (n, 1e3 * np.median(times)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--config", default=os.path.join(NAV, "config", "amcl.yaml"),
                    help="amcl parameter file (default: the package's config/amcl.yaml)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--odom-noise", type=float, default=0.03,
                    help="odometry noise std per metre / per radian (synthetic.noisy_odometry)")
    ap.add_argument("--beam-exponent", type=float, default=None)
    ap.add_argument("--max-beams", type=int, default=None)
    ap.add_argument("--timing", action="store_true",
                    help="also time one update at 500 .. 5000 particles")
    ap.add_argument("--skip-first", type=int, default=3,
                    help="estimates left out of the statistics while the filter converges")
    args = ap.parse_args()
    with open(args.config) as f:
        params = from_params(mcl.MclParams, yaml.safe_load(f).get)
    if args.beam_exponent is not None:
        params.laser_beam_exponent = args.beam_exponent
    if args.max_beams is not None:
        params.laser_max_beams = args.max_beams
    all_err, all_in, all_yaw, all_times = [], [], [], []
    print("run  updates  mean_err_m  max_err_m  sigma_m  in_2sigma  yaw_err_rad  particles"
          "  update_ms(mean/max)  drive_s")
    for r in range(args.runs):
        err, ins, yaw, cnt, tms, sig, dur = run_once(args.seed + r, params, args.odom_noise)
        s = args.skip_first
        all_err.append(err[s:])
        all_in.append(ins[s:])
        all_yaw.append(yaw[s:])
        all_times.append(tms)
        print("%3d  %7d  %10.3f  %9.3f  %7.3f  %8.1f%%  %11.3f  %9.0f  %8.1f / %6.1f  %7.0f" % (
            r, len(err), err[s:].mean(), err.max(), sig[s:].mean(), 100 * ins[s:].mean(),
            yaw[s:].mean(), cnt.mean(), 1e3 * tms.mean(), 1e3 * tms.max(), dur))
    if args.runs > 0:
        report(all_err, all_in, all_yaw, all_times)
    if args.timing:
        time_updates(params)
    return 0


def report(all_err, all_in, all_yaw, all_times) -> None:
    err, ins = np.concatenate(all_err), np.concatenate(all_in)
    tms = np.concatenate(all_times)
    print("overall: mean position error %.3f m, 2-sigma containment %.1f %%, mean yaw error "
          "%.3f rad, filter update %.1f ms mean (%.1f ms max)"
          % (err.mean(), 100 * ins.mean(), np.concatenate(all_yaw).mean(), 1e3 * tms.mean(),
             1e3 * tms.max()))


if __name__ == "__main__":
    sys.exit(main())
