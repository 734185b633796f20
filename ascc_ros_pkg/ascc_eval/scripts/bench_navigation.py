#!/usr/bin/env python3
"""Benchmark of the move_base stand-in (planner + controller + recovery), no ROS master.

A unicycle robot (iRobot Create, radius 0.17 m) with a ray-cast URG-04LX drives in the
synthetic office (``synthetic.office_world``) under ``navigation.Navigator`` at 10 Hz, with
the parameters of config/move_base.yaml and a perfect pose (localization is benchmarked by
bench_localization.py). Printed:
  * random goals: N reachable goals (free cells with 0.3 m clearance, reachable on the map)
    in a row (``--world``: on an ascc_sim world's ground-truth map instead); reached /
    aborted / timed out, collisions (robot circle overlapping an occupied cell of the true
    world), time and path length;
  * unreachable goals: a sealed closet, a goal off the map, a goal inside a wall block:
    status, reason and the (simulated) time until ABORTED;
  * unmapped obstacles: a box and a wall that are in the world but not in the map, so the
    controller must stop and the recovery must re-plan around them;
  * planner speed on the thesis's 100 m x 25 m corridor loop at 5 cm: costmap and plan time.

    python3 scripts/bench_navigation.py [--goals 20] [--seed 1]
"""
import argparse
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

from ascc_common.grid import OCCUPIED, GridInfo  # noqa: E402
from ascc_common.params import from_params, tree_getter  # noqa: E402
from ascc_navigation import navigation as nav  # noqa: E402
from ascc_navigation import planner as pln  # noqa: E402
from ascc_navigation import synthetic as syn  # noqa: E402
from ascc_navigation.laser import LaserMount  # noqa: E402

DT = 0.1  # [s] control period (controller_frequency 10 Hz)
MOUNT = LaserMount(0.1, 0.0, 0.0)


def add_box(grid: np.ndarray, info: GridInfo, x0, y0, x1, y1) -> None:
    ix0, iy0 = info.world_to_cell(x0, y0)
    ix1, iy1 = info.world_to_cell(x1 - 1e-9, y1 - 1e-9)
    grid[int(iy0):int(iy1) + 1, int(ix0):int(ix1) + 1] = OCCUPIED


def office_with_closet():
    """The office plus a sealed closet in the north-east room (reachable by nothing)."""
    grid, info = syn.office_world()
    add_box(grid, info, 12.8, 8.0, 13.9, 8.1)
    add_box(grid, info, 12.8, 8.0, 12.9, 9.9)
    return grid, info


class Sim:
    """Kinematic robot, true world, laser; runs a Navigator until the goal ends."""

    def __init__(self, truth_grid, info, navigator: nav.Navigator, rng, radius: float):
        self.occupied = truth_grid == OCCUPIED
        self.info = info
        free = (~self.occupied).astype(np.uint8)
        dist = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        self.surface = np.maximum(dist - 0.5, 0.0) * info.resolution  # [m] to obstacles
        self.nav = navigator
        self.rng = rng
        self.radius = radius
        self.spec = syn.LaserSpec()
        self.t = 0.0
        self.pose = np.zeros(3)
        self.step_times = []

    def clearance(self) -> float:
        ix, iy = self.info.world_to_cell(self.pose[0], self.pose[1])
        return float(self.surface[int(iy), int(ix)])

    def scan_points(self) -> np.ndarray:
        r = syn.simulate_scan(self.occupied, self.info, self.pose, MOUNT, self.spec, self.rng)
        ok = np.isfinite(r)
        a = MOUNT.beam_angles(r.size, self.spec.angle_min, self.spec.angle_increment)[ok]
        return np.column_stack([MOUNT.x + r[ok] * np.cos(a), MOUNT.y + r[ok] * np.sin(a)])

    def run_goal(self, goal, timeout: float):
        """Returns (status, reason, duration [s], travelled [m], min clearance [m])."""
        self.nav.set_goal(goal[0], goal[1], goal[2], self.t)
        t0, travelled, min_clear = self.t, 0.0, np.inf
        step = nav.Step()
        while self.t - t0 < timeout:
            pts = self.scan_points()
            c0 = time.perf_counter()
            step = self.nav.step(self.t, self.pose, pts, DT)
            self.step_times.append(time.perf_counter() - c0)
            if step.status != nav.ACTIVE:
                break
            v, w = step.v, step.w
            th = self.pose[2]
            if abs(w) > 1e-9:
                self.pose += [v / w * (np.sin(th + w * DT) - np.sin(th)),
                              -v / w * (np.cos(th + w * DT) - np.cos(th)), w * DT]
            else:
                self.pose += [v * DT * np.cos(th), v * DT * np.sin(th), 0.0]
            self.pose[2] = (self.pose[2] + np.pi) % (2 * np.pi) - np.pi
            travelled += abs(v) * DT
            self.t += DT
            min_clear = min(min_clear, self.clearance())
        else:
            self.nav.cancel()
            return "timeout", "", self.t - t0, travelled, min_clear
        return step.status, step.reason, self.t - t0, travelled, min_clear


def load_params():
    with open(os.path.join(NAV, "config", "move_base.yaml")) as f:
        p = from_params(nav.MoveBaseParams, tree_getter(yaml.safe_load(f)))
    return p.planner, p.controller, p.nav


def random_goals(grid, info, planner_params, start, n, rng):
    """Goals on free cells with >= 0.3 m clearance that the planner can reach from the
    previous goal (so the tour is feasible on the map)."""
    free = (grid != OCCUPIED).astype(np.uint8)
    surf = np.maximum(cv2.distanceTransform(free, cv2.DIST_L2, 5) - 0.5, 0) * info.resolution
    iy, ix = np.nonzero((surf >= 0.3) & (grid == 0))
    costmap = pln.Costmap(grid, info, planner_params)
    goals, prev = [], start
    while len(goals) < n:
        k = rng.integers(ix.size)
        x, y = info.cell_to_world(ix[k], iy[k])
        res = pln.plan(costmap, prev[:2], (float(x), float(y)))
        if res.ok:
            goals.append((float(x), float(y), float(rng.uniform(-np.pi, np.pi))))
            prev = goals[-1]
    return goals


def load_sim_world(path):
    """The ground-truth map (walls + furniture) and robot start of an ascc_sim world."""
    from ascc_sim.world import load_world  # only this option needs the simulator package

    world = load_world(path, 0.165)
    m = world.truth_map
    info = m.info
    pose = world.robots[0].pose
    return m.occupancy.copy(), info, np.array([pose.x, pose.y, pose.yaw], dtype=float)


def bench_random(args, params):
    if args.world:
        grid, info, start = load_sim_world(args.world)
        where = os.path.basename(args.world)
    else:
        grid, info = office_with_closet()
        start, where = np.array([2.0, 2.0, 0.0]), "synthetic office"
    rng = np.random.default_rng(args.seed)
    navigator = nav.Navigator(*params)
    navigator.set_map(grid, info)
    sim = Sim(grid, info, navigator, rng, params[1].robot_radius)
    sim.pose = start.copy()
    goals = random_goals(grid, info, params[0], sim.pose, args.goals, rng)
    print("== %d random reachable goals in the %s ==" % (len(goals), where))
    print(" #   goal (x, y)       status     time_s  travelled_m  min_clearance_m")
    reached = collisions = 0
    for i, g in enumerate(goals):
        status, reason, dur, dist, clear = sim.run_goal(g, timeout=120.0)
        reached += status == nav.SUCCEEDED
        collisions += clear < params[1].robot_radius
        print("%2d  (%5.2f, %5.2f)  %-9s  %6.1f  %11.1f  %15.3f %s" % (
            i, g[0], g[1], status, dur, dist, clear, "" if status == nav.SUCCEEDED else reason))
    print("reached %d / %d, collisions %d; navigator step %.1f ms mean, %.1f ms max"
          % (reached, len(goals), collisions, 1e3 * np.mean(sim.step_times),
             1e3 * np.max(sim.step_times)))


def bench_unreachable(args, params):
    grid, info = office_with_closet()
    print("== unreachable and invalid goals ==")
    cases = [("sealed closet", (13.4, 9.0, 0.0)), ("off the map", (20.0, 20.0, 0.0)),
             ("inside the central block", (7.0, 4.2, 0.0))]
    for name, goal in cases:
        navigator = nav.Navigator(*params)
        navigator.set_map(grid, info)
        sim = Sim(grid, info, navigator, np.random.default_rng(args.seed), 0.17)
        sim.pose = np.array([2.0, 2.0, 0.0])
        c0 = time.perf_counter()
        status, reason, dur, _, _ = sim.run_goal(goal, timeout=30.0)
        print("%-24s %-8s after %4.1f s simulated (%.2f s wall): %s"
              % (name, status, dur, time.perf_counter() - c0, reason))


def bench_unmapped(args, params):
    print("== obstacles missing from the map ==")
    cases = [("box in the south corridor", (7.6, 1.5, 8.2, 2.6), (2.0, 2.0, 0.0),
              (12.0, 2.0, 0.0)),
             ("wall closing the south corridor", (8.0, 0.1, 8.2, 3.0), (2.0, 2.0, 0.0),
              (12.0, 2.0, 0.0))]
    for name, box, start, goal in cases:
        grid, info = syn.office_world()
        truth = grid.copy()
        add_box(truth, info, *box)
        navigator = nav.Navigator(*params)
        navigator.set_map(grid, info)
        sim = Sim(truth, info, navigator, np.random.default_rng(args.seed), 0.17)
        sim.pose = np.array(start, dtype=float)
        status, reason, dur, dist, clear = sim.run_goal(goal, timeout=180.0)
        print("%-32s %-9s %5.1f s, %5.1f m travelled, min clearance %.3f m %s"
              % (name, status, dur, dist, clear, reason if status != nav.SUCCEEDED else ""))


def bench_planner(params):
    print("== planner on the 100 m x 25 m corridor loop (5 cm map) ==")
    grid, info = syn.rect_world((100.0, 25.0), 0.05, [(2.5, 2.5, 97.5, 22.5)])
    for res in (0.1, 0.05):
        p = pln.PlannerParams(**{**params[0].__dict__, "resolution": res})
        c0 = time.perf_counter()
        costmap = pln.Costmap(grid, info, p)
        c1 = time.perf_counter()
        result = pln.plan(costmap, (1.2, 1.2), (98.8, 23.8))
        c2 = time.perf_counter()
        print("planning grid %.2f m (%d x %d): costmap %.0f ms, plan %.0f ms (%d rounds), "
              "path %.1f m" % (res, costmap.shape[1], costmap.shape[0], 1e3 * (c1 - c0),
                               1e3 * (c2 - c1), result.rounds, pln.path_length(result.path)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--world", default="",
                    help="an ascc_sim world YAML: random goals on its ground-truth map "
                    "(needs the built workspace); default: the synthetic office")
    ap.add_argument("--skip", default="", help="comma list of parts to skip: "
                    "random,unreachable,unmapped,planner")
    args = ap.parse_args()
    params = load_params()
    skip = set(args.skip.split(","))
    if "random" not in skip:
        bench_random(args, params)
    if "unreachable" not in skip:
        bench_unreachable(args, params)
    if "unmapped" not in skip:
        bench_unmapped(args, params)
    if "planner" not in skip:
        bench_planner(params)
    return 0


if __name__ == "__main__":
    sys.exit(main())
