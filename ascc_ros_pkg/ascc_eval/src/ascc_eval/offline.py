"""Offline exploration on a ground-truth grid: the explorer's loop without ROS, for comparing
strategies (utility vs nearest) and tuning weights before the full simulator run.

Idealised model (stated, so numbers are read for what they are):
* the robot follows the planner's own path (the coarse-grid shortest path through known
  traversable space) exactly, at `speed_mps`, and spends `goal_overhead_s` per goal
  (planning, turning); localisation and mapping are perfect;
* the laser (range `sensor_range_m`, field of view `fov_deg` centred on the direction of
  travel, `n_rays` rays) copies the truth into the map every `scan_spacing_m` along the
  path, and once at the start over a full turn;
* a goal fails (and is blacklisted) when it is not free with the footprint's clearance in
  the truth, counted in `bad_goals`.
No ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import numpy as np

from ascc_common.grid import UNKNOWN, GridInfo
from frontier_detector import explorer as ex
from frontier_detector.frontiers import traversable_mask
from frontier_detector.goal_selection import Plan, PlannerParams
from frontier_detector.paths import DC, DR, MOVES

from .report import coverage, reachable_area, scan_truth


@dataclass
class OfflineParams:
    speed_mps: float = 0.3          # thesis: the ASCCbot mapped at 0.3 m/s
    goal_overhead_s: float = 3.0    # per goal: planning + turning in place [s]
    sensor_range_m: float = 4.0     # URG-04LX
    fov_deg: float = 240.0
    n_rays: int = 240
    scan_spacing_m: float = 0.5     # a scan every this much travel [m]
    max_goals: int = 400
    max_time_s: float = 7200.0


@dataclass
class OfflineRun:
    strategy: str
    status: str
    goals: int
    bad_goals: int
    path_m: float
    times_s: List[float] = field(default_factory=list)
    coverage: List[float] = field(default_factory=list)
    path_at: List[float] = field(default_factory=list)      # path length [m] at each sample
    trajectory: List[Tuple[float, float]] = field(default_factory=list)
    goals_xy: List[Tuple[float, float]] = field(default_factory=list)
    known: Optional[np.ndarray] = None


def backtrack(result: Plan, goal_rc: Tuple[int, int]) -> List[Tuple[int, int]]:
    """Block-centre cells of the planner's shortest path from the robot to goal_rc."""
    fr = result.frontiers
    g, dist = fr.graph, fr.path_m
    if g is None or dist is None:
        return []
    r0, c0 = fr.window[0], fr.window[1]
    node = g.node(goal_rc[0] - r0, goal_rc[1] - c0)
    if not np.isfinite(dist[node]):
        return []
    offsets = DR * g.shape[1] + DC
    back = np.array([1, 0, 3, 2, 7, 6, 5, 4])           # reverse direction of each move
    cells = []
    for _ in range(dist.size):                           # at most one visit per block
        i, j = divmod(int(node), g.shape[1])
        cells.append(((i - 1) * g.k + g.k // 2 + r0, (j - 1) * g.k + g.k // 2 + c0))
        if dist[node] == 0.0:
            break
        moves = MOVES[g.allow[node]]
        nbs = node + offsets[moves]
        # Neighbours that can step to this node; take the one closest to the start.
        ok = MOVES[g.allow[nbs]][np.arange(nbs.size), back[moves]]
        if not ok.any():
            break
        nbs = nbs[ok]
        best = nbs[int(np.argmin(dist[nbs]))]
        if dist[best] >= dist[node]:
            break
        node = best
    return cells[::-1]


def _rc(info: GridInfo, xy: Tuple[float, float]) -> Tuple[int, int]:
    """Array index (row, col) = (iy, ix) of the cell holding the point xy [m]."""
    ix, iy = info.world_to_cell(xy[0], xy[1])
    return iy, ix


def run(truth: np.ndarray, info: GridInfo, start_xy: Tuple[float, float], strategy: str,
        params: Optional[OfflineParams] = None, planner: Optional[PlannerParams] = None,
        explorer: Optional[ex.ExplorerParams] = None) -> OfflineRun:
    """Explore `truth` from start_xy with the given strategy; see the module docstring."""
    op = params or OfflineParams()
    pp = planner or PlannerParams()
    pp.strategy = strategy
    ctrl = ex.ExplorationController(explorer or ex.ExplorerParams(), pp)
    ctrl.start()
    res = info.resolution
    rng_cells = int(round(op.sensor_range_m / res))
    fov = math.radians(op.fov_deg)
    safe = traversable_mask(truth, pp.frontier.footprint_radius_m / res) > 0
    reach = reachable_area(truth, info, start_xy, pp.frontier.footprint_radius_m)
    known = np.full(truth.shape, UNKNOWN, np.int8)
    pose = (float(start_xy[0]), float(start_xy[1]))
    scan_truth(truth, known, _rc(info, pose), 0.0, rng_cells, 2 * math.pi,
               2 * op.n_rays)
    out = OfflineRun(strategy, ex.EXPLORING, 0, 0, 0.0, trajectory=[pose])
    t, stamp = 0.0, 0

    def record():
        out.times_s.append(t)
        out.path_at.append(out.path_m)
        out.coverage.append(coverage(known, info, truth, info, start_xy, reachable=reach))

    record()
    idle_steps = 0
    while out.goals < op.max_goals and t < op.max_time_s:
        d = ctrl.step(t, known, info, pose, stamp, True)
        out.status = d.status
        if d.status == ex.DONE or (d.action != ex.SEND and d.status != ex.EXPLORING):
            break
        if d.action != ex.SEND:
            idle_steps += 1
            if idle_steps > 10:                          # nothing happens any more
                break
            continue
        idle_steps = 0
        out.goals += 1
        goal = d.goal_xy
        grc = _rc(info, goal)
        if not safe[grc]:
            out.bad_goals += 1
            ctrl.report_outcome(ex.ABORTED)
            continue
        cells = backtrack(d.plan, grc) if d.plan is not None else []
        waypoints = [info.cell_to_world(c, r) for r, c in cells[1:-1]] + [goal]
        since_scan = 0.0
        for wx, wy in waypoints:
            step = math.hypot(wx - pose[0], wy - pose[1])
            heading = math.atan2(wy - pose[1], wx - pose[0]) if step > 0 else 0.0
            pose = (wx, wy)
            out.path_m += step
            t += step / op.speed_mps
            since_scan += step
            out.trajectory.append(pose)
            at_goal = (wx, wy) == goal
            if at_goal and d.goal_yaw is not None:
                heading = d.goal_yaw                     # turns to face its frontier
            if since_scan >= op.scan_spacing_m or at_goal:
                since_scan = 0.0
                scan_truth(truth, known, _rc(info, pose), heading, rng_cells,
                           fov, op.n_rays)
        t += op.goal_overhead_s
        out.goals_xy.append(goal)
        stamp += 1
        ctrl.report_outcome(ex.SUCCEEDED)
        record()
    out.known = known
    return out
