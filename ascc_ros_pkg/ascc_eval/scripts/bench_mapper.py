#!/usr/bin/env python3
"""Benchmark of the gmapping-compatible mapper (no ROS master needed).

For each world the robot drives a fixed route (turn in place, then straight at 0.3 m/s) with
drifting wheel odometry; scans are fed to ``SlamMapper`` (the node's core) with the shipped
parameters ``config/gmapping.yaml`` (30 particles). Printed per world:
  * ms per filter update: CPU time of this process (mean / 95th percentile; the benchmark
    is single-threaded, so this is the cost on one core even when other processes share the
    machine) and the wall-clock mean;
  * map accuracy: share of the cells the map marks known (0 or 100) that agree with the
    ground truth (also split into free / occupied cells), over the cells that fall on the
    truth's known area; "map_ok": the same share with the cells off it counted as
    disagreeing (``map_quality.agreed_share``, ``bench_exploration.py``'s ``map_ok``: issue
    24's measure; lower than "accuracy" where walls or free space land outside the plan);
  * pose error [m] of map->odom->base_link against the truth: at the end of the route
    (the routes are loops, so this is the loop-closure error), the maximum along the route,
    and the odometry's own end error for comparison;
  * "ideal": the accuracy of a map built from the same scans at the true poses of the
    filter updates (what the map building and the measure allow with perfect
    localisation: the rest of the gap is the pose error's); "ideal_sides_%" that map's
    sides (below), i.e. what the grid's cell model alone does to them;
  * "along" / "across": the largest pose error along / across the robot's true heading
    (on the corridor: along / across the corridor); "heading_mrad": the median and 95th
    percentile of the heading error at the filter updates [mrad];
  * "inc_mm": the error of the map's own trajectory (the best particle's poses at the
    updates, which its map was built from) in each translating update's forward motion,
    mean / std [mm], and the odometry's ("odom_inc_mm"): a systematic along-motion bias
    shows as a mean, a random walk as the std (its mean's standard error is std /
    sqrt(updates));
  * simulator worlds: ``ascc_eval.map_quality`` on the final map: the sides of the outer
    outline, map minus floor plan in % ("sides_%"), and the largest corner angle error
    ("corner"); ``--save DIR`` also writes each map (map_server files) and its overlay PNG;
  * "odom_scale": the true path length over the odometry's: the factor the run's odometry
    would need (its wheels' scale error; 1 with ``--odometry exact``).

``--oracle PART`` (an attribution experiment, not a mapper setting): before each filter update
registers its scan, every particle's pose is corrected in PART to the truth of that scan:
``position`` (x, y), ``heading``, ``along`` (the component along the true heading) or
``across`` (the component across it); the rest stays the filter's. The map is then built from
poses wrong only in the other parts: the agreement shows what the map loses to them. (All
particles then share that part, so the weights cannot tell them apart in it; the losses of
the parts do not add up to the shipped filter's.)

``--filters K`` (an attribution experiment): K filters per seed on the same odometry and
scans, with the filter seeds seed, seed + 1000, ... (the first is the usual run), and one
more line: the map rebuilt from the pose-by-pose average of their lineages. What the
average gains is the share of the error that the filters' own random draws make (it
differs from filter to filter); what it keeps is the share they all make from the data.

Worlds: ``synthetic`` (``ascc_navigation.synthetic.office_world``, 14 m x 10 m, own ray
caster, 1 cm range noise) and the simulator's ``office``, ``lab``, ``corridor`` (ascc_sim
world files, ground truth ``truth_map``, scans from ascc_sim's URG-04LX model: 1 %
range noise, dropouts at far range and grazing incidence, glass cabinet in the lab); not in
the default list: ``annex``, a 134 m corridor loop whose walls are not all at right angles
(a side at 45 degrees, one 3.6 degrees off), built to test the wall-axis prior's
assumption of right angles.

    python3 scripts/bench_mapper.py [--worlds synthetic,office,lab,corridor] [--seed 1]
        [--runs N] [--odometry create1] [--oracle along] [--filters K] [--set NAME=VALUE]
"""
import argparse
import math
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the node runs

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NAV = os.path.join(HERE, "..", "..", "ascc_navigation")   # the package measured
sys.path.insert(0, os.path.join(NAV, "src"))

from ascc_common.grid import OCCUPIED  # noqa: E402
from ascc_common.params import from_params, parameters  # noqa: E402
from ascc_common.pose2d import compose, mean_yaw, relative, wrap_angle  # noqa: E402
from ascc_eval.drive_bag import ROUTES  # noqa: E402
from ascc_eval.map_quality import agreed_share  # noqa: E402
from ascc_navigation import mapper as M  # noqa: E402
from ascc_navigation import synthetic as S  # noqa: E402
from ascc_navigation.grid import map_agreement  # noqa: E402
from ascc_navigation.laser import LaserMount  # noqa: E402
from ascc_navigation.posegraph import rebuild_counts  # noqa: E402
from ascc_navigation.rbpf import ParticleMaps  # noqa: E402

CONFIG = os.path.join(NAV, "config", "gmapping.yaml")
SIM_WORLDS = os.path.join(HERE, "..", "..", "ascc_sim", "worlds")
SCAN_PERIOD_S = 0.1
FEED_EVERY = 2  # feed every 2nd scan (5 Hz): the node also skips scans when busy
WALL_RUNS = 10     # --odometry wall: calibrate_odometry runs (its README advises 10) ...
WALL_RUN_M = 1.5   # ... of its default distance_m
MIN_CLEARANCE_M = 0.25  # routes keep this far from obstacles (robot radius 0.165 m)


def load_params(path):
    with open(path) as f:
        values = yaml.safe_load(f)
    known = {p.name for p in parameters(M.MapperConfig)}
    return {k: v for k, v in values.items() if k in known}


def add_parameter_arguments(ap):
    """--config and --set (shared with replay_mapper.py)."""
    ap.add_argument("--config", default=CONFIG)
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="override a parameter of the config (gmapping name), repeatable")


def parameters_from_arguments(ap, args):
    """The mapper parameters of --config with the --set overrides applied."""
    params = load_params(args.config)
    known = {p.name for p in parameters(M.MapperConfig)}
    for item in args.set:
        name, _, value = item.partition("=")
        if name not in known:
            ap.error("unknown parameter %r (known: %s)" % (name, " ".join(sorted(known))))
        params[name] = yaml.safe_load(value)
    return params


class SyntheticWorld:
    name = "synthetic"

    def __init__(self, rng):
        self.truth, self.info = S.office_world()
        self.occupied = self.truth == OCCUPIED
        self.route = S.office_loop_waypoints()
        self.spec = S.LaserSpec()
        self.mount = LaserMount(0.05, 0.0, 0.0)
        self.rng = rng

    def scan(self, pose):
        return S.simulate_scan(self.occupied, self.info, pose, self.mount, self.spec, self.rng)


class SimWorld:
    """A world of ascc_sim, scanned with its own laser model (imported from ascc_sim)."""

    def __init__(self, name, rng):
        from ascc_sim.laser import LaserConfig, LaserModel
        from ascc_sim.world import load_world

        self.name = name
        world = load_world(os.path.join(SIM_WORLDS, name + ".yaml"))
        g = world.truth_map
        self.truth = g.occupancy
        self.info = g.info
        self.clearance = g.clearance_m
        with open(os.path.join(SIM_WORLDS, "..", "config", "asccbot.yaml")) as f:
            robot = yaml.safe_load(f)
        self.mount = LaserMount(robot["laser_x_m"], robot["laser_y_m"],
                                math.radians(robot["laser_yaw_deg"]))
        cfg = LaserConfig()
        self.laser = LaserModel(world.grid, cfg, world.dropout)
        self.circles = world.circles
        self.spec = S.LaserSpec(fov=cfg.angle_max_rad - cfg.angle_min_rad,
                                increment=cfg.angle_increment_rad, range_min=cfg.range_min_m,
                                range_max=cfg.range_max_m)
        self.spec.n = cfg.n_beams
        self.spec.angle_min = cfg.angle_min_rad
        self.route = ROUTES[name]
        self.rng = rng

        self.plan, self.plan_info = world.map.occupancy, world.map.info

    def quality(self, grid, info, save=None):
        """map_quality's sides (outer outline, % of the plan) and worst corner [deg]; the
        map frame is the world frame (the odometry starts at the true start)."""
        from ascc_eval import map_quality as Q

        q = Q.measure(grid, info, self.plan, self.plan_info, self.truth, self.route[0])
        if save:
            Q.write_overlay(save + "_quality.png", q, grid, info, self.plan, self.plan_info,
                            (0.0, 0.0, 0.0))
        sides, corner = [], 0.0
        rows = [r for r in q.sides() if r["outline"] == 0]
        if len(rows) > 8:  # rooms and doors (the office): no sides to speak of
            return [], float("nan")
        for r in rows:
            if r["plan_m"] and r["map_m"] is not None:
                sides.append(100.0 * (r["map_m"] - r["plan_m"]) / r["plan_m"])
            if r["plan_deg"] is not None and r["map_deg"] is not None:
                corner = max(corner, abs(r["map_deg"] - r["plan_deg"]))
        return sides, corner

    def check_route(self, traj):
        ix, iy = self.info.world_to_cell(traj[:, 0], traj[:, 1])
        low = float(self.clearance[iy, ix].min())
        if low < MIN_CLEARANCE_M:
            raise SystemExit("route of %s passes %.2f m from an obstacle" % (self.name, low))

    def scan(self, pose):
        lx, ly, lth = compose(pose, (self.mount.x, self.mount.y, self.mount.yaw))
        return self.laser.scan(lx, ly, lth, self.circles, self.rng)


def odometry(kind, traj, rng):
    """Odometry along the true trajectory, starting at the true start (so the map frame is
    the world frame). ``sim``: ascc_sim's wheel-encoder model with its configured errors;
    ``harsh``: ``synthetic.noisy_odometry``'s defaults (1 % scale, 3 % noise, 0.01 rad/m
    heading bias), several times worse; ``wall``: ``sim`` (the same draws) corrected by the
    factor ``calibrate_odometry`` would measure on those wheels (``WALL_RUNS`` runs of
    ``WALL_RUN_M``), as the driver's ``odom_linear_scale_correction`` applies it;
    ``calibrated``: ``sim`` without the per-run scale error of the wheels (a perfect
    calibration; the same noise draws as ``sim``); ``exact``: the true poses (what the scan
    matcher and the filter's own motion noise leave); ``create1``: ``sim`` (the same draws)
    with the turn reported in whole degrees, the remainder carried, as the Create 1's angle
    packet reaches the driver from ascc_sim's virtual Create (the heading lags by up to 1
    deg)."""
    if kind == "exact":
        return traj[:, :3].copy()
    if kind == "harsh":
        return S.noisy_odometry(traj, rng)
    with open(os.path.join(SIM_WORLDS, "..", "config", "asccbot.yaml")) as f:
        robot = yaml.safe_load(f)
    base, noise = robot["wheel_base_m"], robot["encoder_noise_m_per_sqrt_m"]
    if kind == "calibrated":
        return S.wheel_odometry(traj, rng, base, 0.0, noise)
    scale = 1.0 + robot["encoder_scale_sigma"] * rng.standard_normal(2)  # sim's first draw
    unit = math.radians(1.0) if kind == "create1" else 0.0
    odom = S.wheel_odometry(traj, rng, base, noise_k=noise, scale=scale, angle_unit_rad=unit)
    if kind in ("sim", "create1"):
        return odom
    # "wall": the same wheels, corrected by irobot_create_2_1's calibrate_odometry (runs of
    # WALL_RUN_M towards a wall and back): the factor is the true distance over the
    # odometry's on those runs, as the laser measures it (in ascc_sim's calibration.test
    # within 0.003 % of the truth, so taken as exact here); the wheels' noise on the runs
    # is what it leaves.
    cal_rng = np.random.default_rng(int(rng.integers(2 ** 31)))
    leg = np.arange(0.0, WALL_RUN_M + 1e-9, 0.15 * SCAN_PERIOD_S)
    x = np.concatenate([leg if i % 2 == 0 else leg[::-1] for i in range(WALL_RUNS)])
    runs = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    cal = S.wheel_odometry(runs, cal_rng, base, noise_k=noise, scale=scale)
    factor = (np.sum(np.abs(np.diff(runs[:, 0])))
              / np.sum(np.hypot(np.diff(cal[:, 0]), np.diff(cal[:, 1]))))
    inc = relative(odom[:-1], odom[1:]) * [factor, factor, 1.0]
    out = [odom[0]]
    for d in inc:  # per time step: integrating the corrected increments as the driver does
        out.append(compose(out[-1], d))
    return np.array(out)


def average_lineages(lineages):
    """The pose-by-pose average of several filters' trajectories over the same updates
    ((K, T, 3) -> (T, 3)): mean position, circular mean heading."""
    t = np.asarray(lineages, dtype=float)
    out = t.mean(axis=0)
    out[:, 2] = [mean_yaw(t[:, i, 2]) for i in range(t.shape[1])]
    return out


def rebuilt_map(info, poses, scans, occ_thresh):
    """The one-particle map of ``scans`` registered at ``poses`` on the grid ``info``:
    (occupancy grid, its geometry)."""
    maps = rebuild_counts(lambda: ParticleMaps(1, info), np.asarray(poses), scans)
    return maps.occupancy(0, occ_thresh), maps.info


def average_map(world, results):
    """The map rebuilt from the average of ``results``' lineages (runs of ``run`` on the same
    odometry and scans with different filter seeds): its agreement and sides, or None if a
    filter was reset (its lineage does not cover every scan)."""
    if any(r["lineage"] is None for r in results):
        return None
    first = results[0]
    grid, info = rebuilt_map(first["info"], average_lineages([r["lineage"] for r in results]),
                             first["scans"], first["occ_thresh"])
    acc = map_agreement(grid, info, world.truth, world.info)
    sides = world.quality(grid, info)[0] if hasattr(world, "quality") else []
    return acc, sides


def increment_errors(truth, estimate, odom, min_step_m=0.1):
    """Mean and std [mm] of the error in forward motion of the translating increments
    (> ``min_step_m``) between consecutive updates: of ``estimate`` and of ``odom`` (poses
    (T, 3) at the same updates as ``truth``); NaN if the lengths differ (a reset)."""
    if truth.shape[0] != estimate.shape[0] or truth.shape[0] < 3:
        return (float("nan"),) * 2, (float("nan"),) * 2
    true_inc = relative(truth[:-1], truth[1:])
    moving = np.hypot(true_inc[:, 0], true_inc[:, 1]) > min_step_m
    out = []
    for poses in (estimate, odom):
        err = 1e3 * (relative(poses[:-1], poses[1:])[moving, 0] - true_inc[moving, 0])
        out.append((float(err.mean()), float(err.std())))
    return out[0], out[1]


ORACLES = ("position", "heading", "along", "across")


def apply_oracle(poses, truth, part):
    """Correct ``poses`` (n, 3) in place in ``part`` (one of ORACLES) to ``truth`` (x, y,
    theta): the position, the heading, or the position's component along / across the true
    heading. The other parts stay as they were."""
    if part == "heading":
        poses[:, 2] = truth[2]
        return poses
    ex, ey = poses[:, 0] - truth[0], poses[:, 1] - truth[1]
    c, s = math.cos(truth[2]), math.sin(truth[2])
    if part == "position":
        poses[:, 0], poses[:, 1] = truth[0], truth[1]
    elif part == "along":
        a = c * ex + s * ey
        poses[:, 0] -= a * c
        poses[:, 1] -= a * s
    elif part == "across":
        a = -s * ex + c * ey
        poses[:, 0] += a * s
        poses[:, 1] -= a * c
    else:
        raise ValueError("unknown oracle part %r (one of %s)" % (part, ", ".join(ORACLES)))
    return poses


def with_oracle(mapper, part, truth_now):
    """Make ``mapper``'s filter correct its particles with ``apply_oracle`` (``part``, the
    pose ``truth_now()`` returns) just before each registration of a scan into the maps.
    Returns the filter wrapped; call again when the mapper has a new one (a reset)."""
    slam = mapper.slam
    register = slam._register  # the filter's own step, wrapped here, not changed

    def corrected(scan):
        apply_oracle(slam.poses, truth_now(), part)
        return register(scan)

    slam._register = corrected
    return slam


def run(world, params, seed, odom_kind, save=None, oracle=None, filter_seed=None):
    """One route: odometry and scans drawn from ``seed`` (the world's own rng for the scans),
    the filter's draws from ``filter_seed`` (default: ``seed``)."""
    rng = np.random.default_rng(seed)
    traj = S.waypoint_trajectory(world.route, v=0.3, w=0.8, dt=SCAN_PERIOD_S)
    if hasattr(world, "check_route"):
        world.check_route(traj)
    odom = odometry(odom_kind, traj, rng)
    mapper = M.SlamMapper(from_params(M.MapperConfig, params.get),
                          seed=seed if filter_seed is None else filter_seed)
    spec = world.spec
    now = [0]  # the index of the scan being fed (the oracle's truth)
    wrapped = None  # the filter the oracle wraps (a reset makes a new one)
    times, walls, errors, statuses = [], [], [], {}
    along, across, heading = [0.0], [0.0], []  # heading: one per update, no start value
    true_poses, scans, odom_poses = [], [], []  # of the updates (map at the true poses)
    k = 0
    for k in range(0, traj.shape[0], FEED_EVERY):
        scan = M.ScanInput(k * SCAN_PERIOD_S, world.scan(traj[k]), spec.angle_min,
                           spec.angle_increment, spec.range_min, spec.range_max)
        now[0] = k
        if oracle and mapper.slam is not wrapped:
            wrapped = with_oracle(mapper, oracle, lambda: traj[now[0]])
        t0, c0 = time.perf_counter(), time.process_time()
        out = mapper.handle_scan(scan, odom[k], world.mount)
        cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        statuses[out.status] = statuses.get(out.status, 0) + 1
        if out.map_changed:
            true_poses.append(traj[k])
            odom_poses.append(odom[k])
            scans.append(mapper._prepare(scan, world.mount))
        if out.status == M.UPDATED:
            times.append(cpu)
            walls.append(wall)
            est = compose(mapper.map_to_odom(), odom[k])
            ex, ey = est[0] - traj[k, 0], est[1] - traj[k, 1]
            errors.append(math.hypot(ex, ey))
            ch, sh = math.cos(traj[k, 2]), math.sin(traj[k, 2])
            along.append(abs(ch * ex + sh * ey))
            across.append(abs(-sh * ex + ch * ey))
            heading.append(abs(float(wrap_angle(est[2] - traj[k, 2]))))
    est_grid, est_info = mapper.occupancy()
    acc = map_agreement(est_grid, est_info, world.truth, world.info)
    ideal_grid, ideal_info = rebuilt_map(est_info, true_poses, scans,
                                         mapper.cfg.rbpf.occ_thresh)
    ideal_acc = map_agreement(ideal_grid, ideal_info, world.truth, world.info)
    final = compose(mapper.map_to_odom(), odom[k])
    sides, corner, ideal_sides = [], float("nan"), []
    if hasattr(world, "quality"):
        prefix = None
        if save:
            from ascc_common.map_io import save_map

            prefix = os.path.join(save, "%s_seed%d" % (world.name, seed))
            save_map(prefix + ".yaml", est_grid, est_info)
        sides, corner = world.quality(est_grid, est_info, prefix)
        ideal_sides, _ = world.quality(ideal_grid, ideal_info)
    lineage = mapper.slam.trajectory()
    inc, odom_inc = increment_errors(np.array(true_poses), lineage, np.array(odom_poses))
    return {
        # the best particle's poses at the registered scans (None after a reset)
        "lineage": lineage if lineage.shape[0] == len(scans) else None,
        "scans": scans, "info": est_info, "occ_thresh": mapper.cfg.rbpf.occ_thresh,
        "inc": inc, "odom_inc": odom_inc,
        "odom_scale": float(np.sum(np.hypot(np.diff(traj[:, 0]), np.diff(traj[:, 1])))
                            / np.sum(np.hypot(np.diff(odom[:, 0]), np.diff(odom[:, 1])))),
        "along": max(along), "across": max(across), "sides": sides, "corner": corner,
        "ideal_sides": ideal_sides,
        "heading_mrad": tuple(1e3 * np.percentile(heading, [50, 95])),
        "world": world.name, "updates": len(times), "statuses": statuses,
        "ms_mean": 1e3 * float(np.mean(times)), "ms_p95": 1e3 * float(np.percentile(times, 95)),
        "ms_max": 1e3 * float(np.max(times)), "ms_wall": 1e3 * float(np.mean(walls)),
        "acc": acc, "ideal": ideal_acc["accuracy"],
        "cpu_s": float(np.sum(times)),
        "end_err": math.hypot(final[0] - traj[k, 0], final[1] - traj[k, 1]),
        "max_err": float(np.max(errors)),
        "odom_err": math.hypot(odom[k, 0] - traj[k, 0], odom[k, 1] - traj[k, 1]),
        "length": float(np.sum(np.hypot(np.diff(traj[:, 0]), np.diff(traj[:, 1])))),
        "map_m": (est_info.width * est_info.resolution, est_info.height * est_info.resolution),
        "maps_mb": 2.0 * est_info.width * est_info.height * mapper.slam.maps.n / 1e6,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worlds", default="synthetic,office,lab,corridor")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--runs", type=int, default=1, help="seeds per world (seed, seed+1, ...)")
    ap.add_argument("--particles", type=int, default=None, help="override the config")
    ap.add_argument("--odometry",
                    choices=("sim", "wall", "calibrated", "exact", "harsh", "create1"),
                    default="sim", help="odometry error model (see odometry())")
    ap.add_argument("--save", metavar="DIR", help="write the maps and overlays here")
    ap.add_argument("--oracle", choices=ORACLES, default=None,
                    help="correct this part of every particle's pose to the truth before "
                         "each scan is registered (an attribution experiment)")
    ap.add_argument("--filters", type=int, default=1, metavar="K",
                    help="run K filters per seed on the same odometry and scans (filter "
                         "seeds seed, seed+1000, ...; the first is the usual run) and also "
                         "print the map rebuilt from the average of their lineages")
    add_parameter_arguments(ap)
    args = ap.parse_args()
    if args.save:
        os.makedirs(args.save, exist_ok=True)
    cv2.setNumThreads(1)
    params = parameters_from_arguments(ap, args)
    if args.particles:
        params["particles"] = args.particles
    print("mapper benchmark, %s odometry%s, parameters: %s" % (
        args.odometry, ", ORACLE %s (the particles' %s set to the truth before each "
        "registration)" % (args.oracle, args.oracle) if args.oracle else "",
        " ".join("%s=%s" % kv for kv in sorted(params.items()))))
    columns = ("world", "seed", "route", "updates", "cpu_ms", "p95", "wall_ms", "accuracy",
               "map_ok", "free", "occ", "known", "end_err", "max_err", "along", "across", "odom",
               "map", "maps", "ideal", "cpu_s", "inc_mm", "odom_inc_mm", "sides_% corner_deg",
               "odom_scale", "ideal_sides_%", "heading_mrad p50/p95")
    header = ("%-9s %4s %6s %7s %7s %7s %7s %8s %7s %6s %6s %8s %7s %7s %6s %6s %7s %11s %6s %7s "
              "%6s %11s %11s  %s  %s  %s  %s" % columns)
    print(header)
    for name in args.worlds.split(","):
        for seed in range(args.seed, args.seed + args.runs):
            results = []
            world = None
            for j in range(args.filters):
                rng = np.random.default_rng(1000 + seed)  # the same scans for every filter
                if world is None:
                    world = SyntheticWorld(rng) if name == "synthetic" else SimWorld(name, rng)
                world.rng = rng  # the world is loaded once, its scans' draws restart
                results.append(run(world, params, seed, args.odometry,
                                   args.save if j == 0 else None, args.oracle,
                                   filter_seed=seed + 1000 * j))
                print_row(results[-1], seed)
            if args.filters > 1:
                avg = average_map(world, results)
                accs = [100 * r["acc"]["accuracy"] for r in results]
                if avg is None:
                    print("  average of the %d filters' lineages: - (a filter was reset)"
                          % args.filters)
                else:
                    print("  average of the %d filters' lineages: %.2f%% (theirs %s, mean "
                          "%.2f%%), sides %s" % (args.filters, 100 * avg[0]["accuracy"],
                                                 " ".join("%.2f" % v for v in accs),
                                                 float(np.mean(accs)),
                                                 " ".join("%+.2f" % v for v in avg[1]) or "-"))
                sys.stdout.flush()


def print_row(r, seed):
    a = r["acc"]
    print("%-9s %4d %5.0fm %7d %7.1f %7.1f %7.1f %7.2f%% %6.2f%% %5.1f%% %5.1f%% %8d %6.3fm "
          "%6.3fm %5.2fm %5.2fm %6.2fm %4.0fmx%4.0fm %4.0fMB %6.2f%% %6.1f "
          "%+5.2f/%5.2f %+5.2f/%5.2f  %s %.2f  %.4f  %s  %.1f/%.1f"
          % (r["world"], seed, r["length"], r["updates"], r["ms_mean"], r["ms_p95"],
             r["ms_wall"], 100 * a["accuracy"], 100 * agreed_share(a),
             100 * a["free_accuracy"], 100 * a["occupied_accuracy"], a["known"], r["end_err"],
             r["max_err"],
             r["along"], r["across"], r["odom_err"], r["map_m"][0], r["map_m"][1],
             r["maps_mb"], 100 * r["ideal"], r["cpu_s"], r["inc"][0], r["inc"][1],
             r["odom_inc"][0], r["odom_inc"][1],
             " ".join("%+.2f" % v for v in r["sides"]) or "-", r["corner"],
             r["odom_scale"],
             " ".join("%+.2f" % v for v in r["ideal_sides"]) or "-",
             *r["heading_mrad"]))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
