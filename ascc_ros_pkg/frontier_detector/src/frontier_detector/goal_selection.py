"""One planning step of the integrated exploration (fig. 2.7): map -> candidates -> x*.

`plan()` runs the three phases (frontiers.py), classifies the scenario (scenario.py) and
scores the candidates (utility.py), timing each part: phase1, phase2, phase3, utility
(scenario + ray casting + eq. 2.1) and total. Poses and goals are in map metres; cells are
(row, col) of the grid. Blacklisted points exclude every candidate within
`blacklist_radius_m`. No ROS import.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import nested, param

from .frontiers import (
    STATUS_EMPTY_MAP,
    STATUS_OK,
    STATUS_ROBOT_OUTSIDE,
    FrontierParams,
    FrontierResult,
    find_frontiers,
)
from .scenario import Scenario, ScenarioParams, classify
from .utility import STRATEGIES, Scores, UtilityParams, score_candidates

STATUS_ALL_BLACKLISTED = "all_candidates_blacklisted"
STATUS_NO_GAIN = "no_informative_frontiers"     # all left see < min_info_gain_m2


@dataclass
class PlannerParams:
    frontier: FrontierParams = nested(FrontierParams)
    utility: UtilityParams = nested(UtilityParams)
    scenario: ScenarioParams = nested(ScenarioParams)
    strategy: str = param("utility", '"utility" (eq. 2.1) or "nearest"', choices=STRATEGIES)
    blacklist_radius_m: float = param(0.5, "[m] candidates this close to a blacklisted point "
                                      "are skipped")

    def validate(self) -> None:
        if self.strategy not in STRATEGIES:
            raise ValueError(f"strategy must be one of {STRATEGIES}, not {self.strategy!r}")
        self.frontier.validate()
        self.utility.validate()


@dataclass
class Plan:
    status: str
    frontiers: FrontierResult
    info: GridInfo
    scores: Optional[Scores] = None
    scenario: Optional[Scenario] = None
    goals_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    allowed: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    timings_ms: Dict[str, float] = field(default_factory=dict)

    @property
    def best(self) -> int:
        return -1 if self.scores is None else self.scores.best

    @property
    def goal_xy(self) -> Optional[Tuple[float, float]]:
        if self.best < 0:
            return None
        return float(self.goals_xy[self.best, 0]), float(self.goals_xy[self.best, 1])

    @property
    def goal_yaw(self) -> Optional[float]:
        """Heading [rad] at x*: towards its cluster's centroid, i.e. facing the frontier
        (the laser's field of view is 240 deg); None if x* sits on the centroid."""
        goal = self.goal_xy
        if goal is None:
            return None
        c = self.frontiers.centroids_rc[self.best]
        cx, cy = self.info.cell_to_world(float(c[1]), float(c[0]))
        dx, dy = cx - goal[0], cy - goal[1]
        if math.hypot(dx, dy) < 0.5 * self.info.resolution:
            return None
        return math.atan2(dy, dx)


def plan(grid: np.ndarray, info: GridInfo, robot_xy: Tuple[float, float],
         params: Optional[PlannerParams] = None, entropy: Optional[float] = None,
         blacklist_xy: Sequence[Tuple[float, float]] = ()) -> Plan:
    """Candidates and the chosen goal for a trinary grid and the robot's map position."""
    p = params or PlannerParams()
    p.validate()
    rx, ry = float(robot_xy[0]), float(robot_xy[1])
    if grid.size == 0 or not (info.resolution > 0.0 and math.isfinite(info.resolution)):
        fr = FrontierResult(STATUS_EMPTY_MAP)
    elif not (math.isfinite(rx) and math.isfinite(ry)):
        fr = FrontierResult(STATUS_ROBOT_OUTSIDE)
    else:
        ix, iy = info.world_to_cell(rx, ry)
        fr = find_frontiers(grid, info.resolution, (iy, ix), p.frontier)
    timings = dict(fr.timings_ms)
    out = Plan(fr.status, fr, info, timings_ms=timings)
    if fr.status != STATUS_OK:
        timings["utility"] = 0.0
        timings["total"] = sum(timings.get(k, 0.0) for k in ("phase1", "phase2", "phase3"))
        return out
    t0 = time.perf_counter()
    rows, cols = fr.goals_rc[:, 0], fr.goals_rc[:, 1]
    gx, gy = info.cell_to_world(cols, rows)
    out.goals_xy = np.stack([gx, gy], axis=1)
    allowed = np.ones(rows.size, bool)
    for bx, by in blacklist_xy:
        allowed &= np.hypot(gx - bx, gy - by) > p.blacklist_radius_m
    out.allowed = allowed
    out.scenario = classify(grid, info.resolution, fr.robot_rc, p.scenario)
    path_m = fr.path_length_m(rows, cols)
    out.scores = score_candidates(grid, info.resolution, rows, cols, path_m, fr.cluster_cells,
                                  p.utility, p.strategy, out.scenario.w_scenario, entropy,
                                  allowed)
    if out.scores.best < 0:
        eligible = allowed & np.isfinite(path_m)
        out.status = STATUS_NO_GAIN if eligible.any() else STATUS_ALL_BLACKLISTED
    timings["utility"] = (time.perf_counter() - t0) * 1e3
    timings["total"] = sum(timings[k] for k in ("phase1", "phase2", "phase3", "utility"))
    return out


def warm_up() -> float:
    """One plan on a small made-up map, so that every compiled (numba) kernel of the
    search is loaded from numba's cache, or compiled on a first run (a few seconds of CPU
    once per source change; README). Returns the CPU time it took [s]."""
    t0 = time.process_time()
    grid = np.full((60, 80), -1, np.int8)           # unknown, a walled free room in it
    grid[5:55, 5:45] = 100
    grid[6:54, 6:44] = 0
    grid[20:30, 44] = 0                              # a door into the unknown
    plan(grid, GridInfo(0.05, 80, 60), (1.0, 1.0), PlannerParams())
    return time.process_time() - t0
