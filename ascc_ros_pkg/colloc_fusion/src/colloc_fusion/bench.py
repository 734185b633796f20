"""The accuracy benchmark's pure parts (scripts/bench_colloc.py runs the simulator):
random placements of the cone and the three robots in a world, and the errors of each
robot alone and of every fusion method, replayed offline on the recorded estimates.

A placement is valid when the cone stands ``cone_clearance_m`` clear of walls and
furniture, every robot stands ``robot_clearance_m`` clear of them, at ``range_m`` from
the cone with a free line of sight to it (grid cells and the other robots), the robots
``min_separation_m`` apart, each facing the cone within +-``max_heading_offset_rad`` (the
laser sees +-120 deg). All draws follow ``seed``.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import yaml

from .estimate import TargetEstimate
from .fuser import FusionCore
from .fusion import METHODS
from .node_params import FusionParams

ROBOTS = ("robotA", "robotB", "robotC")


@dataclass
class Placement:
    cone: Tuple[float, float]
    robots: Dict[str, Tuple[float, float, float]]


@dataclass
class PlacementRules:
    cone_clearance_m: float = 0.5
    robot_clearance_m: float = 0.35
    range_m: Tuple[float, float] = (1.2, 3.2)
    min_separation_m: float = 0.8
    max_heading_offset_rad: float = 1.0
    line_of_sight_step_m: float = 0.05


def _free(grid, x: float, y: float, clearance_m: float) -> bool:
    return grid.disc_contact(x, y, clearance_m) is None


def _line_of_sight(grid, a, b, step_m: float, others, radius_m: float) -> bool:
    n = max(2, int(math.hypot(b[0] - a[0], b[1] - a[1]) / step_m))
    ts = np.linspace(0.0, 1.0, n)[1:-1]
    xs, ys = a[0] + ts * (b[0] - a[0]), a[1] + ts * (b[1] - a[1])
    if any(grid.value_at(float(x), float(y)) >= 50 for x, y in zip(xs, ys)):
        return False
    for o in others:
        if np.min(np.hypot(xs - o[0], ys - o[1])) < radius_m:
            return False
    return True


def random_placement(grid, rng: np.random.Generator, bounds: Sequence[float],
                     rules: Optional[PlacementRules] = None, robot_radius_m: float = 0.165,
                     tries: int = 20000) -> Placement:
    """A valid random placement in ``grid`` (an ascc_sim GridMap of walls and furniture)
    within ``bounds`` (x0, y0, x1, y1) [m]; RuntimeError after ``tries`` draws."""
    rules = rules or PlacementRules()
    x0, y0, x1, y1 = bounds
    for _ in range(tries):
        cone = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
        if not _free(grid, cone[0], cone[1], rules.cone_clearance_m):
            continue
        robots: Dict[str, Tuple[float, float, float]] = {}
        for name in ROBOTS:
            for _ in range(500):
                r = rng.uniform(*rules.range_m)
                phi = rng.uniform(-math.pi, math.pi)
                x, y = cone[0] + r * math.cos(phi), cone[1] + r * math.sin(phi)
                if not (x0 <= x <= x1 and y0 <= y <= y1):
                    continue
                if not _free(grid, x, y, rules.robot_clearance_m):
                    continue
                if any(math.hypot(x - p[0], y - p[1]) < rules.min_separation_m
                       for p in robots.values()):
                    continue
                if not _line_of_sight(grid, (x, y), cone, rules.line_of_sight_step_m,
                                      list(robots.values()), robot_radius_m + 0.05):
                    continue
                yaw = math.atan2(cone[1] - y, cone[0] - x) + rng.uniform(
                    -rules.max_heading_offset_rad, rules.max_heading_offset_rad)
                robots[name] = (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))
                break
            else:
                break
        if len(robots) == len(ROBOTS):
            # the robots placed later must not block the earlier ones' view either
            if all(_line_of_sight(grid, p[:2], cone, rules.line_of_sight_step_m,
                                  [q for m, q in robots.items() if m != n],
                                  robot_radius_m + 0.05) for n, p in robots.items()):
                return Placement(cone, robots)
    raise RuntimeError("no valid placement after %d draws" % tries)


def write_placement_world(path: str, placement: Placement, src: str) -> str:
    """Writes to ``path`` the world YAML ``src`` with its robots and its cone moved to
    ``placement`` (map path made absolute); returns ``path``."""
    with open(src) as f:
        doc = yaml.safe_load(f)
    doc["map"] = os.path.join(os.path.dirname(os.path.abspath(src)), doc["map"])
    for r in doc["robots"]:
        r["pose"] = [round(v, 4) for v in placement.robots[r["name"]]]
    for o in doc["objects"]:
        if o["type"] == "cone":
            o["pose"] = [round(v, 4) for v in placement.cone]
    with open(path, "w") as f:
        yaml.safe_dump(doc, f)
    return path


def replay_errors(estimates: Sequence[TargetEstimate], truth: Tuple[float, float],
                  t0: float, t1: float, period_s: float = 0.5, window_s: float = 1.0,
                  variants: Optional[Dict[str, dict]] = None,
                  left_out: Optional[Dict[str, Dict[str, List[str]]]] = None
                  ) -> Dict[str, List[float]]:
    """Errors [m] against ``truth`` between ``t0`` and ``t1`` (sim time [s]): each robot's
    estimates alone (``robotX``), and every variant {name: FusionParams fields} (default:
    each method) fused as the fusion node would every ``period_s`` (each robot's newest
    estimate within ``window_s``; the estimate is taken as received at its stamp).
    ``left_out``, if given, is filled with {variant: {robot: [the reasons, one per fusion
    step that left it out]}}, as the node's status reports them."""
    variants = variants or {m: {"method": m} for m in METHODS}
    out: Dict[str, List[float]] = {}
    ests = sorted(estimates, key=lambda e: e.stamp_s)
    for e in ests:
        if t0 <= e.stamp_s <= t1:
            out.setdefault(e.robot, []).append(math.hypot(e.x - truth[0], e.y - truth[1]))
    for name, fields in variants.items():
        core = FusionCore(FusionParams(window_s=window_s, **fields))
        errs, i = [], 0
        for t in np.arange(t0, t1 + 1e-9, period_s):
            while i < len(ests) and ests[i].stamp_s <= t:
                core.add(ests[i], ests[i].stamp_s)
                i += 1
            fused, left = core.step(float(t))
            if left_out is not None:
                for robot, why in left.items():
                    left_out.setdefault(name, {}).setdefault(robot, []).append(why)
            if fused is not None:
                errs.append(math.hypot(fused.x - truth[0], fused.y - truth[1]))
        out[name] = errs
    return out


def error_split(estimates: Sequence[TargetEstimate], poses: Mapping[str, Sequence],
                robot_truth: Mapping[str, Sequence[float]], truth: Tuple[float, float],
                t0: float, t1: float) -> Dict[str, Dict[str, float]]:
    """Each robot's target error split into what its pose estimate and what its
    measurement (range, bearing, range offset) contribute, averaged over its estimates
    stamped in [t0, t1].

    ``poses[robot]``: the robot's pose estimates [stamp, x, y, yaw] (amcl_pose);
    ``robot_truth[robot]``: its true pose (x, y, yaw), in the same frame as ``truth``. An
    estimate e made from pose estimate P with measurement m (the target in the robot's
    frame, m = R(-yaw_P) (e - p_P)) would have been e' = p_T + R(yaw_T) m from the true
    pose T: ``pose`` is |e - e'| (the localisation's share), ``measurement`` |e' - truth|
    (the range and bearing's share), ``total`` |e - truth|, ``pose_xy`` / ``pose_yaw``
    the pose estimate's own errors [m, rad] (absolute), all means. A robot without pose
    estimates or truth is left out.
    """
    out: Dict[str, Dict[str, float]] = {}
    tx, ty = truth
    for robot, plist in poses.items():
        if not plist or robot not in robot_truth:
            continue
        arr = np.array(sorted(plist), dtype=float)
        true = np.asarray(robot_truth[robot], dtype=float)
        acc: Dict[str, List[float]] = {"pose": [], "measurement": [], "total": [],
                                       "pose_xy": [], "pose_yaw": []}
        for e in estimates:
            if e.robot != robot or not t0 <= e.stamp_s <= t1:
                continue
            k = int(np.searchsorted(arr[:, 0], e.stamp_s, side="right")) - 1
            if k < 0:
                continue
            _, px, py, pyaw = arr[k]
            c, s = math.cos(pyaw), math.sin(pyaw)
            dx, dy = e.x - px, e.y - py
            mx, my = c * dx + s * dy, -s * dx + c * dy
            ct, st = math.cos(true[2]), math.sin(true[2])
            ex, ey = true[0] + ct * mx - st * my, true[1] + st * mx + ct * my
            acc["pose"].append(math.hypot(e.x - ex, e.y - ey))
            acc["measurement"].append(math.hypot(ex - tx, ey - ty))
            acc["total"].append(math.hypot(e.x - tx, e.y - ty))
            acc["pose_xy"].append(math.hypot(px - true[0], py - true[1]))
            acc["pose_yaw"].append(abs(math.atan2(math.sin(pyaw - true[2]),
                                                  math.cos(pyaw - true[2]))))
        if acc["total"]:
            out[robot] = {k: float(np.mean(v)) for k, v in acc.items()}
    return out


def best_on_average(rows: Sequence[Mapping], robots: Sequence[str] = ROBOTS) -> str:
    """The robot whose per-trial error [m] (``row[robot]``) is smallest on average over
    ``rows`` (trials it missed are left out of its mean)."""
    means = {}
    for r in robots:
        vals = [row[r] for row in rows if row.get(r) is not None]
        if vals:
            means[r] = float(np.mean(vals))
    if not means:
        raise ValueError("no robot's error in any trial")
    return min(means, key=means.get)


def beats_counts(rows: Sequence[Mapping], methods: Sequence[str],
                 robots: Sequence[str] = ROBOTS, advance_robot: Optional[str] = None
                 ) -> Dict[str, Dict[str, int]]:
    """For each method, in how many trials (rows: {name: per-trial error [m]}) its error
    is below ``per_trial_best`` (the smallest of the robots' errors in that trial: the
    robot chosen afterwards with the truth), ``median_robot`` (the middle one) and, with
    ``advance_robot`` (a robot chosen in advance, e.g. the best on average on another
    set), ``advance_robot``; ``trials``: the trials with that method's error and at
    least one robot's (and ``advance_trials``: those that also have advance_robot's);
    ``each_robot``: {robot: [wins, trials]} against every robot as if fixed in advance."""
    out: Dict[str, Dict[str, int]] = {}
    for m in methods:
        c = {"trials": 0, "per_trial_best": 0, "median_robot": 0,
             "each_robot": {r: [0, 0] for r in robots}}
        if advance_robot is not None:
            c.update(advance_robot=0, advance_trials=0)
        for row in rows:
            singles = [row[r] for r in robots if row.get(r) is not None]
            if row.get(m) is None or not singles:
                continue
            c["trials"] += 1
            c["per_trial_best"] += int(row[m] < min(singles))
            c["median_robot"] += int(row[m] < float(np.median(singles)))
            for r in robots:
                if row.get(r) is not None:
                    c["each_robot"][r][0] += int(row[m] < row[r])
                    c["each_robot"][r][1] += 1
            if advance_robot is not None and row.get(advance_robot) is not None:
                c["advance_trials"] += 1
                c["advance_robot"] += int(row[m] < row[advance_robot])
        out[m] = c
    return out


def pooled_error_correlation(vectors: Sequence[Mapping[str, Sequence[float]]],
                             robots: Sequence[str] = ROBOTS) -> Optional[float]:
    """How much the robots' errors go together: over trials (each {robot: its mean error
    vector (x, y) [m]}, trials missing a robot left out), the correlation of the robots'
    error components pooled over robot pairs and both axes, taking the errors as zero mean
    (sum e_i . e_j / sqrt(sum |e_i|^2 sum |e_j|^2)). 0: independent (as the fusion
    assumes); 1: one shared error no fusion removes. None with fewer than 2 trials."""
    rows = [np.array([v[r] for r in robots], dtype=float) for v in vectors
            if all(r in v for r in robots)]
    if len(rows) < 2:
        return None
    e = np.array(rows)  # trials x robots x 2
    num = den = 0.0
    for i in range(len(robots)):
        for j in range(i + 1, len(robots)):
            num += float(np.sum(e[:, i] * e[:, j]))
            den += math.sqrt(float(np.sum(e[:, i] ** 2)) * float(np.sum(e[:, j] ** 2)))
    return num / den if den > 0 else None
