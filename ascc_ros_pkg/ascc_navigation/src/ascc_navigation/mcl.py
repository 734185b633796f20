"""Monte Carlo localization on a known occupancy grid, as amcl does it (no ROS imports).

* Motion: the odometry motion model of Thrun et al., Probabilistic Robotics, table 5.6
  (amcl's ``diff`` model, noise ``odom_alpha1..4``), applied to all particles at once.
* Sensor: the likelihood-field laser model (table 6.3). The distance of every cell to the
  nearest obstacle surface comes from ``cv2.distanceTransform`` once per map; a particle's
  score is one bilinear table lookup per beam for the whole (particles x beams) block.
  Particles standing in an occupied cell or off the map are penalised.
  Beams of one scan are not independent; their log-likelihoods are summed with the
  exponent ``laser_beam_exponent`` (< 1) so the posterior is not over-confident.
* Resampling: low-variance (systematic) resampling with KLD-adaptive sample size
  (Fox 2003; amcl's ``kld_err``/``kld_z``, ``min_particles``..``max_particles``), and
  optional random-particle injection (augmented MCL, ``recovery_alpha_slow/fast``).
* Estimate: weighted mean and covariance of the whole cloud, yaw included (circular mean,
  wrapped deviations): the reported covariance is the particle spread, widened by the Monte
  Carlo error of the mean (1 + 1/ESS) and the map's cell size (see ``estimate``).
* Optional refinement of the estimate (stand-in only, ``refine_estimate``): the mean is
  scan-matched to the map with many beams (``refine_pose``: hill climbing on a robust
  likelihood of the beams' signed distance to the nearest obstacle surface). A robot that
  stands still gets no motion noise, so its particles cannot move: the cloud's mean stays
  where the best initial particles happened to be (centimetres, a degree or two off).
  The refinement is not fed back into the particles; the covariance stays the cloud's.

Poses are (x [m], y [m], yaw [rad]) rows; the grid follows nav_msgs/OccupancyGrid (row-major,
row index grows with +y of the map origin).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import cv2
import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import nested, param
from ascc_common.pose2d import compose, inverse, mean_yaw, wrap_angle
from ascc_navigation.laser import LaserMount

OCCUPIED_MIN = 65  # occupancy value [0..100] from which a cell counts as an obstacle
FREE_MAX = 25  # occupancy value up to which a known cell counts as free
OBSTACLE_LOG_PENALTY = -50.0  # log-weight of a particle standing in an occupied cell


@dataclass
class MclParams:
    """Filter parameters, named and defaulted as amcl's ROS parameters; read with
    ``ascc_common.params.from_params``."""

    min_particles: int = param(100, "particles at least (KLD sampling)", ge=1)
    max_particles: int = param(5000, "particles at most (KLD sampling)", ge=1)
    kld_err: float = param(0.01, "max error between true and estimated distribution", gt=0.0)
    kld_z: float = param(0.99, "upper standard normal quantile, used as amcl uses it")
    update_min_d: float = param(0.2, "[m] translation between filter updates")
    update_min_a: float = param(np.pi / 6.0, "[rad] rotation between filter updates")
    resample_interval: int = param(2, "filter updates between resamplings")
    selective_resampling: bool = param(False, "resample only when the effective sample "
                                       "size is below half the particles (amcl's option)")
    recovery_alpha_slow: float = param(0.0, "random-particle injection; 0 disables it")
    recovery_alpha_fast: float = param(0.0, "random-particle injection; 0 disables it")
    laser_max_beams: int = param(30, "beams used per scan", ge=1)
    laser_z_hit: float = param(0.95, "weight of the hit part of the likelihood field")
    laser_z_rand: float = param(0.05, "weight of the random part of the likelihood field")
    laser_sigma_hit: float = param(0.2, "[m] std of the hit part", gt=0.0)
    laser_likelihood_max_dist: float = param(2.0, "[m] distance transform clipped here")
    laser_beam_exponent: float = param(0.2, "weight of each beam's log-likelihood "
                                       "(stand-in only)")
    odom_alpha1: float = param(0.2, "rotation noise from rotation")
    odom_alpha2: float = param(0.2, "rotation noise from translation")
    odom_alpha3: float = param(0.2, "translation noise from translation")
    odom_alpha4: float = param(0.2, "translation noise from rotation")
    kld_bin_xy: float = param(0.5, "[m] histogram bin used by KLD sampling (as in amcl)",
                              gt=0.0)
    kld_bin_yaw: float = param(float(np.deg2rad(10.0)), "[rad] histogram bin used by KLD "
                               "sampling", gt=0.0)
    refine_estimate: bool = param(False, "scan-match the published pose to the map "
                                  "(stand-in only)")
    refine_max_beams: int = param(360, "beams used by the refinement", ge=3)
    refine_max_shift_m: float = param(0.3, "[m] refinement moves the estimate at most this "
                                      "far (a match further away is not used)", gt=0.0)
    refine_max_rot_rad: float = param(0.2, "[rad] and turns it at most this much", gt=0.0)


@dataclass
class MclNodeParams:
    """Everything the mcl_localizer node reads (private parameters, amcl's names):
    ``MclParams`` plus the node's own settings."""

    filter: MclParams = nested(MclParams)
    global_frame_id: str = param("map", "map frame")
    odom_frame_id: str = param("odom", "odometry frame")
    base_frame_id: str = param("base_link", "robot frame")
    transform_tolerance: float = param(0.1, "[s] map -> odom post-dating")
    tf_broadcast: bool = param(True, "broadcast map -> odom")
    first_map_only: bool = param(False, "ignore maps after the first")
    laser_min_range: float = param(-1.0, "[m] shorter beams dropped; -1: the scan's")
    laser_max_range: float = param(-1.0, "[m] longer beams dropped; -1: the scan's")
    gui_publish_rate: float = param(-1.0, "[Hz] particlecloud rate; <=0: every update")
    tf_wait_s: float = param(0.1, "[s] wait for a scan's odometry TF")
    initial_pose_x: float = param(0.0, "[m] initial pose")
    initial_pose_y: float = param(0.0, "[m] initial pose")
    initial_pose_a: float = param(0.0, "[rad] initial pose")
    initial_cov_xx: float = param(0.25, "[m^2] initial covariance")
    initial_cov_yy: float = param(0.25, "[m^2] initial covariance")
    initial_cov_aa: float = param((np.pi / 12) ** 2, "[rad^2] initial covariance")
    seed: int = param(-1, "random seed; < 0: random")
    process_period_s: float = param(0.05, "[s] filter timer")


class LikelihoodField:
    """Per-cell log-likelihood of a laser end point, precomputed for one map."""

    def __init__(self, grid: np.ndarray, info: GridInfo, sigma_hit: float = 0.2,
                 z_hit: float = 0.95, z_rand: float = 0.05, max_dist: float = 2.0,
                 range_max: float = 5.6):
        grid = np.asarray(grid)
        if grid.shape != info.shape or grid.size == 0:
            raise ValueError("occupancy grid of shape %s does not match %r"
                             % (grid.shape, info))
        self.info = info.check_axis_aligned()
        self.shape = grid.shape
        self.resolution = info.resolution
        occupied = grid >= OCCUPIED_MIN
        self.free_cells = np.flatnonzero((grid >= 0) & (grid <= FREE_MAX))
        self.occupied = occupied.ravel()
        if occupied.any():
            # centre-to-centre distance minus half a cell: distance to the obstacle's surface
            dist = cv2.distanceTransform((~occupied).astype(np.uint8), cv2.DIST_L2,
                                         cv2.DIST_MASK_PRECISE)
            dist = np.maximum(dist - 0.5, 0.0) * info.resolution
        else:
            dist = np.full(grid.shape, np.inf, dtype=np.float32)
        self.signed_dist = _signed_surface_distance(occupied, info.resolution, max_dist)
        dist = np.minimum(dist, max_dist)
        rand = z_rand / max(range_max, 1e-3)
        self.sigma_hit, self.z_hit, self.rand_density = sigma_hit, z_hit, rand
        self.max_dist = max_dist
        self.log_p = np.log(z_hit * np.exp(-dist ** 2 / (2.0 * sigma_hit ** 2)) + rand)
        self.log_p = self.log_p.astype(np.float32).ravel()
        self.log_p_outside = float(np.log(z_hit * np.exp(-max_dist ** 2 / (2 * sigma_hit ** 2))
                                          + rand))

    def cell_centres(self, flat_index: np.ndarray) -> np.ndarray:
        """World coordinates (N, 2) [m] of the centres of cells given by flat index."""
        rows, cols = np.divmod(flat_index, self.shape[1])
        return np.column_stack(self.info.cell_to_world(cols, rows))

    def in_obstacle(self, xy: np.ndarray) -> np.ndarray:
        """True for world points (..., 2) in an occupied cell or off the map."""
        ix, iy = self.info.world_to_cell(xy[..., 0], xy[..., 1])
        inside = self.info.contains(ix, iy)
        flat = np.where(inside, iy * self.shape[1] + ix, 0)
        return ~inside | self.occupied[flat]

    def log_likelihood(self, xy: np.ndarray) -> np.ndarray:
        """log p(end point) for world points (..., 2), bilinear between cell centres.

        Interpolating (rather than taking the nearest cell, as amcl does) keeps the score
        smooth below one cell, so the estimate is not quantised to the map resolution.
        Points off the map get the floor value.
        """
        return self._bilinear(self.log_p, xy, self.log_p_outside)

    def surface_log_likelihood(self, xy: np.ndarray) -> np.ndarray:
        """log p(end point) for world points (..., 2) from their signed distance to the
        nearest obstacle surface (negative inside obstacles), bilinear between cell centres.

        Unlike ``log_likelihood`` (zero distance everywhere inside an obstacle), it peaks on
        the surface itself, so a scan match is not pulled into the walls. Off the map: the
        floor value. Used by ``refine_pose``.
        """
        d = self._bilinear(self.signed_dist, xy, self.max_dist)
        return np.log(self.z_hit * np.exp(-d ** 2 / (2.0 * self.sigma_hit ** 2))
                      + self.rand_density)

    def _bilinear(self, table: np.ndarray, xy: np.ndarray, outside: float) -> np.ndarray:
        info = self.info
        gc = (xy[..., 0] - info.origin_x) / info.resolution - 0.5  # cell centres at integers
        gr = (xy[..., 1] - info.origin_y) / info.resolution - 0.5
        c0 = np.floor(gc)
        r0 = np.floor(gr)
        fc, fr = gc - c0, gr - r0
        c0 = c0.astype(np.int64)
        r0 = r0.astype(np.int64)
        rows, cols = self.shape
        inside = (r0 >= 0) & (r0 < rows - 1) & (c0 >= 0) & (c0 < cols - 1)
        flat = np.where(inside, r0 * cols + c0, 0)
        val = ((1 - fr) * ((1 - fc) * table[flat] + fc * table[flat + 1])
               + fr * ((1 - fc) * table[flat + cols] + fc * table[flat + cols + 1]))
        return np.where(inside, val, outside)


def _signed_surface_distance(occupied: np.ndarray, resolution: float,
                             max_dist: float) -> np.ndarray:
    """Signed distance [m] of each cell centre to the nearest cell edge between free and
    occupied space: + outside obstacles, - inside; clipped to +-max_dist; flattened.
    Interpolated bilinearly it crosses zero on a straight wall's surface."""
    if not occupied.any() or occupied.all():
        sign = -1.0 if occupied.any() else 1.0
        return np.full(occupied.size, sign * max_dist, dtype=np.float32)
    out = cv2.distanceTransform((~occupied).astype(np.uint8), cv2.DIST_L2,
                                cv2.DIST_MASK_PRECISE)
    inside = cv2.distanceTransform(occupied.astype(np.uint8), cv2.DIST_L2,
                                   cv2.DIST_MASK_PRECISE)
    sd = np.where(occupied, -(inside - 0.5), out - 0.5) * resolution
    return np.clip(sd, -max_dist, max_dist).astype(np.float32).ravel()


def _pose_points(poses: np.ndarray, endpoints: np.ndarray) -> np.ndarray:
    """World points (K, B, 2) of base-frame end points (B, 2) seen from poses (K, 3)."""
    c, s = np.cos(poses[:, 2:3]), np.sin(poses[:, 2:3])
    ex, ey = endpoints[None, :, 0], endpoints[None, :, 1]
    return np.stack([poses[:, 0:1] + c * ex - s * ey, poses[:, 1:2] + s * ex + c * ey],
                    axis=-1)


# the 27 moves (-1, 0, +1 steps in x, y and yaw) of one hill-climbing round; (0, 0, 0) first
_MOVES = np.array([(i, j, k) for i in (0, -1, 1) for j in (0, -1, 1) for k in (0, -1, 1)],
                  dtype=float)


def refine_pose(field: LikelihoodField, pose: Sequence[float], endpoints: np.ndarray,
                max_shift_m: float = 0.3, max_rot_rad: float = 0.2, step_m: float = 0.04,
                step_rad: float = 0.02, min_step_m: float = 0.0005,
                max_rounds: int = 200) -> Tuple[np.ndarray, float]:
    """Scan match: the pose near ``pose`` whose end points best fit the map.

    Hill climbing on the sum over beams of ``field.surface_log_likelihood`` (robust: a beam
    on an unmapped object costs at most the z_rand floor): each round scores the 27 poses
    one step away in x, y and yaw at once, moves to the best, and halves the steps when no
    move helps, down to ``min_step_m`` (the yaw step in proportion). Moves further than
    ``max_shift_m`` / ``max_rot_rad`` from ``pose`` are not taken. Returns the pose (3,)
    and the score gained (log-likelihood units, >= 0).
    """
    start = np.asarray(pose, dtype=float).copy()
    pts = np.asarray(endpoints, dtype=float).reshape(-1, 2)
    if len(pts) == 0:
        return start, 0.0

    def score(poses):
        return field.surface_log_likelihood(_pose_points(poses, pts)).sum(axis=1)

    best = start.copy()
    best_score = start_score = float(score(best[None])[0])
    steps = np.array([step_m, step_m, step_rad])
    for _ in range(max_rounds):
        cand = best[None, :] + _MOVES[1:] * steps
        ok = ((np.hypot(cand[:, 0] - start[0], cand[:, 1] - start[1]) <= max_shift_m)
              & (np.abs(wrap_angle(cand[:, 2] - start[2])) <= max_rot_rad))
        cand = cand[ok]
        sc = score(cand) if len(cand) else np.zeros(0)
        if len(sc) and sc.max() > best_score:
            i = int(np.argmax(sc))
            best, best_score = cand[i].copy(), float(sc[i])
        else:
            steps = steps / 2.0
            if steps[0] < min_step_m:
                break
    best[2] = float(wrap_angle(best[2]))
    return best, best_score - start_score


def scan_endpoints(ranges: np.ndarray, angle_min: float, angle_increment: float,
                   mount: LaserMount, range_min: float, range_max: float,
                   max_beams: int) -> np.ndarray:
    """End points (B, 2) [m] in the base frame of up to ``max_beams`` usable beams.

    Beams that are NaN/inf, below ``range_min`` or at/after ``range_max`` (no return) are
    dropped, as amcl's likelihood-field model does; the rest are subsampled evenly.
    """
    ranges = np.asarray(ranges, dtype=float).ravel()
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(ranges) & (ranges >= range_min) & (ranges < range_max)
    idx = np.flatnonzero(ok)
    if idx.size > max_beams > 0:
        idx = idx[np.round(np.linspace(0, idx.size - 1, max_beams)).astype(np.int64)]
    a = mount.beam_angles(ranges.size, angle_min, angle_increment)[idx]
    r = ranges[idx]
    return np.column_stack([mount.x + r * np.cos(a), mount.y + r * np.sin(a)])


def kld_sample_count(k: np.ndarray, err: float, z: float) -> np.ndarray:
    """Particles needed (Fox 2003) when the samples occupy ``k`` histogram bins."""
    k = np.asarray(k, dtype=float)
    km1 = np.maximum(k - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * z
    n = np.ceil(km1 / (2.0 * err) * x ** 3)
    return np.where(k <= 1, 0, n)


def low_variance_indices(weights: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: ``count`` indices drawn with one random offset."""
    cdf = np.cumsum(weights)
    cdf /= cdf[-1]
    u = (rng.random() + np.arange(count)) / count
    return np.minimum(np.searchsorted(cdf, u, side="right"), len(weights) - 1)


class MonteCarloLocalizer:
    """The particle filter. ``process`` is the one call per scan; the rest are its steps."""

    def __init__(self, field: LikelihoodField, params: Optional[MclParams] = None,
                 rng: Optional[np.random.Generator] = None):
        self.params = params or MclParams()
        self.rng = rng or np.random.default_rng()
        self.field = field
        self.poses = np.zeros((0, 3))
        self.log_w = np.zeros(0)
        self.last_odom: Optional[np.ndarray] = None
        self.updates_since_resample = 0
        self.force_update = True
        self.log_w_slow = None  # augmented MCL running averages of the mean likelihood
        self.log_w_fast = None
        self.last_ess = float("inf")  # effective sample size after the last sensor update
        self.last_refinement = None  # (shift [m], turn [rad], score gain) of refined_estimate

    # -- initialisation -------------------------------------------------------------
    @property
    def initialized(self) -> bool:
        return len(self.poses) > 0

    def initialize_gaussian(self, mean: Sequence[float], cov: np.ndarray) -> None:
        """Particles drawn around ``mean`` (x, y, yaw) with 3x3 covariance ``cov``."""
        n = self.params.max_particles
        cov = np.asarray(cov, dtype=float).reshape(3, 3)
        cov = 0.5 * (cov + cov.T) + np.eye(3) * 1e-9
        self.poses = self.rng.multivariate_normal(np.asarray(mean, dtype=float), cov, n)
        self.poses[:, 2] = wrap_angle(self.poses[:, 2])
        self.log_w = np.full(n, -np.log(n))
        self._restart()

    def initialize_global(self) -> None:
        """Particles spread uniformly over the free cells (amcl's global_localization)."""
        self.poses = self._uniform_free(self.params.max_particles)
        self.log_w = np.full(len(self.poses), -np.log(max(len(self.poses), 1)))
        self._restart()

    def _restart(self) -> None:
        self.force_update = True
        self.updates_since_resample = 0
        self.last_ess = float("inf")
        self.log_w_slow = self.log_w_fast = None

    def set_map(self, field: LikelihoodField) -> None:
        """New map: keep the particles (amcl re-initialises only on request)."""
        self.field = field

    def reset_odometry(self) -> None:
        """Forget the odometry reference (TF jumped back): next scan is a sensor-only update."""
        self.last_odom = None
        self.force_update = True

    def _uniform_free(self, n: int) -> np.ndarray:
        free = self.field.free_cells
        if free.size == 0:
            raise ValueError("map has no free cell to spread particles over")
        pick = free[self.rng.integers(0, free.size, n)]
        xy = self.field.cell_centres(pick) + (self.rng.random((n, 2)) - 0.5) * \
            self.field.resolution
        yaw = self.rng.uniform(-np.pi, np.pi, n)
        return np.column_stack([xy, yaw])

    # -- filter steps ---------------------------------------------------------------
    def predict(self, odom_prev: Sequence[float], odom_now: Sequence[float]) -> None:
        """Moves every particle by the odometry increment, with sampled noise."""
        p = self.params
        dx, dy = odom_now[0] - odom_prev[0], odom_now[1] - odom_prev[1]
        trans = float(np.hypot(dx, dy))
        rot1 = float(wrap_angle(np.arctan2(dy, dx) - odom_prev[2])) if trans > 0.01 else 0.0
        rot2 = float(wrap_angle(odom_now[2] - odom_prev[2] - rot1))
        # driving backwards is a small rotation plus negative motion, not a half turn
        rot1_n = min(abs(rot1), abs(float(wrap_angle(rot1 - np.pi))))
        rot2_n = min(abs(rot2), abs(float(wrap_angle(rot2 - np.pi))))
        n = len(self.poses)
        sd_rot1 = np.sqrt(p.odom_alpha1 * rot1_n ** 2 + p.odom_alpha2 * trans ** 2)
        sd_trans = np.sqrt(p.odom_alpha3 * trans ** 2 + p.odom_alpha4 * (rot1_n ** 2 + rot2_n ** 2))
        sd_rot2 = np.sqrt(p.odom_alpha1 * rot2_n ** 2 + p.odom_alpha2 * trans ** 2)
        r1 = rot1 - self.rng.normal(0.0, 1.0, n) * sd_rot1
        tr = trans - self.rng.normal(0.0, 1.0, n) * sd_trans
        r2 = rot2 - self.rng.normal(0.0, 1.0, n) * sd_rot2
        heading = self.poses[:, 2] + r1
        self.poses[:, 0] += tr * np.cos(heading)
        self.poses[:, 1] += tr * np.sin(heading)
        self.poses[:, 2] = wrap_angle(heading + r2)

    def update_sensor(self, endpoints_base: np.ndarray) -> float:
        """Weights the particles by the scan; returns the mean log-likelihood per particle.

        ``endpoints_base`` (B, 2) [m] are beam end points in the robot's base frame.
        """
        if len(endpoints_base) == 0:
            return float("nan")
        world = _pose_points(self.poses, endpoints_base)
        log_lik = self.params.laser_beam_exponent * self.field.log_likelihood(world).sum(axis=1)
        # a robot cannot stand inside an obstacle (nor off the map): without this, particles
        # inside a large solid block score best, as all their beams end in occupied cells
        log_lik[self.field.in_obstacle(self.poses[:, :2])] += OBSTACLE_LOG_PENALTY
        self.log_w = self.log_w + log_lik
        self.log_w -= np.logaddexp.reduce(self.log_w)
        self.last_ess = self.effective_sample_size()
        self._track_likelihood(log_lik)
        return float(log_lik.mean())

    def _track_likelihood(self, log_lik: np.ndarray) -> None:
        p = self.params
        if p.recovery_alpha_slow <= 0.0 or p.recovery_alpha_fast <= 0.0:
            return
        log_avg = float(np.logaddexp.reduce(log_lik) - np.log(len(log_lik)))
        if self.log_w_slow is None:
            self.log_w_slow = self.log_w_fast = log_avg
            return
        self.log_w_slow = float(np.logaddexp(np.log1p(-p.recovery_alpha_slow) + self.log_w_slow,
                                             np.log(p.recovery_alpha_slow) + log_avg))
        self.log_w_fast = float(np.logaddexp(np.log1p(-p.recovery_alpha_fast) + self.log_w_fast,
                                             np.log(p.recovery_alpha_fast) + log_avg))

    def resample(self) -> None:
        """Low-variance resampling, sample size adapted by KLD, random-particle injection."""
        p = self.params
        w = np.exp(self.log_w - self.log_w.max())
        idx = low_variance_indices(w, p.max_particles, self.rng)
        cand = self.poses[self.rng.permutation(idx)]  # random order: prefixes are fair samples
        n = self._kld_size(cand)
        new = cand[:n].copy()
        if self.log_w_slow is not None and self.log_w_fast is not None:
            p_random = max(0.0, 1.0 - float(np.exp(self.log_w_fast - self.log_w_slow)))
            n_random = int(self.rng.binomial(n, p_random)) if p_random > 0 else 0
            if n_random > 0:
                new[:n_random] = self._uniform_free(n_random)
                self.log_w_slow = self.log_w_fast = None  # restart the averages after injection
        self.poses = new
        self.log_w = np.full(n, -np.log(n))

    def _kld_size(self, cand: np.ndarray) -> int:
        p = self.params
        bx = np.floor(cand[:, 0] / p.kld_bin_xy).astype(np.int64)
        by = np.floor(cand[:, 1] / p.kld_bin_xy).astype(np.int64)
        bt = np.floor(cand[:, 2] / p.kld_bin_yaw).astype(np.int64)
        keys = (bx * 1_000_003 + by) * 1_009 + bt
        _, first = np.unique(keys, return_index=True)
        new_bin = np.zeros(len(cand), dtype=np.int64)
        new_bin[first] = 1
        k = np.cumsum(new_bin)
        need = np.clip(kld_sample_count(k, p.kld_err, p.kld_z), p.min_particles, p.max_particles)
        enough = np.flatnonzero(np.arange(1, len(cand) + 1) >= need)
        return int(enough[0] + 1) if enough.size else len(cand)

    def process(self, odom_pose: Sequence[float], endpoints_base: np.ndarray) -> bool:
        """One scan with the odometry pose at its time stamp; returns True if filtered.

        As amcl: the filter runs only after ``update_min_d``/``update_min_a`` of motion (or
        on the first scan / after a reset), and resamples every ``resample_interval`` runs.
        """
        if not self.initialized:
            return False
        odom_pose = np.asarray(odom_pose, dtype=float)
        if self.last_odom is not None:
            d = odom_pose - self.last_odom
            moved = (abs(d[0]) > self.params.update_min_d or abs(d[1]) > self.params.update_min_d
                     or abs(float(wrap_angle(d[2]))) > self.params.update_min_a)
            if not moved and not self.force_update:
                return False
            self.predict(self.last_odom, odom_pose)
        self.last_odom = odom_pose
        if len(endpoints_base) == 0:
            return False
        self.update_sensor(endpoints_base)
        self.force_update = False
        self.updates_since_resample += 1
        if self.updates_since_resample >= max(self.params.resample_interval, 1):
            if (not self.params.selective_resampling
                    or self.last_ess < 0.5 * len(self.poses)):
                self.resample()
            self.updates_since_resample = 0
        return True

    def request_nomotion_update(self) -> None:
        """The next scan updates the filter although the robot did not move."""
        self.force_update = True

    # -- estimate -------------------------------------------------------------------
    def estimate(self) -> Tuple[np.ndarray, np.ndarray]:
        """Weighted mean pose (3,) and covariance (3, 3) of x [m], y [m], yaw [rad].

        The covariance is the weighted spread of the cloud, times (1 + 1/ESS) for the Monte
        Carlo error of the weighted mean (ESS = effective sample size of the last sensor
        update), plus the variance of a uniform position within one map cell (res^2 / 12)
        on x and y, which a grid map cannot resolve.
        """
        w = np.exp(self.log_w - self.log_w.max())
        w /= w.sum()
        mx, my = float(w @ self.poses[:, 0]), float(w @ self.poses[:, 1])
        myaw = mean_yaw(self.poses[:, 2], w)
        dev = np.column_stack([self.poses[:, 0] - mx, self.poses[:, 1] - my,
                               wrap_angle(self.poses[:, 2] - myaw)])
        cov = (dev * w[:, None]).T @ dev
        ess = max(min(self.last_ess, self.effective_sample_size()), 1.0)
        cov *= 1.0 + 1.0 / ess
        cov[0, 0] += self.field.resolution ** 2 / 12.0
        cov[1, 1] += self.field.resolution ** 2 / 12.0
        return np.array([mx, my, myaw]), cov

    def refined_estimate(self, endpoints_base: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """``estimate()``, its mean scan-matched to the map (``refine_pose``) with the
        end points (B, 2) [m, base frame] when ``refine_estimate`` is set; the covariance
        is the cloud's. ``last_refinement`` keeps (shift [m], turn [rad], score gain)."""
        mean, cov = self.estimate()
        p = self.params
        if not p.refine_estimate or len(endpoints_base) == 0:
            return mean, cov
        pose, gain = refine_pose(self.field, mean, endpoints_base, p.refine_max_shift_m,
                                 p.refine_max_rot_rad)
        self.last_refinement = (float(np.hypot(*(pose[:2] - mean[:2]))),
                                float(wrap_angle(pose[2] - mean[2])), gain)
        return pose, cov

    def effective_sample_size(self) -> float:
        w = np.exp(self.log_w - self.log_w.max())
        w /= w.sum()
        return float(1.0 / np.sum(w ** 2))


def map_to_odom(pose_map: Sequence[float], pose_odom: Sequence[float]) -> np.ndarray:
    """The map->odom transform that puts the base at ``pose_map`` given its odometry pose."""
    return compose(pose_map, inverse(pose_odom))


def covariance_6x6(cov3: np.ndarray) -> list:
    """Row-major 6x6 (x, y, z, roll, pitch, yaw) covariance as in PoseWithCovariance."""
    out = np.zeros((6, 6))
    sel = [0, 1, 5]
    out[np.ix_(sel, sel)] = cov3
    return out.ravel().tolist()
