"""A mapper front end without particles: each update's scan matched against a submap of the
last keyframes' scans, fused with the odometry by their covariances, its heading held to the
walls (no ROS imports). An alternative to the particle filter (``rbpf``) behind the same
``SlamMapper`` (``frontend: submap``); not gmapping.

Per update (``SlamMapper`` decides when, as for the filter: ``linearUpdate``,
``angularUpdate``):

* **prediction**: the last pose composed with the odometry increment; its covariance from
  the increment (``odom_*`` stds: along and across the motion, heading), the last pose
  taken as known; after the fusion the increment's translation is re-aimed along the chord
  of the fused turn (``odom_chord``, ``chord``);
* **scan-to-submap match**: the scan's end points (on the surface, ``hit_offset`` moved back
  along their beams) against the end points of the keyframes of the last ``submap_m`` of
  path at their estimated poses: ``posegraph.correlative_match`` (likelihood field at
  ``field_res_m``, every candidate of a +-``window_m``, +-``window_rad`` grid, refined),
  scoring only where those keyframes' scans saw; the candidates' spread is the match's
  covariance (along a featureless corridor large, so the prediction holds the position
  there), scaled by ``match_cov_scale`` (one scan's beams are not independent);
* **wall heading**: the walls' direction of this scan (``wall_axes.scan_wall_axis`` of the
  surface points), modulo a right angle, against the reference direction (the mean of the
  first scan's and of up to ``wall_reference_scans`` taken before the robot first moves:
  ``observe_still``), as a heading measurement of std ``wall_std_rad`` where it lies within
  ``wall_gate_rad`` of the match; walls off every reference, seen alike in
  ``wall_learn_scans`` matched scans, become a reference of their own (a wing at 45
  degrees, a side a few degrees off), and each scan is measured against the reference
  nearest the match's heading; a scan whose walls disagree among themselves (two
  families a few degrees apart) is neither measured nor learned from;
* the three fused (information form); a match scoring under ``min_score`` is not used, nor
  one whose offset from the prediction is an outlier under both covariances (squared
  Mahalanobis distance above ``match_gate``: a match at its window's edge can be
  confidently wrong).

The map is the one-particle occupancy grid (``rbpf.ParticleMaps``) of the scans at their
fused poses. The poses never move afterwards: no smoothing and no loop closure of its own
(``loop_closure`` works with it as with the filter). ``UpdateStats.entropy`` is the
Gaussian entropy of the fused pose covariance [nats], not the particle weights'.

Why: on the corridor loop the filter's maps lose what they lose to where their parts lie,
and one filter's random draws move a run by 1-2.5 points. This front end is deterministic;
with its walls' direction from the surface points (the filter fits the end points pushed
half a cell along their beams, which bends the lobby's walls by about 4.5 mrad) it holds
the heading to 1.4-2 mrad (95th percentile) on the scripted corridor loops
(docs/results/ascc_navigation.md).

Limit, and why it is not the default: the chain of scan-to-submap matches does not hold the
heading by itself. Without the walls' measurement it drifts by about 8 mrad in 5 m even
with exact odometry; where walls at a new angle have not been seen long enough to be
learned, it follows the odometry's heading in part (on the held-out ``annex`` world one
seed's wheels turn 56 mrad per metre and its map breaks). A learned direction carries the
heading error of the moment it was learned. Experimental; online no better than the
filter (docs/results/ascc_navigation.md).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Deque, List, Optional, Tuple

import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import param
from ascc_common.pose2d import compose, wrap_angle
from ascc_navigation.laser import PreparedScan
from ascc_navigation.posegraph import (
    LikelihoodField,
    _seen_polygon,
    _subsample,
    _surface_points,
    _transform,
    correlative_match,
)
from ascc_navigation.rbpf import ParticleMaps, UpdateStats
from ascc_navigation.wall_axes import mean_direction, scan_wall_axis, wrap_right_angle


@dataclass
class SubmapConfig:
    """The particle-free front end's parameters (``frontend: submap``), read by the mapper
    node as private parameters with these names."""

    submap_m: float = param(15.0, "[m] the submap: keyframes of this much path back",
                            "submap_path_m", gt=0.0)
    field_res_m: float = param(0.02, "[m] the match's likelihood field cell",
                               "submap_field_res_m", gt=0.0)
    window_m: float = param(0.2, "[m] the match searches +- this in x and y around the "
                            "prediction", "submap_window_m", gt=0.0)
    window_rad: float = param(0.08, "[rad] ... and +- this in heading",
                              "submap_window_rad", gt=0.0)
    step_rad: float = param(0.005, "[rad] heading step of the match's grid",
                            "submap_step_rad", gt=0.0)
    match_sigma_m: float = param(0.05, "[m] end point to submap distance scale of the score",
                                 "submap_match_sigma_m", gt=0.0)
    match_points: int = param(400, "end points matched (evenly spread)",
                              "submap_match_points", ge=10)
    min_score: float = param(0.5, "a match scoring less (0..1) is not used",
                             "submap_min_score", ge=0.0)
    match_cov_scale: float = param(10.0, "the match's covariance multiplied by this",
                                   "submap_match_cov_scale", gt=0.0)
    odom_chord: bool = param(True, "the odometry's translation taken along the chord of the "
                             "fused turn (its distance, not its sideways part)",
                             "submap_odom_chord")
    match_gate: float = param(16.27, "a match whose offset from the prediction has a squared "
                              "Mahalanobis distance above this (under the prediction's and "
                              "the scaled match's covariances; chi-square, 3 dof: 16.27 is "
                              "its 99.9 % point) is not used; <= 0: off",
                              "submap_match_gate")
    wall_std_rad: float = param(0.002, "[rad] std of the walls' heading measurement; "
                                "<=0: off", "submap_wall_std_rad")
    wall_reference_scans: int = param(50, "the walls' reference direction: the mean of this "
                                      "many scans at most, taken before the robot first "
                                      "moves (1: the first scan's alone)",
                                      "submap_wall_reference_scans", ge=1)
    wall_gate_rad: float = param(0.03, "[rad] the walls' heading is used within this of "
                                 "the match's", "submap_wall_gate_rad", gt=0.0)
    wall_learn_scans: int = param(10, "walls whose direction is further than wall_gate_rad "
                                  "from every reference, seen in this many matched scans "
                                  "agreeing within wall_learn_tol_rad, become a reference "
                                  "of their own (their direction at the fused heading); "
                                  "0: only the start's reference",
                                  "submap_wall_learn_scans", ge=0)
    wall_learn_tol_rad: float = param(0.01, "[rad] scans agreeing within this join a "
                                      "direction being learned (another one restarts it)",
                                      "submap_wall_learn_tol_rad", gt=0.0)
    odom_along_m: float = param(0.002, "[m] odometry std along the motion, per update",
                                "submap_odom_along_m", ge=0.0)
    odom_along_per_m: float = param(0.01, "[m/m] ... plus this per metre driven",
                                    "submap_odom_along_per_m", ge=0.0)
    odom_across_m: float = param(0.01, "[m] odometry std across the motion, per update",
                                 "submap_odom_across_m", ge=0.0)
    odom_across_per_m: float = param(0.05, "[m/m] ... plus this per metre driven",
                                     "submap_odom_across_per_m", ge=0.0)
    odom_heading_rad: float = param(0.01, "[rad] odometry heading std, per update",
                                    "submap_odom_heading_rad", ge=0.0)
    odom_heading_per_m: float = param(0.05, "[rad/m] ... plus this per metre driven",
                                      "submap_odom_heading_per_m", ge=0.0)
    odom_heading_per_rad: float = param(0.05, "[rad/rad] ... plus this per radian turned",
                                        "submap_odom_heading_per_rad", ge=0.0)


def odometry_covariance(delta: np.ndarray, heading: float, cfg: SubmapConfig) -> np.ndarray:
    """Covariance (map frame, x y theta) of the prediction from an odometry increment
    ``delta`` (dx, dy, dtheta in the previous pose's frame) taken at map heading
    ``heading``: independent stds along and across the motion and in heading, each a
    constant plus a part proportional to the distance (and the heading's to the turn)."""
    d = math.hypot(float(delta[0]), float(delta[1]))
    along = cfg.odom_along_m + cfg.odom_along_per_m * d
    across = cfg.odom_across_m + cfg.odom_across_per_m * d
    turn = (cfg.odom_heading_rad + cfg.odom_heading_per_m * d
            + cfg.odom_heading_per_rad * abs(float(delta[2])))
    direction = heading + (math.atan2(float(delta[1]), float(delta[0])) if d > 1e-6 else 0.0)
    c, s = math.cos(direction), math.sin(direction)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rot @ np.diag([along * along, across * across, turn * turn]) @ rot.T


def chord(delta: np.ndarray, heading: float, turn: float) -> np.ndarray:
    """The map-frame translation of an odometry increment ``delta`` (dx, dy, dtheta in the
    previous pose's frame) from a pose at ``heading`` [rad], its direction turned by half
    of ``turn`` [rad] instead of half of the odometry's own dtheta: a wheeled base moves
    along the chord of its arc, so an increment's sideways part follows from its turn, and
    where the odometry's turn is wrong (the Create 1's whole-degree heading) so is that
    part. The distance stays the odometry's."""
    dx, dy, dth = float(delta[0]), float(delta[1]), float(delta[2])
    length = math.hypot(dx, dy)
    if length < 1e-9:
        return np.zeros(2)
    direction = heading + math.atan2(dy, dx) + 0.5 * (turn - dth)
    return length * np.array([math.cos(direction), math.sin(direction)])


def gaussian_entropy(cov: np.ndarray) -> float:
    """Differential entropy [nats] of a Gaussian with covariance ``cov``."""
    k = cov.shape[0]
    sign, logdet = np.linalg.slogdet(cov)
    if sign <= 0:
        return float("-inf")
    return 0.5 * (k * math.log(2.0 * math.pi * math.e) + logdet)


class SubmapSlam:
    """The front end's state: the pose, the keyframes of the submap, the map. The same
    calls as ``rbpf.RbpfSlam`` where ``SlamMapper`` and the benchmarks use them."""

    def __init__(self, cfg: SubmapConfig, delta: float, occ_thresh: float,
                 bounds: Tuple[float, float, float, float], grow_margin: float):
        self.cfg = cfg
        self.delta = float(delta)            # [m] the map's cell
        self.hit_offset = 0.5 * self.delta   # prepare_scan's, as SlamMapper prepares scans
        self.occ_thresh = float(occ_thresh)
        self.grow_margin = float(grow_margin)
        self.maps = ParticleMaps(1, GridInfo.from_bounds(self.delta, *bounds))
        self.pose = np.zeros(3)
        self.initialized = False
        self.updates = 0
        self.path_m = 0.0
        # map-frame walls' directions [rad]: the start's reference first, then the
        # directions learned (wall_learn_scans)
        self.wall_references: List[float] = []
        self._learning: Optional[Tuple[float, int]] = None  # (mean direction, scans)
        self.gated_matches = 0  # matches scoring min_score or more but left out by match_gate
        self.reference_scans = 0  # scans averaged into wall_reference
        # the submap: (path [m], surface points, seen polygon), both in the map frame (a
        # keyframe's pose never moves; a loop closure's restart drops them)
        self._keyframes: Deque[Tuple[float, np.ndarray, np.ndarray]] = deque()
        self._history = np.zeros((64, 3))

    @property
    def wall_reference(self) -> Optional[float]:
        """The start's walls' direction in the map frame [rad], None before one is seen."""
        return self.wall_references[0] if self.wall_references else None

    @property
    def best_pose(self) -> np.ndarray:
        return self.pose.copy()

    @property
    def poses(self) -> np.ndarray:
        """(1, 3): the one pose, as the filter's particle poses."""
        return self.pose[None].copy()

    def occupancy(self) -> Tuple[np.ndarray, GridInfo]:
        """-1/0/100 grid and its geometry."""
        return self.maps.occupancy(0, self.occ_thresh), self.maps.info

    def new_maps(self) -> ParticleMaps:
        """An empty one-particle map on the current grid geometry."""
        return ParticleMaps(1, self.maps.info)

    def start(self, pose, scan: PreparedScan) -> UpdateStats:
        """Start at ``pose`` (x, y, theta in the map frame) with this scan."""
        self.pose = np.asarray(pose, dtype=float).copy()
        self.maps = ParticleMaps(1, self.maps.info)
        self._keyframes.clear()
        self.path_m = 0.0
        self.gated_matches = 0
        stats = UpdateStats(entropy=0.0, neff=1.0)
        stats.grown = self._register(scan)
        surface = self._surface(scan, scan.hits)
        self.wall_references = []
        self._learning = None
        self.reference_scans = 0
        self._average_reference(surface)
        self._keep(scan, surface)
        self.initialized = True
        self.updates = 1
        self._record(0)
        return stats

    def wants_still_scans(self) -> bool:
        """Whether ``observe_still`` would use another scan from the start pose."""
        return (self.updates == 1 and self.cfg.wall_std_rad > 0.0
                and self.reference_scans < self.cfg.wall_reference_scans)

    def observe_still(self, scan: PreparedScan) -> None:
        """Another scan taken at the start pose (the robot has not moved since ``start``):
        its walls' direction joins the reference's mean, up to ``wall_reference_scans``.
        One scan's direction is off by about a milliradian, and the reference's error turns
        the whole map (0.1 m at the far end of a 100 m corridor); the scans a robot takes
        while it stands at the start average it out."""
        if self.wants_still_scans():
            self._average_reference(self._surface(scan, scan.hits))

    def _average_reference(self, surface: np.ndarray) -> None:
        if self.cfg.wall_std_rad <= 0.0:
            return
        wall = scan_wall_axis(surface)
        if wall is None:
            return
        self.wall_references = [mean_direction(self.wall_reference, self.reference_scans,
                                               float(self.pose[2]) + wall.angle)]
        self.reference_scans += 1

    def update(self, odom_delta, scan: PreparedScan) -> UpdateStats:
        """The robot moved by ``odom_delta`` (dx, dy, dtheta in the previous robot frame,
        from odometry) and then took ``scan``."""
        if not self.initialized:
            raise RuntimeError("SubmapSlam.update() before start()")
        cfg = self.cfg
        delta = np.asarray(odom_delta, dtype=float)
        guess = np.asarray(compose(self.pose, delta), dtype=float)
        q = odometry_covariance(delta, float(self.pose[2]), cfg)
        info = np.linalg.inv(q)
        q_info = info.copy()
        rhs = np.zeros(3)
        stats = UpdateStats(neff=1.0)
        stats.odom_delta = delta.copy()
        surface = self._surface(scan, scan.hits)
        unknown_wall = None  # a matched scan's walls off every reference
        pts = _subsample(self._surface(scan, scan.match), cfg.match_points)
        if scan.usable and pts.shape[0] >= 10 and self._keyframes:
            field = self._field()
            best, score, cov, _ = correlative_match(
                field, pts, guess, cfg.window_m, cfg.window_rad, cfg.step_rad,
                cfg.match_sigma_m, seen_floor_share=0.1)
            stats.mean_score = float(score)
            stats.beams = int(pts.shape[0])
            d = best - guess
            d[2] = wrap_angle(d[2])
            scaled = cov * cfg.match_cov_scale
            gated = score >= cfg.min_score and cfg.match_gate > 0.0 and float(
                d @ np.linalg.solve(q + scaled, d)) > cfg.match_gate
            if gated:
                self.gated_matches += 1
            elif score >= cfg.min_score:
                stats.matched = 1
                ci = np.linalg.inv(scaled)
                info = info + ci
                rhs = rhs + ci @ d
                if self.wall_references:
                    wall = scan_wall_axis(surface)
                    # walls of two families a few degrees apart (a corner into a side
                    # off the others) fit a direction between them: neither used nor learned
                    if wall is not None and wall.disagreement <= 3.0 * cfg.wall_std_rad:
                        # the heading each reference implies; the one nearest the match's
                        meas = guess[2] + wrap_right_angle(
                            np.asarray(self.wall_references) - wall.angle - guess[2])
                        off = np.abs(wrap_angle(meas - best[2]))
                        near = int(np.argmin(off))
                        stats.wall_axis = wall.angle
                        if off[near] < cfg.wall_gate_rad:
                            w = cfg.wall_std_rad ** -2
                            info[2, 2] += w
                            rhs[2] += w * wrap_angle(float(meas[near]) - guess[2])
                            stats.wall_axis_used = True
                        else:
                            unknown_wall = wall.angle
        step = np.linalg.solve(info, rhs)
        new = guess + step
        if cfg.odom_chord:
            # the prediction's translation re-aimed by the fused turn instead of the
            # odometry's (the mean is linear in the prediction: shift it and add)
            moved = chord(delta, float(self.pose[2]), float(step[2]) + float(delta[2]))
            new = new + np.linalg.solve(info, q_info @ np.array(
                [self.pose[0] + moved[0] - guess[0], self.pose[1] + moved[1] - guess[1], 0.0]))
        new[2] = wrap_angle(new[2])
        if unknown_wall is not None and cfg.wall_learn_scans > 0:
            self._learn(float(new[2]) + unknown_wall)
        self.path_m += math.hypot(float(delta[0]), float(delta[1]))
        self.pose = new
        stats.entropy = gaussian_entropy(np.linalg.inv(info))
        stats.grown = self._register(scan)
        if scan.usable:
            self._keep(scan, surface)
        self._record(self.updates)
        self.updates += 1
        return stats

    def trajectory(self, updates: Optional[np.ndarray] = None,
                   particle: Optional[int] = None) -> np.ndarray:
        """The poses (map frame) at which the scans of the given updates were registered
        (0 = the first scan; default: all). ``particle`` is ignored (one pose)."""
        cols = np.arange(self.updates) if updates is None else np.asarray(updates)
        return self._history[cols].copy()

    def set_trajectory(self, updates: np.ndarray, poses: np.ndarray) -> None:
        """The poses at the given updates replaced (a map rebuilt from them)."""
        self._history[np.asarray(updates)] = np.asarray(poses, dtype=float)

    def restart(self, pose, maps: ParticleMaps) -> None:
        """Continue from a map rebuilt elsewhere (the pose graph's loop closure: a fresh
        one-particle ``maps``, taken over), at ``pose``; the submap's keyframes are dropped
        (their poses moved)."""
        self.maps = maps
        self.pose = np.asarray(pose, dtype=float).copy()
        self._keyframes.clear()

    # -- internals --

    def _learn(self, direction: float) -> None:
        """A matched scan's walls at map-frame ``direction`` [rad] (at the fused heading),
        off every reference: it joins the direction being learned if it agrees within
        ``wall_learn_tol_rad`` (else starts a new one); after ``wall_learn_scans`` scans
        their mean is a reference. A building's walls at another angle (a wing at 45
        degrees, a side a few degrees off) then hold the heading along them as the
        start's walls do elsewhere, instead of leaving it to the chain of matches (and
        the start's reference, a few degrees off them, cannot capture it once the chain
        has drifted that far)."""
        cfg = self.cfg
        refs = np.asarray(self.wall_references)
        if refs.size and np.min(np.abs(wrap_right_angle(refs - direction))) < cfg.wall_gate_rad:
            return
        if self._learning is None or abs(float(wrap_right_angle(
                direction - self._learning[0]))) > cfg.wall_learn_tol_rad:
            self._learning = (direction, 1)
        else:
            mean, count = self._learning
            self._learning = (mean_direction(mean, count, direction), count + 1)
        if self._learning[1] >= cfg.wall_learn_scans:
            self.wall_references.append(float(wrap_right_angle(self._learning[0])))
            self._learning = None

    def _surface(self, scan: PreparedScan, pts: np.ndarray) -> np.ndarray:
        """End points of ``scan`` (base frame) moved back to the surface, float64."""
        return _surface_points(np.asarray(scan.origin, dtype=float),
                               np.asarray(pts, dtype=float), self.hit_offset).astype(float)

    def _keep(self, scan: PreparedScan, surface: np.ndarray) -> None:
        """The scan (its ``surface`` points) as a keyframe of the submap at the current
        pose; keyframes beyond ``submap_m`` dropped."""
        behind = 3.0 * self.cfg.match_sigma_m  # the field's cap: a miss scores ~0 there
        self._keyframes.append((self.path_m, _transform(self.pose, surface),
                                _transform(self.pose, _seen_polygon(scan, behind))))
        while self._keyframes and self._keyframes[0][0] < self.path_m - self.cfg.submap_m:
            self._keyframes.popleft()

    def _field(self) -> LikelihoodField:
        cloud = np.vstack([pts for _, pts, _ in self._keyframes if pts.shape[0]]
                          or [self.pose[None, :2]])
        seen = [poly for _, _, poly in self._keyframes if len(poly) >= 3]
        return LikelihoodField(cloud, self.cfg.field_res_m, self.cfg.window_m + 1.0,
                               3.0 * self.cfg.match_sigma_m, seen)

    def _register(self, scan: PreparedScan) -> bool:
        return self.maps.grow_and_register(self.pose[None], scan, 2.0 * self.delta,
                                           self.grow_margin)

    def _record(self, row: int) -> None:
        if row >= self._history.shape[0]:
            grown = np.zeros((2 * row, 3))
            grown[:self._history.shape[0]] = self._history
            self._history = grown
        self._history[row] = self.pose
