"""Loop closure for the mapper: a pose graph of keyframes, scan-to-submap matching and a
sparse robust least-squares optimisation (no ROS imports).

The particle filter (``rbpf``) corrects the robot's pose only within its matcher's window
(``search_margin``, 0.5 m) and never moves the past: drift along a long loop stays in the
map. This module keeps, next to the filter, one keyframe per filter update:

* **node** k: the filter's best pose at update k (base frame in the map frame) and that
  update's ``PreparedScan`` (base frame; float32 copies);
* **sequential edge** k-1 -> k: on fresh ground the filter's own increment; where old
  keyframes are near (``_revisiting``: the filter's matcher may snap onto old parts of its
  map, and its increments then hold part of the loop correction) a filter-independent
  one, from matching scan k against a local submap of the previous ``local_keyframes``
  scans placed along the chain of edges, starting from the odometry increment;
* **loop edge** j -> k: when the robot is within ``search_radius_m`` of keyframes that lie
  more than ``min_travel_m`` back along the path, scan k is matched against a submap of those
  old keyframes' scans at their node poses: a correlative search (likelihood field from
  ``cv2.distanceTransform``, every (dx, dy, dtheta) of a grid scored at once) refined on a
  finer grid with bilinear lookups (both compiled: ``climb.grid_scores``,
  ``pose_scores``), scoring only the end points that land in space the old scans saw
  (``LikelihoodField``'s ``seen``; a match with fewer than ``min_seen_share`` of them
  there is rejected). It is accepted only if the matched share of the beams reaches
  ``min_score`` and the match is determined: the candidates' score-weighted covariance
  gives each position axis a std; axes above ``max_spread_m`` are left free (a
  featureless corridor fixes the lateral position and the heading, not the position along
  it), and a match with no fixed axis, or a heading std above ``max_spread_rad``, is
  rejected.

* **confirmation** (``loop_confirm``): an accepted match waits for the next accepted one;
  the two are added only if, optimised together, they cost the graph no more squared
  whitened error than a chi-square at ``confirm_sigmas`` above either alone (two right
  matches say the same; a wrong one, however confident, disagrees with the next);
* **heading measurement** of node k (``loop_wall_headings``): where the filter's wall-axis
  prior held on scan k (its walls within the gate of the first scan's directions), the
  filter's heading there, wrap(theta_k - heading_k) / ``wall_axis_std_rad``: the closure then
  corrects positions, not the headings the walls held.

With a new loop edge the graph is optimised (quadratic then Huber loss on whitened
residuals, sparse analytic Jacobian, node 0 fixed; ``loop_solver``: Gauss-Newton on the
sparse normal equations, or ``scipy.optimize.least_squares``' trust region). If the
optimisation moves any node by more than ``max_correction_m`` the loop edge is removed and
nothing changes (reported, so the node logs it); if it moves none by more than ``min_correction_m``
the edge is kept but the map is left as is; otherwise the node poses are replaced and the
caller rebuilds the map from the corrected keyframes (``rebuild_counts``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix, diags
from scipy.sparse.linalg import spsolve
from scipy.stats import chi2

from ascc_common.params import param
from ascc_common.pose2d import compose, relative, wrap_angle
from ascc_navigation.climb import grid_scores, pose_scores
from ascc_navigation.laser import PreparedScan


@dataclass
class LoopClosureConfig:
    """Loop-closure parameters (stand-in only; gmapping has none), read by the mapper node
    as private parameters with these names."""

    # off by default: on the corridor benchmark it did not yet improve the map (results)
    enabled: bool = param(False, "pose-graph loop closure on/off", "loop_closure")
    search_radius_m: float = param(3.0, "[m] old keyframes this close to the current pose "
                                   "are loop candidates", "loop_search_radius_m", gt=0.0)
    min_travel_m: float = param(10.0, "[m] candidates lie at least this far back along the "
                                "path", "loop_min_travel_m", ge=0.0)
    check_every_m: float = param(1.0, "[m] path between two loop searches",
                                 "loop_check_every_m", ge=0.0)
    window_m: float = param(1.0, "[m] loop match searches +- this in x and y",
                            "loop_window_m", gt=0.0)
    window_rad: float = param(0.15, "[rad] loop match searches +- this in heading",
                              "loop_window_rad", ge=0.0)
    min_score: float = param(0.8, "[share of the beams] a loop match must reach this",
                             "loop_min_score", gt=0.0, le=1.0)
    max_spread_m: float = param(0.15, "[m] a loop match's position std above which that "
                                "axis is left free (both: rejected)", "loop_max_spread_m",
                                gt=0.0)
    max_spread_rad: float = param(0.05, "[rad] a loop match's heading std above which it is "
                                  "rejected", "loop_max_spread_rad", gt=0.0)
    max_correction_m: float = param(1.5, "[m] a closure moving any keyframe further is "
                                    "rejected", "loop_max_correction_m", gt=0.0)
    min_correction_m: float = param(0.03, "[m] a closure moving no keyframe further leaves "
                                    "the map as is", "loop_min_correction_m", ge=0.0)
    # Opt-in: it rejected the corridor's wrong match (0.8 m off, an 8 cm std claimed), but
    # in test_corridor_loop's run one of its closures raised the keyframes' mean error by
    # 1.1 cm (docs/results/ascc_navigation.md, "Two loop matches that agree").
    confirm: bool = param(False, "a loop match closes only with a second one that agrees "
                          "with it", "loop_confirm")
    # The filter's wall-axis prior (rbpf's wall_axis_std_rad) holds its heading to the first
    # scan's walls wherever they show; without that in the graph a closure spreads its
    # correction over the headings too, and turns sides that the prior had held. The graph
    # takes the filter's own heading there, not the walls' direction: the filter's
    # positions agree with its headings, and a graph turned onto the walls swings them
    # (docs/results/ascc_navigation.md, "A direct solve for the graph"). No effect with the
    # prior off.
    wall_headings: bool = param(True, "keyframes where the wall-axis prior held keep the "
                                "filter's heading there as a measurement in the graph",
                                "loop_wall_headings")
    # "direct": Gauss-Newton on the sparse normal equations (SuperLU), to the minimum, tens
    # of milliseconds on the corridor's 820 keyframes. "trust_region": scipy's least_squares
    # (trust region, LSMR), 20 evaluations for each loss, ~0.5-0.8 s there; it stops before
    # the minimum, which keeps the filter's shape where the graph's headings are loose
    # (the prior off). docs/results/ascc_navigation.md, "A direct solve for the graph".
    solver: str = param("direct", "how the graph is optimised: direct (sparse "
                        "Gauss-Newton to the minimum) or trust_region (least_squares, "
                        "stops after 20 evaluations)", "loop_solver",
                        choices=("trust_region", "direct"))
    # Front end and edge uncertainties (not ROS parameters).
    # sequential match: pull of the position to the odometry's (see correlative_match's
    # prior); none on the heading, which the walls fix and the odometry's drifts
    seq_prior_m: float = 0.02         # [m]
    revisit_margin_m: float = 2.0     # [m] see PoseGraph._revisiting
    local_keyframes: int = 20          # scans in the local submap of a sequential match
    submap_radius_m: float = 4.0      # [m] old keyframes within this of the anchor: submap
    coarse_step_m: float = 0.05       # [m] = the loop search's likelihood field cell
    fine_step_m: float = 0.02         # [m] field cell of sequential matches and refinement
    coarse_step_rad: float = 0.01     # [rad]
    match_sigma_m: float = 0.05       # [m] end-point score std
    coarse_points: int = 120          # of them scored in the loop search's coarse grid
    # a loop match scores only the scan's end points that land in space the submap's scans
    # saw (their free-space polygons, ``LikelihoodField``'s ``seen``), but over at least
    # seen_floor_share of all; a match at which fewer than min_seen_share of them land
    # there is rejected (it rests on too little). End points past the submap's view
    # counted as misses pulled a corridor match 0.7 m along it, with a claimed 0.13 m std
    # (docs/results)
    seen_only: bool = True
    seen_floor_share: float = 0.1
    min_seen_share: float = 0.5
    max_points: int = 400             # matched end points per scan (evenly subsampled)
    # sequential edges: "geometry" = the front end's increment where its scan constrains
    # it, the odometry's where not (``PoseGraph._geometry_edges``); "isotropic" = the
    # front end's increment with the fixed stds seq_sigma_* (the default: "geometry" made
    # test_corridor_loop's trajectory worse, see docs/results)
    seq_model: str = "isotropic"
    # node poses before a loop search: "particle" = re-anchored on the best particle's
    # trajectory (``PoseGraph.trajectory_source``), "best_pose" = each update's best pose
    anchor: str = "best_pose"
    seq_sigma_xy: Tuple[float, float] = (0.01, 0.03)     # [m] + [m/m] std of a sequential edge
    seq_sigma_theta: Tuple[float, float] = (0.005, 0.01)  # [rad] + [rad/m]
    point_sigma_m: float = 0.05       # [m] std of one surface point (scan information)
    info_points: int = 120            # surface points counted in the scan information
    # wheel odometry of an increment of length d: std a + b d along the motion, across it
    # and in heading (the Create's encoders: good in distance, poor in heading)
    odom_sigma_along: Tuple[float, float] = (0.002, 0.01)   # [m] + [m/m]
    odom_sigma_cross: Tuple[float, float] = (0.01, 0.05)    # [m] + [m/m]
    odom_sigma_theta: Tuple[float, float] = (0.01, 0.05)    # [rad] + [rad/m]
    loop_sigma_xy: float = 0.05       # [m] std of a loop edge
    loop_sigma_theta: float = 0.02    # [rad]
    # two loop matches agree if adding the second to the graph with the first costs no
    # more than a chi-square of its fixed axes at the probability of this many stds
    # (``loop_confirm``)
    confirm_sigmas: float = 3.0
    # after a pair closed, one match's position information in the directions the other
    # left free (a corridor match that fixes the position along it, paired with one that
    # does not; the newer's if both have such) waits for the next match to confirm it,
    # instead of being dropped
    confirm_rest: bool = True


class LoopResult:
    """What ``PoseGraph.add_keyframe`` did. ``status``: ``none`` (no loop search or no
    candidate), ``rejected`` (``reason`` says why), ``pending`` (an accepted match waits
    for a second one, ``loop_confirm``), ``kept`` (loop edges added, correction below
    ``min_correction_m``), ``closed`` (poses corrected: rebuild the map)."""

    __slots__ = ("status", "reason", "correction_m", "anchor", "score")

    def __init__(self, status: str = "none", reason: str = "", correction_m: float = 0.0,
                 anchor: int = -1, score: float = 0.0):
        self.status = status
        self.reason = reason
        self.correction_m = correction_m
        self.anchor = anchor
        self.score = score

    def __repr__(self) -> str:
        return "LoopResult(%s, %s)" % (self.status, self.reason)


class LikelihoodField:
    """Distance [m] from each cell of a window to the nearest end point of a set of points
    (world frame), capped; scored by nearest-cell gathers (coarse search) or bilinear
    interpolation (refinement), both in ``climb`` (``grid_scores``, ``pose_scores``).

    ``seen`` (polygons, world frame; ``_seen_polygon`` of the scans the points came from):
    the cells inside them are the space the points' scans saw (``self.seen``, 1 there, 0
    elsewhere; None without polygons: everywhere). A match then scores only the end points
    that land there: an end point beyond what the submap's scans saw (past their reach or
    outside their field of view) tells nothing about the pose, but counted as a miss it
    pulls the match towards more overlap, along a corridor as far as the window lets it."""

    def __init__(self, points: np.ndarray, resolution: float, margin_m: float, cap_m: float,
                 seen: Optional[List[np.ndarray]] = None):
        self.res = float(resolution)
        lo = points.min(axis=0) - margin_m
        hi = points.max(axis=0) + margin_m
        self.x0, self.y0 = float(lo[0]), float(lo[1])
        self.w = int(math.ceil((hi[0] - lo[0]) / self.res)) + 1
        self.h = int(math.ceil((hi[1] - lo[1]) / self.res)) + 1
        img = np.full((self.h, self.w), 255, dtype=np.uint8)
        ix = ((points[:, 0] - self.x0) / self.res).astype(np.int64)
        iy = ((points[:, 1] - self.y0) / self.res).astype(np.int64)
        img[iy, ix] = 0
        dist = cv2.distanceTransform(img, cv2.DIST_L2, cv2.DIST_MASK_5)
        dist *= np.float32(self.res)
        np.minimum(dist, np.float32(cap_m), out=dist)
        self.dist = dist
        self.seen = None
        if seen is not None:
            # vertices in pixel coordinates (cell centres at integers), 4 fractional bits
            origin = np.array([self.x0, self.y0])
            polys = [np.round(((np.asarray(p, dtype=float) - origin) / self.res - 0.5) * 16.0)
                     .astype(np.int32) for p in seen if len(p) >= 3]
            mask = np.zeros((self.h, self.w), np.float32)
            for poly in polys:
                # one call per polygon: fillPoly's even-odd rule would leave the space two
                # (or any even number of) scans saw unfilled
                cv2.fillPoly(mask, [poly], 1.0, lineType=cv2.LINE_8, shift=4)
            self.seen = mask

    def seen_share(self, pose: np.ndarray, pts: np.ndarray) -> float:
        """Share of the base-frame points ``pts`` that land in seen space at ``pose`` (1
        without ``seen``)."""
        if self.seen is None or pts.shape[0] == 0:
            return 1.0
        w = _transform(pose, pts)
        ix = np.floor((w[:, 0] - self.x0) / self.res).astype(np.int64)
        iy = np.floor((w[:, 1] - self.y0) / self.res).astype(np.int64)
        inside = (ix >= 0) & (ix < self.w) & (iy >= 0) & (iy < self.h)
        return float(self.seen[iy[inside], ix[inside]].sum()) / pts.shape[0]


def _transform(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack([pose[0] + c * pts[:, 0] - s * pts[:, 1],
                            pose[1] + s * pts[:, 0] + c * pts[:, 1]])


def correlative_match(field: LikelihoodField, pts: np.ndarray, guess: np.ndarray,
                      window_m: float, window_rad: float, step_rad: float, sigma: float,
                      prior: Optional[np.ndarray] = None, coarse_points: int = 0,
                      seen_floor_share: float = 0.1
                      ) -> Tuple[np.ndarray, float, np.ndarray, bool]:
    """Best pose of the base-frame points ``pts`` (M, 2) in ``field`` within +-window_m,
    +-window_rad of ``guess``: every candidate of a grid (field cells in x, y; ``step_rad``
    in heading) scored at once by nearest-cell gathers, then a finer grid around the best
    with bilinear lookups. Score: mean over points of exp(-d^2 / 2 sigma^2) (1 = perfect).
    ``coarse_points`` > 0: the coarse grid scores only that many of the points (evenly
    spread), the refinement all.
    Returns (pose, score, cov, at_edge): ``cov`` is the covariance (x, y, theta; map frame)
    of the coarse candidates weighted by exp(M (score - best score)), M the points scored
    (a score the way a likelihood would be, as Olson's correlative matcher does), plus the
    grid's own discretisation: large along the walls of a featureless corridor, where the
    scan slides. ``at_edge``: the best coarse candidate lies on the window's border in
    heading, or in x or y (the true pose may be beyond it).
    ``prior`` (w_x, w_y, w_theta): the search maximises score - sum w_k (pose_k - guess_k)^2
    instead (a pull to the guess, as the filter's ``motion_prior``: a scan in a featureless
    corridor does not slide along it); the returned score is the plain one.
    A field with ``seen`` space: the mean is over the points that land in it, but over at
    least ``seen_floor_share`` of all (a candidate with almost none there does not score
    high on a handful)."""
    all_pts = pts
    if coarse_points > 0:
        pts = _subsample(pts, coarse_points)
    res = field.res
    k_xy = max(int(round(window_m / res)), 0)
    k_th = max(int(round(window_rad / step_rad)), 0) if step_rad > 0 else 0
    thetas = guess[2] + step_rad * np.arange(-k_th, k_th + 1)
    c = np.cos(thetas)[:, None]
    s = np.sin(thetas)[:, None]
    # end points for every heading, relative to the guess position, in cells
    px = (guess[0] - field.x0 + c * pts[:, 0] - s * pts[:, 1]) / res
    py = (guess[1] - field.y0 + s * pts[:, 0] + c * pts[:, 1]) / res
    ix = np.floor(px).astype(np.int64)  # (T, M)
    iy = np.floor(py).astype(np.int64)
    offs = np.arange(-k_xy, k_xy + 1)
    # pad the field so every shifted index stays inside
    pad = k_xy + 1
    padded = np.pad(field.dist, pad, mode="edge")
    lut = np.exp(-0.5 * (padded.astype(np.float32) / np.float32(sigma)) ** 2)
    seen = None
    if field.seen is not None:
        seen = np.pad(field.seen, pad, mode="constant")
        lut *= seen
    wp = padded.shape[1]
    ix = np.clip(ix, 0, field.w - 1) + pad
    iy = np.clip(iy, 0, field.h - 1) + pad
    base = iy * wp + ix  # (T, M)
    shift = (offs[:, None] * wp + offs[None, :]).ravel()  # (dy, dx) flattened: (K*K,)
    scores = grid_scores(lut.ravel(), base, shift, seen, seen_floor_share)  # (T, K*K)
    objective = scores
    if prior is not None:
        dxy = (offs * res) ** 2
        pen = prior[0] * dxy[None, :] + prior[1] * dxy[:, None]  # [dy, dx]
        objective = scores - (pen.ravel()[None, :]
                              + prior[2] * (thetas - guess[2])[:, None] ** 2).astype(np.float32)
    t_best, j_best = np.unravel_index(int(np.argmax(objective)), scores.shape)
    dy_best, dx_best = divmod(int(j_best), offs.size)
    best = np.array([guess[0] + offs[dx_best] * res, guess[1] + offs[dy_best] * res,
                     thetas[t_best]])
    weight = np.exp(pts.shape[0] * (scores.astype(float) - float(scores[t_best, j_best])))
    weight /= weight.sum()
    gy, gx = np.divmod(np.arange(shift.size), offs.size)
    cand = np.stack(np.broadcast_arrays(offs[gx][None, :] * res, offs[gy][None, :] * res,
                                        (thetas - guess[2])[:, None]), axis=-1).reshape(-1, 3)
    w = weight.reshape(-1)
    mean = w @ cand
    dev = cand - mean
    cov = (dev * w[:, None]).T @ dev + np.diag([res * res / 12.0] * 2
                                               + [step_rad * step_rad / 12.0])
    at_edge = (k_xy > 0 and max(abs(offs[dx_best]), abs(offs[dy_best])) == k_xy) or (
        k_th > 0 and abs(int(t_best) - k_th) == k_th)
    best, score = _refine(field, all_pts, best, res, step_rad, sigma, guess, prior,
                          seen_floor_share)
    return best, score, cov, bool(at_edge)


def _refine(field: LikelihoodField, pts: np.ndarray, start: np.ndarray, step_m: float,
            step_rad: float, sigma: float, guess: np.ndarray,
            prior: Optional[np.ndarray], seen_floor_share: float = 0.1
            ) -> Tuple[np.ndarray, float]:
    """Two finer grids (a fifth of the coarse steps, then a fifth again) around ``start``,
    bilinear scores (and the prior's pull to ``guess``)."""
    best = start.copy()
    score = 0.0
    for level in (1, 2):
        sm = step_m / 5 ** level
        sr = step_rad / 5 ** level
        o = np.arange(-3, 4)
        dx, dy, dt = np.meshgrid(o * sm, o * sm, o * sr, indexing="ij")
        cand = best + np.column_stack([dx.ravel(), dy.ravel(), dt.ravel()])
        sc = pose_scores(field.dist, field.x0, field.y0, field.res, cand, pts, sigma,
                         field.seen, seen_floor_share)
        obj = sc if prior is None else sc - ((cand - guess) ** 2 * prior).sum(axis=1)
        j = int(np.argmax(obj))
        best = cand[j]
        score = float(sc[j])
    best[2] = float(wrap_angle(best[2]))
    return best, score


def _sqrt_info(w) -> np.ndarray:
    """A 3x3 square-root information matrix from 1/std per axis or a 3x3 matrix."""
    w = np.asarray(w, dtype=float)
    return np.diag(w) if w.ndim == 1 else w


def _fixes_position(sqrt_info: np.ndarray) -> bool:
    """Whether a square-root information matrix holds any position information."""
    return bool(np.abs(np.asarray(sqrt_info)[:, :2]).max() > 1e-9)


def _subsample(pts: np.ndarray, n: int) -> np.ndarray:
    if pts.shape[0] <= n:
        return pts
    return pts[np.linspace(0, pts.shape[0] - 1, n).round().astype(np.int64)]


def _surface_points(scan_origin: np.ndarray, pts: np.ndarray, hit_offset: float) -> np.ndarray:
    """End points moved back by ``hit_offset`` along their beams (``prepare_scan`` puts them
    behind the surface for the cell rule; point-to-point matching wants the surface)."""
    rel = pts - scan_origin
    r = np.hypot(rel[:, 0], rel[:, 1])
    scale = np.maximum(r - hit_offset, 0.0) / np.maximum(r, 1e-9)
    return (scan_origin + rel * scale[:, None]).astype(np.float32)


def scan_information(points: np.ndarray, sigma: float, max_points: int,
                     max_gap_m: float = 0.3) -> np.ndarray:
    """3x3 information (x, y, theta; the scan's frame) of aligning the surface points
    ``points`` (base frame, in beam order) point-to-line, as ICP's Fisher information
    (Censi 2007): sum of J J^T / sigma^2, J = (n_x, n_y, n . perp(p)), n the surface normal
    from the neighbouring points (points whose neighbours lie further than ``max_gap_m``
    are left out), over at most ``max_points`` evenly spread points. Halved: an increment
    between two keyframes carries the errors of both scans. Along a featureless corridor
    every normal is across it: no information along it."""
    pts = np.asarray(points, dtype=float)
    if pts.shape[0] < 3:
        return np.zeros((3, 3))
    tangent = pts[2:] - pts[:-2]
    gap = np.maximum(np.hypot(*(pts[1:-1] - pts[:-2]).T), np.hypot(*(pts[2:] - pts[1:-1]).T))
    length = np.hypot(tangent[:, 0], tangent[:, 1])
    ok = (gap <= max_gap_m) & (length > 1e-6)
    if not ok.any():
        return np.zeros((3, 3))
    p = pts[1:-1][ok]
    n = np.column_stack([-tangent[ok, 1], tangent[ok, 0]]) / length[ok, None]
    if p.shape[0] > max_points:
        keep = np.linspace(0, p.shape[0] - 1, max_points).round().astype(np.int64)
        p, n = p[keep], n[keep]
    jac = np.column_stack([n, n[:, 0] * -p[:, 1] + n[:, 1] * p[:, 0]])
    return 0.5 * (jac.T @ jac) / (sigma * sigma)


def _seen_polygon(scan: PreparedScan, behind_m: float) -> np.ndarray:
    """The space ``scan`` saw (base frame): its free-space polygon with each vertex short of
    ``max_urange`` (a beam that hit something) moved ``behind_m`` further along its beam,
    past the surface and the free space's pull-back, but not sideways: the walls and
    what lies just behind them (where a misplaced end point lands) belong to it, space
    beside the field of view or past the reach does not."""
    poly = scan.free_polygon.astype(float)
    rel = poly - scan.origin.astype(float)
    r = np.hypot(rel[:, 0], rel[:, 1])
    hit = (r > 1e-6) & (r < scan.max_urange - 1e-3)
    scale = np.where(hit, (r + behind_m) / np.maximum(r, 1e-6), 1.0)
    return scan.origin.astype(float) + rel * scale[:, None]


def _compact(scan: PreparedScan) -> PreparedScan:
    """A float32 copy of the parts of a scan the graph needs (hits, match, free polygon)."""
    f = np.float32
    return PreparedScan(scan.origin.astype(f), scan.hits.astype(f), scan.match.astype(f),
                        scan.match_range.astype(f), scan.max_urange,
                        scan.free_polygon.astype(f), scan.n_beams, scan.n_hits,
                        scan.n_free_only)


class PoseGraph:
    """Keyframes, edges and loop closing (see the module doc). Feed ``add_keyframe`` after
    every filter update; ``poses`` are the node estimates (map frame)."""

    def __init__(self, cfg: LoopClosureConfig, hit_offset: float = 0.0):
        self.cfg = cfg
        self.hit_offset = hit_offset  # [m] prepare_scan's hit_offset of the scans fed
        self.points: List[np.ndarray] = []  # surface end points per keyframe (base frame)
        self.match_points: List[np.ndarray] = []  # the same of the matched beams
        self.poses = np.zeros((0, 3))
        self.chain = np.zeros((0, 3))        # front-end chain (sequential edges composed)
        self.path_m = np.zeros(0)            # path length along the chain at each node
        self.scans: List[PreparedScan] = []
        self.edges: List[Tuple[int, int, np.ndarray, np.ndarray]] = []  # i, j, z, 1/sigma
        self.loop_edges = 0
        self.closures = 0
        self.odometry_edges = 0  # sequential edges from odometry alone (nothing to match)
        self._next_check_m = 0.0
        self._odom = np.zeros((0, 3))            # odometry increment into each node
        self._odom_info = np.zeros((0, 3, 3))    # its information (previous node's frame)
        self._scan_info = np.zeros((0, 3, 3))    # each node's scan information (own frame)
        self._filter_edges: List[int] = []       # edges taken from the filter's increments
        # per keyframe the filter's heading where its wall-axis prior held, else NaN; the
        # std of that prior (the filter's wall_axis_std_rad; 0: no heading measurements)
        self.headings = np.zeros(0)
        self.heading_std_rad = 0.0
        # an accepted loop match waiting for a second one (``loop_confirm``):
        # (i, j, z, sqrt_info, where, score)
        self.pending: Optional[tuple] = None
        self.last_cost = 0.0  # sum of squared whitened residuals after the last optimise()
        # the filter's trajectory at the keyframes (``reanchor`` before a loop search), or None
        self.trajectory_source: Optional[Callable[[], np.ndarray]] = None

    def __len__(self) -> int:
        return self.poses.shape[0]

    # -- front end -------------------------------------------------------------------
    def add_keyframe(self, pose, scan: PreparedScan, odom_delta,
                     walls_held: bool = False) -> LoopResult:
        """Add the filter's pose ``pose`` (map frame) for ``scan``, taken after the odometry
        motion ``odom_delta`` (previous keyframe's robot frame); search for a loop if due.
        ``walls_held``: the filter's wall-axis prior held on this scan, so its heading is
        kept as a heading measurement (``loop_wall_headings``)."""
        cfg = self.cfg
        pose = np.asarray(pose, dtype=float)
        self.headings = np.append(self.headings, pose[2] if walls_held else np.nan)
        self.points.append(_surface_points(scan.origin, scan.hits, self.hit_offset))
        self.match_points.append(_surface_points(scan.origin, scan.match, self.hit_offset))
        scan = _compact(scan)
        k = len(self)
        odom_delta = np.zeros(3) if k == 0 else np.asarray(odom_delta, dtype=float)
        self._odom = np.vstack([self._odom, odom_delta])
        self._odom_info = np.concatenate([self._odom_info,
                                          self._odometry_information(odom_delta)[None]])
        self._scan_info = np.concatenate([self._scan_info, scan_information(
            self.points[-1], cfg.point_sigma_m, cfg.info_points)[None]])
        if k == 0:
            chain_pose, travelled = pose.copy(), 0.0
        else:
            if self._revisiting(pose, k):
                z = self._sequential_edge(scan, np.asarray(odom_delta, dtype=float))
            else:  # fresh ground: the filter's own increment (its map is consistent here)
                z = relative(self.poses[-1], pose)
                self._filter_edges.append(len(self.edges))
            if cfg.seq_model == "geometry":
                zs, ws = self._geometry_edges(np.array([k]), z[None])
                z, sqrt_info = zs[0], ws[0]
            else:
                d = math.hypot(z[0], z[1])
                sqrt_info = _sqrt_info(1.0 / np.array(
                    [cfg.seq_sigma_xy[0] + cfg.seq_sigma_xy[1] * d] * 2
                    + [cfg.seq_sigma_theta[0] + cfg.seq_sigma_theta[1] * d]))
            d = math.hypot(z[0], z[1])
            self.edges.append((k - 1, k, z, sqrt_info))
            chain_pose = compose(self.chain[-1], z)
            travelled = float(self.path_m[-1]) + d
        self.poses = np.vstack([self.poses, pose])
        self.chain = np.vstack([self.chain, chain_pose])
        self.path_m = np.append(self.path_m, travelled)
        self.scans.append(scan)
        if not cfg.enabled or k == 0 or travelled < self._next_check_m:
            return LoopResult()
        return self._search_loop(k)

    def _odometry_information(self, odom_delta: np.ndarray) -> np.ndarray:
        """Information (previous keyframe's frame) of the odometry increment ``odom_delta``:
        std a + b d along the motion, across it and in heading (``odom_sigma_*``)."""
        cfg = self.cfg
        d = math.hypot(odom_delta[0], odom_delta[1])
        heading = math.atan2(odom_delta[1], odom_delta[0]) if d > 1e-6 else 0.0
        ch, sh = math.cos(heading), math.sin(heading)
        rot = np.array([[ch, -sh, 0.0], [sh, ch, 0.0], [0.0, 0.0, 1.0]])  # motion frame
        var = np.array([cfg.odom_sigma_along[0] + cfg.odom_sigma_along[1] * d,
                        cfg.odom_sigma_cross[0] + cfg.odom_sigma_cross[1] * d,
                        cfg.odom_sigma_theta[0] + cfg.odom_sigma_theta[1] * d]) ** 2
        return rot @ np.diag(1.0 / var) @ rot.T

    def _geometry_edges(self, nodes: np.ndarray, z_scan: np.ndarray
                        ) -> Tuple[np.ndarray, np.ndarray]:
        """Sequential edges into ``nodes`` (k-1 -> k) from the front end's increments
        ``z_scan`` where keyframe k's scan constrains them (its surface geometry,
        ``scan_information``) and the odometry's increments where it does not (along a
        featureless corridor the filter's estimate is the odometry's plus its own sampling
        noise), all at once: (z, sqrt_info) stacks."""
        c, s = np.cos(z_scan[:, 2]), np.sin(z_scan[:, 2])
        rot = np.zeros((nodes.size, 3, 3))
        rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1] = c, -s, s, c
        rot[:, 2, 2] = 1.0
        info_scan = rot @ self._scan_info[nodes] @ rot.transpose(0, 2, 1)  # into frame k-1
        info_odom = self._odom_info[nodes]
        info = info_scan + info_odom
        d = self._odom[nodes] - z_scan
        d[:, 2] = wrap_angle(d[:, 2])
        z = z_scan + np.linalg.solve(info, (info_odom @ d[:, :, None]))[:, :, 0]
        z[:, 2] = wrap_angle(z[:, 2])
        return z, np.linalg.cholesky(info).transpose(0, 2, 1)

    def reanchor(self, poses: np.ndarray) -> None:
        """Replace the node poses with ``poses`` (the filter's trajectory of its best
        particle: the one its map was built from, whose increments do not jump between
        particles as the best pose of each update does) and recompute the sequential
        edges taken from the filter from them."""
        poses = np.asarray(poses, dtype=float)
        if poses.shape != self.poses.shape:
            raise ValueError("reanchor: %s poses for %d keyframes" % (poses.shape, len(self)))
        self.poses = poses.copy()
        idx = np.array(self._filter_edges, dtype=np.int64)
        if idx.size == 0:
            return
        nodes = np.array([self.edges[e][1] for e in idx])
        z_scan = relative(poses[nodes - 1], poses[nodes])
        if self.cfg.seq_model == "geometry":
            z, w = self._geometry_edges(nodes, z_scan)
        else:
            z, w = z_scan, [self.edges[e][3] for e in idx]
        for n, e in enumerate(idx):
            self.edges[e] = (int(nodes[n]) - 1, int(nodes[n]), z[n], w[n])

    def _revisiting(self, pose: np.ndarray, k: int) -> bool:
        """Whether keyframes far back along the path (``min_travel_m``) lie within the
        submap radius plus the laser's reach of ``pose``: then the filter's matcher can see
        old parts of its map and its increments may contain a (partial) loop correction."""
        old = self.path_m[:k] <= self.path_m[k - 1] - self.cfg.min_travel_m
        if not old.any():
            return False
        gap = np.hypot(self.poses[:k][old, 0] - pose[0], self.poses[:k][old, 1] - pose[1])
        return bool(gap.min() <= self.cfg.submap_radius_m + self.cfg.revisit_margin_m)

    def _sequential_edge(self, scan: PreparedScan, odom_delta: np.ndarray) -> np.ndarray:
        """Motion from the previous keyframe to this one: scan matched against the last
        ``local_keyframes`` scans placed along the chain; the odometry if nothing to match."""
        cfg = self.cfg
        # beams reaching past what the previous scan could see would pull the pose back
        # onto the end of the mapped walls (as in the filter: ``new_area_margin``)
        reach = scan.max_urange - math.hypot(odom_delta[0], odom_delta[1]) - 0.1
        pts = _subsample(self.match_points[-1][scan.match_range <= reach].astype(float),
                         cfg.max_points)
        first = max(0, len(self) - cfg.local_keyframes)
        local = [_transform(self.chain[i], self.points[i].astype(float))
                 for i in range(first, len(self)) if self.points[i].shape[0]]
        if pts.shape[0] < 10 or not local:
            self.odometry_edges += 1
            return odom_delta.copy()
        field = LikelihoodField(np.vstack(local), cfg.fine_step_m, 1.0, 3.0 * cfg.match_sigma_m)
        guess = compose(self.chain[-1], odom_delta)
        # pull to the odometry's position: one point's score per seq_prior_m squared
        prior = np.array([cfg.seq_prior_m ** -2, cfg.seq_prior_m ** -2, 0.0]) / pts.shape[0]
        best, score, _, _ = correlative_match(field, pts, guess, 0.1, 0.04, cfg.coarse_step_rad,
                                           cfg.match_sigma_m, prior=prior)
        if score < 0.3:  # the local submap does not see what this scan sees: trust odometry
            self.odometry_edges += 1
            return odom_delta.copy()
        return relative(self.chain[-1], best)

    def _search_loop(self, k: int) -> LoopResult:
        cfg = self.cfg
        self._next_check_m = float(self.path_m[k]) + cfg.check_every_m
        old = np.nonzero(self.path_m[:k] <= self.path_m[k] - cfg.min_travel_m)[0]
        if old.size == 0:
            return LoopResult()
        if self.cfg.anchor == "particle" and self.trajectory_source is not None:
            self.reanchor(self.trajectory_source())
        gap = np.hypot(self.poses[old, 0] - self.poses[k, 0],
                       self.poses[old, 1] - self.poses[k, 1])
        if gap.min() > cfg.search_radius_m:
            return LoopResult()
        anchor = int(old[np.argmin(gap)])
        near = old[np.hypot(self.poses[old, 0] - self.poses[anchor, 0],
                            self.poses[old, 1] - self.poses[anchor, 1]) <= cfg.submap_radius_m]
        with_points = [i for i in near if self.points[i].shape[0]]
        cloud = [_transform(self.poses[i], self.points[i].astype(float)) for i in with_points]
        pts = _subsample(self.match_points[k].astype(float), cfg.max_points)
        if not cloud or pts.shape[0] < 10:
            return LoopResult()
        seen = None
        if cfg.seen_only:
            behind = 3.0 * cfg.match_sigma_m  # the field's cap: a miss scores ~0 there
            seen = [_transform(self.poses[i], _seen_polygon(self.scans[i], behind))
                    for i in with_points]
        field = LikelihoodField(np.vstack(cloud), cfg.coarse_step_m,
                                cfg.window_m + cfg.submap_radius_m + 1.0,
                                3.0 * cfg.match_sigma_m, seen)
        best, score, cov, at_edge = correlative_match(
            field, pts, self.poses[k], cfg.window_m, cfg.window_rad, cfg.coarse_step_rad,
            cfg.match_sigma_m, coarse_points=cfg.coarse_points,
            seen_floor_share=cfg.seen_floor_share)
        where = "keyframe %d (%.1f m back) near (%.1f, %.1f)" % (
            anchor, self.path_m[k] - self.path_m[anchor], self.poses[anchor, 0],
            self.poses[anchor, 1])
        if score < cfg.min_score:
            return LoopResult("rejected", "loop candidate %s: match score %.2f below "
                              "loop_min_score %.2f" % (where, score, cfg.min_score),
                              anchor=anchor, score=score)
        if field.seen is not None:
            share = field.seen_share(best, pts)
            if share < cfg.min_seen_share:
                return LoopResult("rejected", "loop candidate %s: the submap saw only %.0f %% "
                                  "of the scan's end points at the match (less than %.0f %%)"
                                  % (where, 100.0 * share, 100.0 * cfg.min_seen_share),
                                  anchor=anchor, score=score)
        # position uncertainty in the anchor's frame (the loop edge's), its principal axes
        c, s = math.cos(self.poses[anchor, 2]), math.sin(self.poses[anchor, 2])
        rot = np.array([[c, s], [-s, c]])
        eig, axes = np.linalg.eigh(rot @ cov[:2, :2] @ rot.T)
        std = np.sqrt(np.maximum(eig, 0.0))
        std_theta = math.sqrt(cov[2, 2])
        fixed = std <= cfg.max_spread_m
        if not fixed.any() or std_theta > cfg.max_spread_rad:
            return LoopResult("rejected", "loop candidate %s: ambiguous match (position std "
                              "%.2f / %.2f m, heading std %.3f rad; loop_max_spread_m %.2f)"
                              % (where, std[0], std[1], std_theta, cfg.max_spread_m),
                              anchor=anchor, score=score)
        if at_edge and fixed.all():
            return LoopResult("rejected", "loop candidate %s: best match on the border of the "
                              "search window (loop_window_m %.2f, loop_window_rad %.2f)"
                              % (where, cfg.window_m, cfg.window_rad), anchor=anchor,
                              score=score)
        # square-root information: the well-determined axes only (a corridor's match fixes
        # the lateral position and the heading, not the position along it)
        sqrt_info = np.zeros((3, 3))
        for a in np.nonzero(fixed)[0]:
            sqrt_info[a, :2] = axes[:, a] / max(std[a], cfg.loop_sigma_xy)
        sqrt_info[2, 2] = 1.0 / max(std_theta, cfg.loop_sigma_theta)
        z = relative(self.poses[anchor], best)
        return self.propose_loop(anchor, k, z, sqrt_info, where, score)

    def propose_loop(self, i: int, j: int, z, sqrt_info, where: str = "",
                     score: float = 0.0) -> LoopResult:
        """An accepted loop match i -> j. Without ``loop_confirm`` it closes at once
        (``close_loop``). With it, the first match waits; the next one is optimised together
        with it, and both close only if the pair adds no more squared whitened error to the
        graph than a chi-square at ``confirm_sigmas`` above either alone. A pair that
        disagrees is dropped but for the newer match, which waits for the next. (A match
        can be wrong and still pass the score and spread tests: along a corridor a match
        0.8 m off claimed an 8 cm std.) Each of the two keeps its position information
        only in the directions the other also fixes (``_confirmed_axes``): a match that
        fixes the position along a corridor, beside one that leaves it free, is confirmed
        across the corridor only, and closes only that."""
        where = where or "keyframes %d -> %d" % (i, j)
        edge = (i, j, np.asarray(z, dtype=float), _sqrt_info(sqrt_info), where, score, False)
        if not self.cfg.confirm:
            return self.close_loop(*edge[:6])
        full = first_full = edge
        first, self.pending = self.pending, edge
        if first is not None:
            first_full = first
            first, edge = self._confirmed_axes(first, edge), self._confirmed_axes(edge, first)
            if first_full[6] and not _fixes_position(first[3]):
                first, edge = None, full  # a rest of an earlier match this one cannot confirm
        if first is None:
            return LoopResult("pending", "loop match with %s (score %.2f) waits for a second "
                              "one to agree" % (where, score), anchor=i, score=score)
        # the cost of the two together above the cost of either alone: small if they say
        # the same, about their disagreement squared over the stds of the short paths
        # between their ends if not (however much a long loop could absorb of either)
        both, optimised = self._cost_with([first, edge])
        added = both - max(self._cost_with([first])[0], self._cost_with([edge])[0])
        dof = min(np.linalg.matrix_rank(first[3]), np.linalg.matrix_rank(edge[3]))
        bound = chi2.ppf(math.erf(self.cfg.confirm_sigmas / math.sqrt(2.0)), dof)
        if added > bound:
            return LoopResult("rejected", "loop matches with %s and with %s disagree (together "
                              "they add %.1f to the graph's squared error, more than %.1f); "
                              "the second waits for another" % (first[4], where, added, bound),
                              anchor=i, score=score)
        self.pending = None
        # what one match fixes and the other left free: the newer's, else the older's
        # (in the frames the pair was tested in)
        rest = self._unconfirmed(full, first_full)
        if not _fixes_position(rest[3]):
            rest = self._unconfirmed(first_full, full)
        result = self._close([first, edge], "%s and %s" % (first[4], where), score, optimised)
        if result.status != "rejected" and self.cfg.confirm_rest and _fixes_position(rest[3]):
            self.pending = rest
        return result

    def _to_map(self, i: int) -> np.ndarray:
        """Rotation of anchor i's frame into the map frame (2 x 2)."""
        c, s = math.cos(self.poses[i, 2]), math.sin(self.poses[i, 2])
        return np.array([[c, -s], [s, c]])

    def _projected(self, edge, other, fixed: bool):
        """``edge`` (i, j, z, sqrt_info, where, score, rest) with its position information
        kept only in the directions (map frame) where ``other``'s is not zero (``fixed``)
        or is zero (not ``fixed``): its square-root information times the projection onto
        them, in edge's anchor frame; and whether those directions are both axes."""
        w = other[3][:, :2] @ self._to_map(other[0]).T
        eig, axes = np.linalg.eigh(w.T @ w)
        some = eig > 1e-9 * max(float(eig.max()), 1e-300)
        keep = axes[:, some if fixed else ~some]
        rot = self._to_map(edge[0])
        proj = np.eye(3) if fixed else np.zeros((3, 3))
        proj[:2, :2] = rot.T @ (keep @ keep.T) @ rot
        return (edge[0], edge[1], edge[2], edge[3] @ proj) + tuple(edge[4:]), \
            keep.shape[1] == 2

    def _unconfirmed(self, edge, other):
        """The rest of ``edge`` after a pair with ``other`` closed: its position information
        in the directions (map frame) ``other`` left free, none in heading (that went into
        the pair), flagged as a rest. It waits to be confirmed by the next match."""
        rest, _ = self._projected(edge, other, fixed=False)
        return rest[:6] + (True,)

    def _confirmed_axes(self, edge, other):
        """``edge`` with its position information kept only in the directions (map frame)
        where ``other``'s is not zero (heading unchanged). Both fix both axes: unchanged."""
        projected, both = self._projected(edge, other, fixed=True)
        return edge if both else projected

    def _cost_with(self, loops) -> Tuple[float, np.ndarray]:
        """The graph's sum of squared whitened residuals, optimised with the given loop
        edges added (and then removed again), and the optimised node poses."""
        n_edges = len(self.edges)
        self.edges.extend((i, j, z, w) for i, j, z, w, *_ in loops)
        try:
            optimised = self.optimise()
        finally:
            del self.edges[n_edges:]
        return self.last_cost, optimised

    # -- back end --------------------------------------------------------------------
    def close_loop(self, i: int, j: int, z, sqrt_info, where: str = "",
                   score: float = 0.0) -> LoopResult:
        """Add the loop edge i -> j (measurement ``z``; ``sqrt_info``: 1/std per axis, or
        a 3x3 square-root information matrix), optimise, and keep the result within the
        correction bounds (see the module doc)."""
        where = where or "keyframes %d -> %d" % (i, j)
        return self._close([(i, j, np.asarray(z, dtype=float), _sqrt_info(sqrt_info), where,
                             score, False)], where, score)

    def _close(self, loops, where: str, score: float,
               optimised: Optional[np.ndarray] = None) -> LoopResult:
        """Add the loop edges ``loops`` ((i, j, z, sqrt_info, where, score) each), optimise
        (unless ``optimised``, the poses ``_cost_with`` found with these edges, is given),
        and keep the result within the correction bounds."""
        cfg = self.cfg
        i = loops[0][0]
        n_edges = len(self.edges)
        self.edges.extend((a, b, z, w) for a, b, z, w, *_ in loops)
        if optimised is None:
            optimised = self.optimise()
        moved = np.hypot(optimised[:, 0] - self.poses[:, 0], optimised[:, 1] - self.poses[:, 1])
        correction = float(moved.max())
        if correction > cfg.max_correction_m:
            del self.edges[n_edges:]
            return LoopResult("rejected", "loop closure with %s rejected: it would move the "
                              "map by %.2f m (more than loop_max_correction_m %.2f m)"
                              % (where, correction, cfg.max_correction_m),
                              correction, i, score)
        self.loop_edges += len(loops)
        if correction <= cfg.min_correction_m:
            return LoopResult("kept", "loop edge with %s agrees with the map (largest "
                              "correction %.3f m)" % (where, correction), correction, i, score)
        self.poses = optimised
        self.closures += 1
        return LoopResult("closed", "loop closed with %s (match score %.2f): keyframes moved "
                          "by up to %.2f m" % (where, score, correction), correction, i, score)

    def optimise(self) -> np.ndarray:
        """Node poses minimising the whitened edge errors, node 0 fixed (scipy
        least_squares, trust region with a sparse analytic Jacobian): first with a plain
        quadratic loss (Gauss-Newton-like, converges in a few steps), then polished from
        there with a Huber loss, so a wrong loop edge that slipped through cannot pull the
        whole graph quadratically."""
        n = len(self)
        if n < 2 or not self.edges:
            self.last_cost = 0.0
            return self.poses.copy()
        ii = np.array([e[0] for e in self.edges])
        jj = np.array([e[1] for e in self.edges])
        zz = np.array([e[2] for e in self.edges])
        ww = np.array([_sqrt_info(e[3]) for e in self.edges])
        m = ii.size
        x_fixed = self.poses[0].copy()
        held = np.zeros(0, dtype=np.int64)
        if self.cfg.wall_headings and self.heading_std_rad > 0.0:
            held = np.nonzero(np.isfinite(self.headings[:n]))[0]
            held = held[held > 0]
        held_heading = self.headings[held]

        def unpack(x):
            p = np.vstack([x_fixed, x.reshape(-1, 3)])
            pi, pj = p[ii], p[jj]
            return pi, pj, np.cos(pi[:, 2]), np.sin(pi[:, 2]), pj[:, 0] - pi[:, 0], \
                pj[:, 1] - pi[:, 1]

        def residuals(x):
            pi, pj, c, s, dx, dy = unpack(x)
            e = np.column_stack([c * dx + s * dy - zz[:, 0], -s * dx + c * dy - zz[:, 1],
                                 wrap_angle(pj[:, 2] - pi[:, 2] - zz[:, 2])])
            r = np.einsum("mab,mb->ma", ww, e).ravel()
            if held.size == 0:
                return r
            th = x.reshape(-1, 3)[held - 1, 2] - held_heading
            return np.concatenate([r, wrap_angle(th) / self.heading_std_rad])

        def jacobian(x):
            _, _, c, s, dx, dy = unpack(x)
            zero, one = np.zeros(m), np.ones(m)
            # d e / d (x_i, y_i, th_i) and d e / d (x_j, y_j, th_j), rows e_x, e_y, e_th
            d_i = np.stack([np.stack([-c, -s, -s * dx + c * dy], 1),
                            np.stack([s, -c, -c * dx - s * dy], 1),
                            np.stack([zero, zero, -one], 1)], 1)
            d_j = np.stack([np.stack([c, s, zero], 1), np.stack([-s, c, zero], 1),
                            np.stack([zero, zero, one], 1)], 1)
            rows, cols, vals = [], [], []
            r = (3 * np.arange(m))[:, None, None] + np.arange(3)[None, :, None]
            for node, d in ((ii, d_i), (jj, d_j)):
                col = (3 * (node - 1))[:, None, None] + np.arange(3)[None, None, :]
                keep = np.broadcast_to((node > 0)[:, None, None], d.shape)
                rows.append(np.broadcast_to(r, d.shape)[keep])
                cols.append(np.broadcast_to(col, d.shape)[keep])
                vals.append(np.einsum("mab,mbc->mac", ww, d)[keep])
            if held.size:
                rows.append(3 * m + np.arange(held.size))
                cols.append(3 * (held - 1) + 2)
                vals.append(np.full(held.size, 1.0 / self.heading_std_rad))
            return csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                      np.concatenate(cols))),
                              shape=(3 * m + held.size, 3 * (n - 1)))

        x = self.poses[1:].ravel()
        if self.cfg.solver == "direct":
            x = _gauss_newton(residuals, jacobian, x)
        else:
            for loss in ("linear", "huber"):
                x = least_squares(residuals, x, jac=jacobian, loss=loss, f_scale=1.0,
                                  method="trf", tr_solver="lsmr", max_nfev=20).x
        self.last_cost = float(np.sum(np.square(residuals(x))))
        out = np.vstack([x_fixed, x.reshape(-1, 3)])
        out[:, 2] = wrap_angle(out[:, 2])
        return out


def _gauss_newton(residuals, jacobian, x: np.ndarray, max_steps: int = 10,
                  tol: float = 1e-6) -> np.ndarray:
    """Minimise the sum of squared ``residuals`` (sparse ``jacobian``) from ``x``:
    Gauss-Newton steps on the normal equations (sparse LU), with a quadratic loss and then
    a Huber loss (iteratively reweighted: a residual beyond 1 counts linearly), each until
    no variable moves by more than ``tol`` or after ``max_steps``."""
    for huber in (False, True):
        for _ in range(max_steps):
            r = residuals(x)
            jac = jacobian(x)
            if huber:  # weights of the Huber loss at these residuals (scipy's "huber")
                w = 1.0 / np.maximum(np.abs(r), 1.0)
                jw = diags(w) @ jac
                h, g = jac.T @ jw, jw.T @ r
            else:
                h, g = jac.T @ jac, jac.T @ r
            step = spsolve(h.tocsc(), -g)
            if not np.all(np.isfinite(step)):  # a singular system (a node without edges)
                break
            x = x + step
            if np.abs(step).max() <= tol:
                break
    return x


def rebuild_counts(maps_factory, poses: np.ndarray, scans: List[PreparedScan]):
    """Register every keyframe scan at its pose into a fresh one-particle ``ParticleMaps``
    made by ``maps_factory()`` (grown to hold them all) and return it."""
    maps = maps_factory()
    pose_arr = np.asarray(poses, dtype=float)
    boxes = np.array([maps.footprint(pose_arr[k:k + 1], s) for k, s in enumerate(scans)])
    pad = 2.0 * maps.info.resolution
    maps.ensure_contains(float(boxes[:, 0].min()) - pad, float(boxes[:, 1].min()) - pad,
                         float(boxes[:, 2].max()) + pad, float(boxes[:, 3].max()) + pad, 2.0)
    for k, s in enumerate(scans):
        maps.register(pose_arr[k:k + 1], s)
    return maps
