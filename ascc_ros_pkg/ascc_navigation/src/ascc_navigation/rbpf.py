"""Rao-Blackwellized particle filter SLAM in the manner of GMapping (Grisetti et al. 2007).

Each particle carries a robot pose (base frame in the map frame) and its own occupancy grid.
One filter update, given the odometry motion since the last update and a prepared scan
(``laser.prepare_scan``):

1. motion: every particle draws a pose from the odometry motion model (``srr, srt, str, stt``);
2. scan matching: every particle's pose is refined by hill climbing (gmapping's six moves,
   steps ``lstep``/``astep`` halved ``iterations`` times) on the match score
   sum_b exp(-d_b^2 / (2 sigma^2)) minus a motion prior motion_prior * |x - x_sampled|^2
   (Mahalanobis, motion-model covariance); d_b is the distance from beam b's end point to the
   nearest occupied cell of the particle's *own* map, bilinearly interpolated in a distance
   field capped at ``match_radius``. Beams longer than maxUrange - motion - new_area_margin
   are left out (they reach past what the map holds), and optionally (``seen_margin_m``)
   beams ending beyond what the previous update's scan saw in their direction; optionally
   (``wall_axis_pull_std_rad``) the matched pose is then pulled, in one Gauss-Newton step,
   towards the heading the scan's straight walls give (step 3's wall reference), where the
   matched heading is already near it;
3. weighting: log w_i += (1/ogain) * sum_b -min(d_b, r_w)^2 / (2 lsigma^2), r_w the match
   radius or the smaller ``weight_radius_m``; optionally (``detrend_along``) minus its
   linear trend in the particles' position along their mean heading; optionally
   (``wall_axis_std_rad``) minus e_i^2 / (2 std^2), e_i the angle between the scan's
   straight walls placed at particle i's heading and the walls of the first scan, modulo a
   right angle (``wall_axes``);
4. pose entropy H = -sum w_i log w_i of the normalised weights (published by the node);
5. selective resampling when N_eff = 1 / sum w_i^2 < resampleThreshold * N (low variance);
6. map update: every particle registers the scan at its pose into its map.

Maps use gmapping's cell model: per cell a count of visits and of hits; a cell is unknown
until visited and occupied iff hits/visits > occ_thresh. The counts are uint8 stacks of shape
(N, H, W) (two bytes per cell and particle); when a count would overflow, both counts of that
cell are halved, which keeps the ratio and slowly forgets old evidence. The grid grows (whole
cells, origin kept on the lattice) whenever a scan reaches beyond it.

Everything is vectorised over particles and beams: the free space of all particles is filled
with one ``cv2.fillPoly`` call on a stack of windows, the likelihood fields of all particles
come from one ``cv2.distanceTransform`` call, and the scan matcher's hill climb is compiled
(``climb``: numba), one end point at a time. No ROS imports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

import cv2
import numpy as np
from scipy.ndimage import uniform_filter1d

from ascc_common.grid import OCCUPIED, GridInfo
from ascc_common.params import param
from ascc_common.pose2d import compose, mean_yaw, wrap_angle
from ascc_navigation.climb import field_image, hill_climb
from ascc_navigation.grid import count_table, occupancy_from_counts
from ascc_navigation.laser import PreparedScan, seen_before
from ascc_navigation.wall_axes import WallAxis, mean_direction, scan_wall_axis, wrap_right_angle

COUNT_MAX = 255  # uint8 counters; a cell at this count is halved before the next increment
FILL_SHIFT = 8  # fractional bits for cv2.fillPoly vertices (1/256 cell)
MIN_ALONG_STD_M = 1e-3  # detrend_along: less spread along the heading than this is none
MAX_CLIMB_STEPS = 60  # safety cap on hill-climbing steps per pose and update


@dataclass
class RbpfConfig:
    """Filter parameters, read as gmapping's ROS parameters (``ascc_common.params``)."""

    particles: int = param(30, "number of particles")
    delta: float = param(0.05, "[m/cell] map resolution")
    xmin: float = param(-10.0, "[m] initial map extent (the map grows as needed)")
    ymin: float = param(-10.0, "[m] initial map extent")
    xmax: float = param(10.0, "[m] initial map extent")
    ymax: float = param(10.0, "[m] initial map extent")
    sigma: float = param(0.05, "[m] std of the end-point match score")
    kernel_size: int = param(1, "[cells] match radius, at least 3 sigma", "kernelSize")
    lstep: float = param(0.05, "[m] initial translation step of the matcher")
    astep: float = param(0.05, "[rad] initial rotation step of the matcher")
    iterations: int = param(5, "step halvings of the matcher")
    lsigma: float = param(0.075, "[m] std of the beam likelihood")
    ogain: float = param(3.0, "divides the log-likelihood (smooths weights)")
    minimum_score: float = param(0.0, "[beams] below this match score the odometry pose is "
                                 "kept", "minimumScore")
    srr: float = param(0.1, "[m/m] translation noise per metre of translation")
    srt: float = param(0.2, "[rad/m] rotation noise per metre of translation")
    str: float = param(0.1, "[m/rad] translation noise per radian of rotation")
    stt: float = param(0.2, "[rad/rad] rotation noise per radian of rotation")
    resample_threshold: float = param(0.5, "N_eff/N below which to resample",
                                      "resampleThreshold")
    occ_thresh: float = param(0.25, "hits/visits above which a cell is occupied")
    grow_margin: float = 2.0        # extra map [m] added on a side when the map grows
    search_margin: float = 0.5      # [m] how far the matcher may move a pose (window size)
    # Not in gmapping: the matcher maximises score - motion_prior * |x - x_sampled|^2_Sigma,
    # Sigma from the motion model (floored at prior_min_xy/prior_min_theta), so a pose cannot
    # slide along a direction the scan does not constrain (corridors); 0 disables it.
    motion_prior: float = param(1.0, "[beams per sigma^2] matcher pull to the sampled pose "
                                "(not gmapping)")
    # Not in gmapping: an extra pull along the particle's heading only (the direction of
    # travel, where a corridor's scan is blind and the wheels' distance is good), leaving
    # the heading and the position across the travel to motion_prior; 0 disables it.
    prior_along: float = param(0.0, "[beams per sigma^2] extra matcher pull to the sampled "
                               "pose along the particle's heading only; 0 off (not gmapping)")
    # Not in gmapping: prior_along only where the scan does not hold the position along the
    # travel itself. The scan's information along the heading (Gauss-Newton, as
    # ``scan_information``, for the best particle at its sampled pose) is the match score's
    # curvature there; the extra pull tops it up to prior_along's (2 * along), and is zero
    # where the scan alone is at least that tight (rooms, corners, door recesses). A fixed
    # pull held the corridor's long sides to the odometry's length but made the lab's maps
    # worse, where the scan constrains the position in every direction.
    prior_along_adaptive: bool = param(False, "prior_along tops up the scan's own "
                                       "information along the heading instead of adding "
                                       "to it (not gmapping)")
    # Not in gmapping: with prior_along_adaptive, the pull along the direction the scan
    # holds least (the eigenvector of the smallest eigenvalue of its position information,
    # for the best particle), topping up that eigenvalue, instead of along the heading. They
    # are the same while the robot drives along a corridor; while it turns or drives
    # obliquely, the heading's information includes the corridor's across (the pull is
    # then off) and the corridor's axis, which the scan does not see, is held by nothing
    # but motion_prior.
    prior_along_blind: bool = param(False, "with prior_along_adaptive: pull along the "
                                    "scan's least-held direction instead of the heading "
                                    "(not gmapping)")
    # Not in gmapping: the motion model's draw along the direction the scan holds least
    # (the smallest eigenvector of its position information, for the best particle at its
    # sampled pose) is scaled by that information over the motion model's (as the matcher
    # weighs them: 1 / max(sigma_xy, prior_min_xy)^2), at most 1: none of it where the scan
    # does not see that direction (a featureless corridor), all of it where the scan tells
    # at least as much as the odometry. (Along the heading instead, a draw's heading error
    # of a few hundredths of a radian lets the corridor's across leak in.) Where the scan is
    # blind the weights cannot tell the draws apart, so their spread is no hypothesis the
    # scans test, only a random walk that the surviving particle's map keeps. The particles
    # then share the odometry's distance there, and keep their spread across the travel and
    # in heading. Off: the scripted corridor loops came out worse (docs/results/
    # ascc_navigation.md).
    draw_along_blind: bool = param(False, "the motion model's draw along the direction the "
                                   "scan holds least scaled by the scan's information there "
                                   "over the odometry's, at most 1 (not gmapping)")
    prior_min_xy: float = 0.02      # [m]
    prior_min_theta: float = 0.02   # [rad]
    # Not in gmapping: beams longer than maxUrange - (distance moved + this margin) are not
    # matched. They reach beyond what the previous scan could see, i.e. beyond the mapped part
    # of a wall, and would pull the pose back onto it: corridors would come out short.
    new_area_margin: float = param(0.1, "[m] beams beyond maxUrange - motion - this are not "
                                   "matched (not gmapping)")
    # Not in gmapping: the same for surfaces the previous update's scan could not see because
    # something was in front of them (``laser.seen_before``): driving past a door recess, its
    # back wall comes into view behind the jamb from the far end towards the robot, a cell or
    # two per update; matched, those end points pull the pose onto the end of the mapped part
    # of the wall, i.e. forwards (+0.3-0.7 mm per update on the corridor; with the check
    # -0.1 to -0.3 mm: ascc_eval/scripts/mapper_along_bias.py). Off by default: the
    # corridor maps came out worse with it (docs/results/ascc_navigation.md). <0: off.
    seen_margin_m: float = param(-1.0, "[m] beams ending more than this beyond what the "
                                 "previous update's scan saw in their direction (occluded, out "
                                 "of view or range) are not matched; <0 off (not gmapping)")
    # Not in gmapping: the distance at which the weights stop telling beams apart. A beam
    # ending farther than this from a particle's map (a surface that came into view since
    # the last update, something not in the map) counts as this far. While the robot
    # explores, such surfaces lie beyond the mapped ones, so a particle that lags along the
    # travel finds them nearer to its map and wins the weighting (ascc_eval/scripts/
    # mapper_along_bias.py, 'selection'). A smaller radius shrinks that pull, but the
    # corridor's long sides did not come out longer online (docs/results/
    # ascc_navigation.md). <0: the match radius, as gmapping's kernel.
    weight_radius_m: float = param(-1.0, "[m] beam end points farther than this from a "
                                   "particle's map count as this far in its weight; <0: the "
                                   "match radius (not gmapping)")
    # Not in gmapping: each update's log-likelihood minus its least-squares linear trend in
    # the particles' position along their mean heading. The weights then keep what tells
    # the particles apart across the travel and in heading, and drop a systematic
    # preference along it: while the robot explores, surfaces newly in view favour the
    # particle that lags, and resampling on such weights compounds it into maps that come
    # out short along corridors. Off by default: better in replays of recorded corridor
    # runs, not online (five corridor seeds: 90.2 % against 90.4 %, one broken map;
    # docs/results/ascc_navigation.md).
    detrend_along: bool = param(False, "remove from each update's weights their linear "
                                "trend in the particles' position along their mean "
                                "heading (not gmapping)")
    # Not in gmapping: re-localisation of a particle whose matched scan fits its map badly
    # (fewer than recover_score of the beams, as a fraction of the perfect score): odometry
    # that turned by an unmodelled amount (a wheel slip, odometry stamped late while the
    # robot spun) leaves the hill climber in a wrong local optimum, and the map registered
    # there is bent for good. Headings within +-recover_angle in recover_step steps are
    # scored, the best is refined by hill climbing without the motion prior, and it is kept
    # if it scores at least recover_gain (fraction of the beams) better. 0 disables it.
    recover_score: float = param(0.7, "[fraction of the perfect match score] below it a wide "
                                 "heading search runs; 0 off (not gmapping)")
    recover_angle: float = param(0.7, "[rad] wide heading search +- this")
    recover_step: float = param(0.035, "[rad] wide heading search step")
    recover_gain: float = param(0.1, "[fraction of the perfect match score] the wide search's "
                                "pose is kept if it scores this much better")
    # Not in gmapping: degeneracy-aware matching (Zhang, Kaess & Singh 2016, "On degeneracy of
    # optimization-based state estimation problems"). After the hill climb, the scan's
    # information about each particle's position (Gauss-Newton, from the likelihood field's
    # gradients at the matched beam end points, with the score's own end-point std sigma)
    # is compared with the motion model's for this update (1 / sigma_xy^2); along its
    # eigen-directions where the ratio is below degenerate_info the scan tells less than
    # the odometry does, and the particle keeps its motion prediction (the sampled pose)
    # there: the matcher's slide along a featureless corridor is dropped. The heading stays
    # the matcher's. 0 disables it.
    degenerate_info: float = param(0.0, "[-] scan / motion-model information ratio below "
                                   "which a direction keeps the motion prediction; 0 off "
                                   "(not gmapping)")
    # Not in gmapping: a heading prior from straight walls at right angles (``wall_axes``).
    # Each scan's wall direction, placed at a particle's matched heading, is compared with
    # the first scan's (modulo a right angle), and the particle's weight takes the Gaussian
    # of that angle with this std. The matcher holds the heading against the particle's own
    # map of the last few metres, about a hundredth of a radian loose, so over a long
    # corridor the map's walls bend; this holds them to the directions they started with.
    # A scan whose walls, at the particles' median heading, are more than wall_axis_gate_rad
    # off is left out: walls not at right angles to the first (a gate of 0.1 let the prior
    # bend a side 3.6 degrees off the others straight; 0.03, three of the prior's std, leaves
    # it out), or a heading that strayed further (then not pulled back). <0: off (the
    # default here, as gmapping has none); config/gmapping.yaml sets 0.01
    # (docs/results/ascc_navigation.md).
    wall_axis_std_rad: float = param(-1.0, "[rad] std of the heading prior from straight "
                                     "walls at right angles to the first scan's; <0 off "
                                     "(not gmapping)")
    # Not in gmapping: with wall_axis_std_rad on, the matched heading held to the scan's
    # walls as well. The weighting above only chooses among the particles; when they all
    # share a heading that has strayed (their maps bent alike), it cannot move them. Here,
    # after the hill climb, each particle's matched pose takes one Gauss-Newton step of the
    # match (its scan information, ``scan_information``, with the motion prior in x and y)
    # plus a prior of this std on the heading its scan's walls give (the first scan's wall
    # directions modulo a right angle): the scan's own heading information (~0.5e6
    # beams/rad^2 in a corridor, ~1.4 mrad) and the walls' share the correction. Only where
    # the particles' matched headings lie within three of this std of the walls' (median)
    # and the scan's walls agree among themselves: a side a few degrees off the others is
    # matched as it is and left alone (docs/results/ascc_navigation.md). <0: off.
    wall_axis_pull_std_rad: float = param(-1.0, "[rad] with wall_axis_std_rad on: std of the "
                                          "matcher's pull of each heading to the one the "
                                          "scan's walls give; <0 off (not gmapping)")
    # Not in gmapping: one scan's walls' direction is off by about a milliradian, and the
    # reference's error turns the whole map (0.1 m at the far end of a 100 m corridor); the
    # scans a robot takes while it stands at the start (the odometry unchanged) average it.
    wall_axis_reference_scans: int = param(1, "the wall-axis prior's reference: the mean "
                                           "direction of this many scans at most, the first "
                                           "and those before the robot first moves",
                                           ge=1)
    wall_axis_gate_rad: float = param(0.03, "[rad] scans whose walls are further than this "
                                      "from the first scan's directions are left out of "
                                      "the wall-axis prior")

    def validate(self) -> None:
        if self.particles < 1:
            raise ValueError("particles must be >= 1")
        for name in ("delta", "sigma", "lstep", "astep", "lsigma", "ogain"):
            if not getattr(self, name) > 0.0:
                raise ValueError("%s must be > 0" % name)
        if not (self.xmax > self.xmin and self.ymax > self.ymin):
            raise ValueError("xmin..xmax and ymin..ymax must be non-empty ranges")
        for name in ("degenerate_info", "motion_prior", "prior_along"):
            if not getattr(self, name) >= 0.0:
                raise ValueError("%s must be >= 0" % name)
        if not 0.0 < self.wall_axis_gate_rad <= math.pi / 4.0:
            raise ValueError("wall_axis_gate_rad must be in (0, pi/4]")
        if not 0.0 <= self.occ_thresh < 1.0:
            raise ValueError("occ_thresh must be in [0, 1)")
        if not (0.0 <= self.recover_score <= 1.0 and self.recover_angle >= 0.0
                and self.recover_step > 0.0 and self.recover_gain >= 0.0):
            raise ValueError("recover_score must be in [0, 1], recover_angle and recover_gain "
                             ">= 0, recover_step > 0")

    @property
    def match_radius(self) -> float:
        """Distance [m] beyond which a beam end point has no match (score 0)."""
        return max(self.kernel_size * self.delta, 3.0 * self.sigma)

    @property
    def weight_radius(self) -> float:
        """Distance [m] at which a beam's term in the weights stops growing."""
        if self.weight_radius_m < 0.0:
            return self.match_radius
        return min(self.weight_radius_m, self.match_radius)


@dataclass
class UpdateStats:
    """What one filter update did (for logging and benchmarks)."""

    entropy: float = 0.0       # pose entropy [nats] of the normalised weights
    neff: float = 0.0          # effective sample size before resampling
    resampled: bool = False
    best: int = 0              # index of the best particle after the update
    mean_score: float = 0.0    # mean match score over particles [beams]
    matched: int = 0           # particles whose matched pose was accepted
    beams: int = 0             # end points matched (after the new-area / seen cuts)
    recovered: int = 0         # particles moved by the wide heading search
    degenerate: int = 0        # particles that kept the prediction in some direction
    along_info: float = 0.0    # [1/m^2] the scan's information along the best particle's
                               # heading (prior_along_adaptive only)
    along_pull: float = 0.0    # [beams/m^2] the along pull the matcher used
    along_angle: float = 0.0   # [rad] its direction from the heading (prior_along_blind)
    draw_along_share: float = 1.0  # share of the draw kept along the scan's least-held
                                   # direction (draw_along_blind)
    grown: bool = False        # the map grew
    log_gain: Optional[np.ndarray] = None       # per particle: this update's log-likelihood
                                                # / ogain, added to the log weights
    weighed_poses: Optional[np.ndarray] = None  # (N, 3) the poses weighed (before resampling)
    odom_delta: Optional[np.ndarray] = None     # the odometry increment (dx, dy, dtheta)
    sampled_poses: Optional[np.ndarray] = None  # (N, 3) the motion model's draws
    resampled_from: Optional[np.ndarray] = None  # (N,) resampling: each particle's index
                                                 # before it (None: not resampled)
    # wall-axis prior: the scan's wall direction [rad, base frame, modulo a right angle]
    # (None: no straight walls, or the prior is off) and whether it weighed the particles
    wall_axis: Optional[float] = None
    wall_axis_used: bool = False
    wall_axis_pulled: bool = False  # wall_axis_pull_std_rad: the matched poses were pulled


def detrend_along(gain: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """``gain`` (one value per particle) minus its least-squares linear trend in the
    particles' position along their mean heading (``poses`` (N, 3)); its mean is kept.
    Unchanged when the particles spread along that heading by less than MIN_ALONG_STD_M
    (a trend fitted to less would be one across the travel, seen through the mean
    heading's error)."""
    h = mean_yaw(poses[:, 2])
    a = math.cos(h) * poses[:, 0] + math.sin(h) * poses[:, 1]
    a = a - a.mean()
    var = float(a @ a)
    if var <= a.size * MIN_ALONG_STD_M ** 2:
        return gain
    return gain - (float((gain - gain.mean()) @ a) / var) * a


def normalized_weights(log_w: np.ndarray) -> np.ndarray:
    w = np.exp(log_w - np.max(log_w))
    return w / w.sum()


def weight_entropy(weights: np.ndarray) -> float:
    """Shannon entropy [nats] of normalised weights (0 for one particle, log N if uniform)."""
    w = weights[weights > 0.0]
    return float(-(w * np.log(w)).sum())


def effective_sample_size(weights: np.ndarray) -> float:
    return float(1.0 / np.sum(weights * weights))


def low_variance_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: indices of the surviving particles (len N, sorted)."""
    n = weights.size
    positions = (rng.random() + np.arange(n)) / n
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0
    return np.searchsorted(cumulative, positions, side="right").clip(0, n - 1)


def motion_noise(delta: np.ndarray, cfg: RbpfConfig) -> Tuple[float, float]:
    """Std of the odometry error for the increment ``delta`` = (dx, dy, dtheta):
      sigma_xy    = srr * |d| + str * |dtheta|   [m] (on dx and on dy)
      sigma_theta = stt * |dtheta| + srt * |d|   [rad], with d = hypot(dx, dy).
    """
    dist = math.hypot(delta[0], delta[1])
    rot = abs(float(wrap_angle(delta[2])))
    return cfg.srr * dist + cfg.str * rot, cfg.stt * rot + cfg.srt * dist


def sample_motion(poses: np.ndarray, delta: np.ndarray, cfg: RbpfConfig,
                  rng: np.random.Generator) -> np.ndarray:
    """Odometry motion model: apply the odometry increment ``delta`` (dx, dy, dtheta in the
    previous robot frame) to every particle with Gaussian noise of ``motion_noise`` stds."""
    n = poses.shape[0]
    s_xy, s_th = motion_noise(delta, cfg)
    noisy = np.empty((n, 3))
    noisy[:, 0] = delta[0] + s_xy * rng.standard_normal(n)
    noisy[:, 1] = delta[1] + s_xy * rng.standard_normal(n)
    noisy[:, 2] = delta[2] + s_th * rng.standard_normal(n)
    return compose(poses, noisy)


def _angle(wall: Optional[WallAxis]) -> Optional[float]:
    """A wall fit's direction [rad], or None without one."""
    return None if wall is None else wall.angle


def shrink_draw(sampled: np.ndarray, predicted: np.ndarray, angle: float,
                share: float) -> np.ndarray:
    """The draws ``sampled`` (N, 3) with their offset from the noise-free ``predicted``
    poses scaled by ``share`` along the direction ``angle`` [rad, map frame]; across it
    and in heading they are unchanged."""
    u = np.array([math.cos(angle), math.sin(angle)])
    offset = (sampled[:, :2] - predicted[:, :2]) @ u
    out = sampled.copy()
    out[:, :2] -= (1.0 - share) * offset[:, None] * u
    return out


NORMAL_BEAMS = 5  # matched beams (in scan order) whose field gradients make one normal
_MIN_STD = 1e-3  # [m] floor of the prediction's position std (no motion: not zero)


def scan_information(d: np.ndarray, gx: np.ndarray, gy: np.ndarray, rx: np.ndarray,
                     ry: np.ndarray, sigma: float) -> np.ndarray:
    """Gauss-Newton information (n, 3, 3) [1/m^2, 1/(m rad), 1/rad^2] that a matched scan
    carries about each pose (x, y, theta) under the match score's own noise model (beam end
    points scattered with std ``sigma`` about the nearest wall): sum_b w_b J_b^T J_b /
    sigma^2, with w_b = exp(-d_b^2 / (2 sigma^2)) the beam's weight in the score and J_b
    the gradient of its end point's distance with respect to the pose: (n_b, n_b x r_b),
    r_b the end point's offset from the pose and n_b the wall's unit normal there.

    n_b is the principal direction of the distance field's gradients (bilinear, per end
    point) over NORMAL_BEAMS neighbouring beams, i.e. over a stretch of the same surface,
    as point-to-plane ICP takes normals from neighbouring points: a wall drawn in cells is
    ragged at the cell scale (gaps where beams grazed it), and the raw gradients' +-
    components along the wall, which cancel in the score, would otherwise count as
    information along it. (The gradients' sign flips across the wall's cell, so their
    outer products are averaged, not the vectors.)"""
    d = d.astype(np.float64)
    w = np.exp(-d * d / (2.0 * sigma * sigma))
    gx = gx.astype(np.float64)
    gy = gy.astype(np.float64)
    k = min(NORMAL_BEAMS, d.shape[-1]) or 1
    txx = uniform_filter1d(gx * gx, k, axis=-1, mode="nearest")
    tyy = uniform_filter1d(gy * gy, k, axis=-1, mode="nearest")
    txy = uniform_filter1d(gx * gy, k, axis=-1, mode="nearest")
    phi = 0.5 * np.arctan2(2.0 * txy, txx - tyy)
    nx, ny = np.cos(phi), np.sin(phi)
    jt = ny * rx - nx * ry
    jac = np.stack([nx, ny, jt], axis=-1)                              # (n, M, 3)
    return np.einsum("nm,nmi,nmj->nij", w, jac, jac) / (sigma * sigma)


def degeneracy_projection(fields: _LikelihoodFields, pts: np.ndarray, sigma: float,
                          predicted: np.ndarray, matched: np.ndarray, particles: np.ndarray,
                          predicted_std: float, threshold: float
                          ) -> Tuple[np.ndarray, np.ndarray]:
    """Degeneracy-aware solution remapping (Zhang, Kaess & Singh 2016) of the matched poses
    (n, 3), in position: the scan's information about (x, y) at the matched pose and
    heading (the x, y block of ``scan_information``), in units of the motion model's
    (times ``predicted_std``^2, the prediction's position std [m]), is split into
    eigen-directions; the matcher's correction (matched - predicted) is kept along those
    whose eigenvalue is >= threshold and dropped along the others, where the odometry knows
    more than the scan. The heading stays the matcher's: the walls within the laser's reach
    fix it at every update, unlike the position along a corridor, and the odometry's heading
    is its weak part. Returns the poses and a mask of the particles that had a flat
    direction."""
    if matched.shape[0] == 0:
        return matched, np.zeros(0, dtype=bool)
    info = scan_information(*fields.gradients(matched, particles, pts), sigma)[:, :2, :2]
    vals, vecs = np.linalg.eigh(info * predicted_std ** 2)                # ascending
    good = (vals >= threshold).astype(float)                              # (n, 2)
    corr = matched[:, :2] - predicted[:, :2]
    coeff = np.einsum("nij,ni->nj", vecs, corr) * good                    # v_j . c, kept
    out = matched.copy()
    out[:, :2] = predicted[:, :2] + np.einsum("nij,nj->ni", vecs, coeff)
    return out, (good < 1.0).any(axis=1)


def _halve_full(counts_a: np.ndarray, counts_b: np.ndarray, full: np.ndarray) -> None:
    """In the gathered counts, halve both where ``full`` (keeps hits/visits, frees headroom)."""
    counts_a[full] //= 2
    counts_b[full] //= 2


class ParticleMaps:
    """Stacked per-particle count grids (hits, visits), shape (N, H, W) uint8, on ``info``."""

    def __init__(self, n: int, info: GridInfo):
        self.info = info.check_axis_aligned()
        self.hits = np.zeros((n,) + info.shape, dtype=np.uint8)
        self.visits = np.zeros((n,) + info.shape, dtype=np.uint8)

    @property
    def n(self) -> int:
        return self.hits.shape[0]

    def select(self, idx: np.ndarray) -> None:
        """Resampling: particle i takes the map of particle idx[i] (copies).

        For sorted ``idx`` (systematic resampling) the maps are copied in place, only where
        idx[i] != i: slots taking a map from below are filled from the top down, those
        taking one from above from the bottom up, so no slot is read after it was written
        (sorted: a slot read from below is never written from above and vice versa). A
        fancy-indexed copy of the whole stack allocates it anew at every resampling (page
        faults: ~5x the time on a corridor-sized map).
        """
        idx = np.asarray(idx, dtype=np.intp)
        if idx.shape != (self.n,) or np.any(idx[1:] < idx[:-1]):
            self.hits = self.hits[idx]
            self.visits = self.visits[idx]
            return
        slots = np.arange(self.n)
        order = np.concatenate((np.nonzero(idx < slots)[0][::-1], np.nonzero(idx > slots)[0]))
        for i in order.tolist():
            self.hits[i] = self.hits[idx[i]]
            self.visits[i] = self.visits[idx[i]]

    def occupancy(self, p: int, occ_thresh: float) -> np.ndarray:
        """-1/0/100 grid of particle p."""
        return occupancy_from_counts(self.hits[p], self.visits[p], occ_thresh)

    def ensure_contains(self, xmin: float, ymin: float, xmax: float, ymax: float,
                        margin: float) -> bool:
        """Grow the grid (by at least ``margin`` [m] on a side that is too small) so the
        rectangle fits; returns True if it grew."""
        info = self.info
        res = info.resolution
        need = [
            math.ceil((info.origin_x - xmin) / res),   # left
            math.ceil((info.origin_y - ymin) / res),   # bottom
            math.ceil((xmax - info.xmax) / res),       # right
            math.ceil((ymax - info.ymax) / res),       # top
        ]
        if max(need) <= 0:
            return False
        extra = int(math.ceil(margin / res))
        left, bottom, right, top = (k + extra if k > 0 else 0 for k in need)
        pad = ((0, 0), (bottom, top), (left, right))
        self.hits = np.pad(self.hits, pad)
        self.visits = np.pad(self.visits, pad)
        self.info = info.grown(left, bottom, right, top)
        return True

    def _window(self, u: np.ndarray, v: np.ndarray, margin_cells: int) -> Tuple[int, int, int, int]:
        """Cell window [x0, x1) x [y0, y1) around continuous cell coords, clipped to the grid."""
        x0 = max(int(math.floor(float(u.min()))) - margin_cells, 0)
        y0 = max(int(math.floor(float(v.min()))) - margin_cells, 0)
        x1 = min(int(math.ceil(float(u.max()))) + margin_cells + 1, self.info.width)
        y1 = min(int(math.ceil(float(v.max()))) + margin_cells + 1, self.info.height)
        return x0, y0, max(x1, x0 + 1), max(y1, y0 + 1)

    def _to_cells(self, poses: np.ndarray, pts: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Base-frame points (M, 2) seen from every pose (N, 3) -> continuous cell coords (N, M)."""
        res = self.info.resolution
        c = np.cos(poses[:, 2])[:, None]
        s = np.sin(poses[:, 2])[:, None]
        px = pts[None, :, 0]
        py = pts[None, :, 1]
        u = (poses[:, 0:1] - self.info.origin_x + c * px - s * py) / res
        v = (poses[:, 1:2] - self.info.origin_y + s * px + c * py) / res
        return u, v

    def footprint(self, poses: np.ndarray, scan: PreparedScan) -> Tuple[float, float, float, float]:
        """World bounding box [m] of the scan's free polygon seen from all poses."""
        u, v = self._to_cells(poses, scan.free_polygon)
        res = self.info.resolution
        ox, oy = self.info.origin_x, self.info.origin_y
        return (ox + float(u.min()) * res, oy + float(v.min()) * res,
                ox + float(u.max()) * res, oy + float(v.max()) * res)

    def grow_and_register(self, poses: np.ndarray, scan: PreparedScan, pad: float,
                          margin: float) -> bool:
        """Grow the grid to hold the scan seen from every pose (its footprint plus ``pad``
        [m], grown by at least ``margin`` [m]), then ``register`` it; True if it grew."""
        xmin, ymin, xmax, ymax = self.footprint(poses, scan)
        grown = self.ensure_contains(xmin - pad, ymin - pad, xmax + pad, ymax + pad, margin)
        self.register(poses, scan)
        return grown

    def register(self, poses: np.ndarray, scan: PreparedScan) -> None:
        """Add the scan to every particle's map (particle i at poses[i]); the grid must already
        contain the scan (``ensure_contains``)."""
        n = self.n
        if scan.free_polygon.shape[0] < 3 and scan.hits.shape[0] == 0:
            return
        u, v = self._to_cells(poses, scan.free_polygon)
        x0, y0, x1, y1 = self._window(u, v, 1)
        h, w = y1 - y0, x1 - x0
        # Free space: all particles' polygons into one tall mask, band p = rows [p*h, (p+1)*h).
        # Pixel (i, j) has its centre at cell coords (i + 0.5, j + 0.5).
        scale = float(1 << FILL_SHIFT)
        pu = np.rint((u - x0 - 0.5) * scale).astype(np.int32)
        pv = np.rint((v - y0 - 0.5 + h * np.arange(n)[:, None]) * scale).astype(np.int32)
        polys = list(np.stack([pu, pv], axis=-1))
        mask = np.zeros((n * h, w), dtype=np.uint8)
        cv2.fillPoly(mask, polys, 1, lineType=cv2.LINE_8, shift=FILL_SHIFT)
        mask = mask.reshape(n, h, w)
        hit_flat = None
        if scan.hits.shape[0]:
            hu, hv = self._to_cells(poses, scan.hits)
            hx = np.floor(hu).astype(np.int64)
            hy = np.floor(hv).astype(np.int64)
            inside = (hx >= 0) & (hx < self.info.width) & (hy >= 0) & (hy < self.info.height)
            pidx = np.broadcast_to(np.arange(n)[:, None], hx.shape)[inside]
            hx, hy = hx[inside], hy[inside]
            # a hit cell is only counted as hit, never also as traversed in this scan
            in_win = (hx >= x0) & (hx < x1) & (hy >= y0) & (hy < y1)
            mask[pidx[in_win], hy[in_win] - y0, hx[in_win] - x0] = 0
            hit_flat = (pidx * self.info.height + hy) * self.info.width + hx
        self._count_free(mask.view(bool), (slice(None), slice(y0, y1), slice(x0, x1)))
        if hit_flat is not None:
            self._count_hits(hit_flat)

    def _count_free(self, mask: np.ndarray, win: tuple) -> None:
        visits = self.visits[win]
        vals = visits[mask]
        full = vals >= COUNT_MAX
        if full.any():
            hits = self.hits[win]
            hvals = hits[mask]
            _halve_full(vals, hvals, full)
            hits[mask] = hvals
        visits[mask] = vals + 1

    def _count_hits(self, flat: np.ndarray) -> None:
        # Gather, add one, scatter: duplicate indices write the same value, so each cell is
        # counted once per scan however many beams end in it.
        visits = self.visits.reshape(-1)
        hits = self.hits.reshape(-1)
        vals = visits[flat]
        hvals = hits[flat]
        full = vals >= COUNT_MAX
        if full.any():
            _halve_full(vals, hvals, full)
        visits[flat] = vals + 1
        hits[flat] = hvals + 1


def _field_table(occ_thresh: float) -> np.ndarray:
    """Lookup (visits << 8 | hits) -> 0 for occupied cells, 255 otherwise (distance input);
    occupied as in the published map (``count_table``)."""
    return np.where(count_table(occ_thresh) == OCCUPIED, 0, 255).astype(np.uint8)


def _bilinear(c: Tuple[np.ndarray, ...], fu: np.ndarray, fv: np.ndarray) -> np.ndarray:
    """The bilinear patches ``c`` = (d, b, c, e) (``_LikelihoodFields._corners``) at
    offsets fu, fv in their cells: d + fu b + fv (c + fu e)."""
    return c[0] + fu * c[1] + fv * (c[2] + fu * c[3])


class _LikelihoodFields:
    """Per-particle distance fields (distance [m] from each cell to the nearest occupied cell
    of that particle's map, capped at the match radius) over one common window, stacked as a
    tall image; looked up with bilinear interpolation so sub-cell motions change the score
    (nearest-cell lookups let sub-cell odometry errors accumulate into map drift)."""

    def __init__(self, maps: ParticleMaps, window: Tuple[int, int, int, int], cfg: RbpfConfig,
                 table: np.ndarray):
        x0, y0, x1, y1 = window
        res = maps.info.resolution
        self.pad = int(math.ceil(cfg.match_radius / res)) + 1
        self.w = x1 - x0
        self.h = y1 - y0
        self.band = self.h + self.pad
        n = maps.n
        img = field_image(maps.visits, maps.hits, window, self.band, table)
        dist = cv2.distanceTransform(img.reshape(n * self.band, self.w), cv2.DIST_L2,
                                     cv2.DIST_MASK_5)
        dist *= np.float32(res)
        np.minimum(dist, np.float32(cfg.match_radius), out=dist)
        # flat, rows of w cells, particle p's band from row p * band; a lookup reads its
        # cell's four corners (``_corners``, ``climb``): the pad rows below each band keep
        # them inside it
        self.dist = dist.reshape(-1)
        # continuous cell coordinates of the window, pixel centres at integers
        self.origin_x = maps.info.origin_x + (x0 + 0.5) * res
        self.origin_y = maps.info.origin_y + (y0 + 0.5) * res
        self.res = res
        # the distances' cap [m], as the image holds it: the range of climb's score table
        self.radius = float(np.float32(cfg.match_radius))

    def rotated(self, theta: np.ndarray, pts: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """End points ``pts`` (M, 2, base frame) rotated by every ``theta`` [rad], in cells:
        two float32 arrays of shape theta.shape + (M,)."""
        inv = np.float32(1.0 / self.res)
        c = np.cos(theta).astype(np.float32)[..., None]
        s = np.sin(theta).astype(np.float32)[..., None]
        mx = (pts[:, 0] * inv).astype(np.float32)
        my = (pts[:, 1] * inv).astype(np.float32)
        return c * mx - s * my, s * mx + c * my

    def cells(self, x: np.ndarray, y: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """World positions [m] -> continuous window cell coordinates (float32, [..., None])."""
        inv = 1.0 / self.res
        return (((x - self.origin_x) * inv).astype(np.float32)[..., None],
                ((y - self.origin_y) * inv).astype(np.float32)[..., None])

    def interpolate(self, u: np.ndarray, v: np.ndarray, particle: np.ndarray) -> np.ndarray:
        """Bilinear distance [m] at window cell coordinates u, v (n, K, M) of particles
        ``particle`` (n,); modifies u and v. Off-window points clamp to the border."""
        return _bilinear(*self._corners(u, v, particle[:, None, None]))

    def _corners(self, u: np.ndarray, v: np.ndarray, particle: np.ndarray
                 ) -> Tuple[Tuple[np.ndarray, ...], np.ndarray, np.ndarray]:
        """The bilinear patches of the cells under window cell coordinates u, v (clamped
        to the window in place) of particles ``particle`` (broadcast against u): (d, b, c,
        e), each of u's shape, float32, the distance at the cell's corner and
        d + fu b + fv (c + fu e) across the cell; and the offsets fu, fv within the
        cells."""
        np.clip(u, 0.0, self.w - 1.001, out=u)
        np.clip(v, 0.0, self.h - 1.001, out=v)
        iu = u.astype(np.int32)
        iv = v.astype(np.int32)
        # float64 offsets, so the arithmetic (and the match score) stays float64 as before:
        # float32 cut about a quarter more of the CPU, but the filter then took other paths
        # (docs/results/ascc_navigation.md, "The matcher's lookups": not adopted)
        fu = u - iu
        fv = v - iv
        idx = iv * np.int32(self.w)
        idx += iu
        idx += particle.astype(np.int32) * np.int32(self.band * self.w)
        d00 = self.dist.take(idx)
        b = self.dist.take(idx + 1) - d00
        d01 = self.dist.take(idx + np.int32(self.w))
        e = self.dist.take(idx + np.int32(self.w + 1)) - d01 - b
        return (d00, b, d01 - d00, e), fu, fv

    def gradients(self, poses: np.ndarray, particle: np.ndarray, pts: np.ndarray
                  ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At the end points ``pts`` (M, 2, base frame) seen from poses (n, 3) of particles
        ``particle`` (n,): the bilinear distance [m], its gradient (d/dx, d/dy, [m/m]) and
        the end points' offsets from the pose in the map frame (rx, ry [m]); each (n, M).
        Off-window points clamp to the border (gradient 0 across it)."""
        ru, rv = self.rotated(poses[:, None, 2], pts)
        ru, rv = ru[:, 0], rv[:, 0]
        xc, yc = self.cells(poses[:, 0], poses[:, 1])
        c, fu, fv = self._corners(xc + ru, yc + rv, particle[:, None])
        inv = np.float32(1.0 / self.res)
        gx = (c[1] + fv * c[3]) * inv
        gy = (c[2] + fu * c[3]) * inv
        return _bilinear(c, fu, fv), gx, gy, ru * self.res, rv * self.res

    def distances(self, poses: np.ndarray, particle: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """Interpolated distance [m] at the end points ``pts`` (M, 2, base frame) for poses
        (n, K, 3) of particles ``particle`` (n,) -> (n, K, M)."""
        ru, rv = self.rotated(poses[..., 2], pts)
        xc, yc = self.cells(poses[..., 0], poses[..., 1])
        return self.interpolate(xc + ru, yc + rv, particle)

    @staticmethod
    def match_score(d: np.ndarray, sigma: float) -> np.ndarray:
        """sum_b exp(-d_b^2 / (2 sigma^2)) [beams] over the last axis."""
        return np.exp(d * d * np.float32(-0.5 / sigma ** 2)).sum(axis=-1)

    @staticmethod
    def log_likelihood(d: np.ndarray, lsigma: float, radius: float) -> np.ndarray:
        """sum_b -min(d_b, radius)^2 / (2 lsigma^2) over the last axis."""
        d = np.minimum(d.astype(np.float64), radius)
        return -(d * d).sum(axis=-1) / (2.0 * lsigma * lsigma)


class RbpfSlam:
    """The filter: particles (poses, log weights, maps). Feed it with ``update``."""

    def __init__(self, cfg: RbpfConfig, seed: Optional[int] = None):
        cfg.validate()
        self.cfg = cfg
        self.rng = np.random.default_rng(seed)
        self.poses = np.zeros((cfg.particles, 3))
        self.log_w = np.zeros(cfg.particles)
        self.maps = ParticleMaps(cfg.particles, GridInfo.from_bounds(
            cfg.delta, cfg.xmin, cfg.ymin, cfg.xmax, cfg.ymax))
        self.best = 0
        self.initialized = False
        self.updates = 0
        self._table = _field_table(cfg.occ_thresh)
        # each particle's trajectory: the pose at which it registered the scan of update u
        # (column u), carried through resampling like its map (gmapping's particle tree)
        self._history = np.zeros((cfg.particles, 64, 3))
        self._previous: Optional[PreparedScan] = None  # the scan of the last update
        # wall-axis prior: the map-frame direction of the walls (modulo a right angle), from
        # the first scan that shows straight walls, placed at the best particle's pose
        self.wall_reference: Optional[float] = None
        self.reference_scans = 0  # scans averaged into wall_reference

    @property
    def weights(self) -> np.ndarray:
        return normalized_weights(self.log_w)

    @property
    def best_pose(self) -> np.ndarray:
        return self.poses[self.best].copy()

    def occupancy(self) -> Tuple[np.ndarray, GridInfo]:
        """-1/0/100 grid of the best particle and its geometry."""
        return self.maps.occupancy(self.best, self.cfg.occ_thresh), self.maps.info

    def start(self, pose, scan: PreparedScan) -> UpdateStats:
        """Initialise all particles at ``pose`` (x, y, theta in the map frame) with this scan."""
        self.poses[:] = np.asarray(pose, dtype=float)
        self.log_w[:] = 0.0
        self.best = 0
        stats = UpdateStats(entropy=weight_entropy(self.weights), neff=float(self.cfg.particles))
        stats.grown = self._register(scan)
        self._previous = scan
        self.wall_reference = None
        self.reference_scans = 0
        if self.cfg.wall_axis_std_rad > 0.0:  # the reference, if this scan shows walls
            stats.wall_axis = _angle(scan_wall_axis(scan.hits))
            self._weigh_wall_axis(stats.wall_axis, np.zeros(self.cfg.particles))
        self.initialized = True
        self.updates = 1
        self._record(0)
        return stats

    def _record(self, column: int) -> None:
        if column >= self._history.shape[1]:
            grown = np.zeros((self._history.shape[0], 2 * column, 3))
            grown[:, :self._history.shape[1]] = self._history
            self._history = grown
        self._history[:, column] = self.poses

    def trajectory(self, updates: Optional[np.ndarray] = None,
                   particle: Optional[int] = None) -> np.ndarray:
        """The poses (map frame) at which particle ``particle`` (default: the best)
        registered the scans of the given updates (0 = the first scan; default: all): the
        trajectory its map was built from."""
        p = self.best if particle is None else particle
        cols = np.arange(self.updates) if updates is None else np.asarray(updates)
        return self._history[p, cols].copy()

    def set_trajectory(self, updates: np.ndarray, poses: np.ndarray) -> None:
        """Every particle's poses at the given updates replaced (a map rebuilt from them)."""
        self._history[:, np.asarray(updates)] = np.asarray(poses, dtype=float)[None]

    def restart(self, pose, maps: ParticleMaps) -> None:
        """Continue from a map rebuilt elsewhere (the pose graph's loop closure): every
        particle takes a copy of the one-particle ``maps`` and the pose ``pose``, with equal
        weights (the filter's diversity restarts from there)."""
        n = self.cfg.particles
        self.maps.info = maps.info
        self.maps.hits = np.repeat(maps.hits[:1], n, axis=0)
        self.maps.visits = np.repeat(maps.visits[:1], n, axis=0)
        self.poses[:] = np.asarray(pose, dtype=float)
        self.log_w[:] = 0.0
        self.best = 0

    def new_maps(self) -> ParticleMaps:
        """An empty one-particle map on the current grid geometry."""
        return ParticleMaps(1, self.maps.info)

    def wants_still_scans(self) -> bool:
        """Whether ``observe_still`` would use another scan from the start pose."""
        return (self.updates == 1 and self.cfg.wall_axis_std_rad > 0.0
                and self.wall_reference is not None
                and self.reference_scans < self.cfg.wall_axis_reference_scans)

    def observe_still(self, scan: PreparedScan) -> None:
        """A scan taken at the start pose before the robot first moved: its walls'
        direction joins the wall-axis prior's reference (a mean of up to
        ``wall_axis_reference_scans``; every particle is still at the start pose)."""
        if not self.wants_still_scans():
            return
        axis = _angle(scan_wall_axis(scan.hits))
        if axis is None:
            return
        self.wall_reference = float(wrap_right_angle(mean_direction(
            self.wall_reference, self.reference_scans, float(self.poses[self.best, 2]) + axis)))
        self.reference_scans += 1

    def update(self, odom_delta, scan: PreparedScan) -> UpdateStats:
        """One filter step: the robot moved by ``odom_delta`` (dx, dy, dtheta in the previous
        robot frame, from odometry) and then took ``scan``."""
        if not self.initialized:
            raise RuntimeError("RbpfSlam.update() before start()")
        cfg = self.cfg
        stats = UpdateStats()
        odom_delta = np.asarray(odom_delta, dtype=float)
        # without the motion model's noise (draw_along_blind's reference)
        predicted = compose(self.poses, odom_delta) if cfg.draw_along_blind else None
        self.poses = sample_motion(self.poses, odom_delta, cfg, self.rng)
        stats.odom_delta = odom_delta
        stats.sampled_poses = self.poses.copy()
        reach = scan.max_urange - math.hypot(odom_delta[0], odom_delta[1]) - cfg.new_area_margin
        use = scan.match_range <= reach
        if cfg.seen_margin_m >= 0.0 and self._previous is not None:
            use &= seen_before(self._previous, odom_delta, scan.match, cfg.seen_margin_m)
        pts = scan.match[use]
        stats.beams = int(pts.shape[0])
        self._previous = scan
        if pts.shape[0]:
            fields = self._fields(pts)
            s_xy, s_th = motion_noise(odom_delta, cfg)
            inv_var = np.array([max(s_xy, cfg.prior_min_xy) ** -2] * 2
                               + [max(s_th, cfg.prior_min_theta) ** -2])
            if cfg.draw_along_blind:
                self._shrink_blind_draw(fields, pts, predicted, inv_var[0], stats)
            along = cfg.prior_along * inv_var[0]
            if cfg.prior_along_adaptive and along > 0.0:
                stats.along_info, stats.along_angle = self._along_information(
                    fields, pts, cfg.prior_along_blind)
                along = max(0.0, along - 0.5 * stats.along_info)
            stats.along_pull = along
            prior = cfg.motion_prior * inv_var
            matched, score = self._hill_climb(fields, pts, prior, self.poses,
                                              np.arange(cfg.particles),
                                              along=along, along_angle=stats.along_angle)
            if cfg.wall_axis_std_rad > 0.0:
                wall = scan_wall_axis(scan.hits)
                stats.wall_axis = _angle(wall)
                stats.wall_axis_pulled = self._wall_axis_pull(wall, fields, pts, prior,
                                                              matched, score)
            recovered = np.zeros(cfg.particles, dtype=bool)
            if cfg.recover_score > 0.0:
                stats.recovered = self._recover(matched, score, pts, recovered)
            if cfg.degenerate_info > 0.0:
                keep = ~recovered  # a wide heading search's jump is the scan's, whole
                matched[keep], flat = degeneracy_projection(
                    fields, pts, cfg.sigma, self.poses[keep], matched[keep],
                    np.nonzero(keep)[0], max(s_xy, _MIN_STD), cfg.degenerate_info)
                stats.degenerate = int(flat.sum())
                score[keep] = fields.match_score(fields.distances(
                    matched[keep][:, None, :], np.nonzero(keep)[0], pts), cfg.sigma)[:, 0]
            accept = score >= cfg.minimum_score
            self.poses[accept] = matched[accept]
            stats.matched = int(accept.sum())
            stats.mean_score = float(score.mean())
            d = fields.distances(self.poses[:, None, :], np.arange(cfg.particles), pts)[:, 0, :]
            stats.log_gain = fields.log_likelihood(d, cfg.lsigma, cfg.weight_radius) / cfg.ogain
            if cfg.detrend_along:
                stats.log_gain = detrend_along(stats.log_gain, self.poses)
            if cfg.wall_axis_std_rad > 0.0:
                stats.wall_axis_used = self._weigh_wall_axis(stats.wall_axis, stats.log_gain)
            stats.weighed_poses = self.poses.copy()
            self.log_w += stats.log_gain
        self.log_w -= self.log_w.max()
        weights = self.weights
        stats.entropy = weight_entropy(weights)
        stats.neff = effective_sample_size(weights)
        self.best = int(np.argmax(weights))
        if stats.neff < cfg.resample_threshold * cfg.particles:
            idx = low_variance_resample(weights, self.rng)
            stats.resampled_from = idx
            self.poses = self.poses[idx]
            self.maps.select(idx)
            self._history[:, :self.updates] = self._history[idx, :self.updates]
            self.log_w[:] = 0.0
            survivors = np.nonzero(idx == self.best)[0]
            self.best = int(survivors[0]) if survivors.size else 0
            stats.resampled = True
        stats.grown = self._register(scan)
        stats.best = self.best
        self._record(self.updates)
        self.updates += 1
        return stats

    def _shrink_blind_draw(self, fields: _LikelihoodFields, pts: np.ndarray,
                           predicted: np.ndarray, motion_info: float,
                           stats: UpdateStats) -> None:
        """draw_along_blind: the draws' offsets from the noise-free ``predicted`` poses
        scaled along the direction the scan holds least by its information there over
        ``motion_info`` (at most 1); records the share and the draws in ``stats``."""
        least, angle = self._along_information(fields, pts, True)
        stats.draw_along_share = min(1.0, least / motion_info)
        self.poses = shrink_draw(self.poses, predicted, angle + self.poses[self.best, 2],
                                 stats.draw_along_share)
        stats.sampled_poses = self.poses.copy()

    def _along_information(self, fields: _LikelihoodFields, pts: np.ndarray,
                           blind: bool = False) -> Tuple[float, float]:
        """The scan's information [1/m^2] about the position along the best particle's
        heading, at its sampled pose in its own map: h^T I_xy h (``scan_information``), and
        0.0; with ``blind``, its smallest eigenvalue instead, and the angle [rad] of that
        eigenvector from the heading (in (-pi/2, pi/2])."""
        b = self.best
        pose = self.poses[b:b + 1]
        info = scan_information(*fields.gradients(pose, np.array([b]), pts), self.cfg.sigma)[0]
        if blind:
            values, vectors = np.linalg.eigh(info[:2, :2])
            v = vectors[:, 0]
            angle = math.atan2(v[1], v[0]) - pose[0, 2]
            angle = math.atan(math.tan(angle))  # the direction, not its sense
            return float(values[0]), float(angle)
        h = np.array([math.cos(pose[0, 2]), math.sin(pose[0, 2])])
        return float(h @ info[:2, :2] @ h), 0.0

    def _wall_axis_pull(self, wall: Optional[WallAxis], fields: _LikelihoodFields,
                        pts: np.ndarray, prior: np.ndarray, matched: np.ndarray,
                        score: np.ndarray) -> bool:
        """wall_axis_pull_std_rad: the ``matched`` poses (updated in place, with their
        ``score``) moved by one Gauss-Newton step of the match (the scan's information at
        each, plus ``prior``'s x and y terms) with a prior of that std on the heading the
        scan's wall fit ``wall`` (base frame) gives against the wall reference, modulo a
        right angle. Not applied (False) without walls, before the reference, where one of
        the scan's walls is off their common direction by more than the gate, three of the
        pull's std (``WallAxis.disagreement``: another family of walls, whose mix the
        common direction is), or where the median matched heading is further than the gate
        from the walls': the matched heading errs by a milliradian or two, so a side of
        walls a few degrees off the reference is left as the scan matched it. (A gate on
        the predicted heading instead, the odometry's turn added to the last one, has the
        odometry's ~10 mrad error per update: narrow, it skipped scans at random; at the
        prior's 0.03 rad it let a side 3.6 degrees off be pulled straight.)"""
        std = self.cfg.wall_axis_pull_std_rad
        if std <= 0.0 or self.wall_reference is None or wall is None:
            return False
        gate = 3.0 * std
        if wall.disagreement > gate:
            return False
        err = wrap_right_angle(matched[:, 2] + wall.angle - self.wall_reference)
        if abs(float(np.median(err))) > gate:
            return False
        particles = np.arange(matched.shape[0])
        hessian = scan_information(*fields.gradients(matched, particles, pts), self.cfg.sigma)
        hessian = hessian + np.diag([prior[0], prior[1], std ** -2])
        rhs = np.zeros((matched.shape[0], 3, 1))
        rhs[:, 2, 0] = -err / std ** 2
        matched += np.linalg.solve(hessian, rhs)[:, :, 0]
        matched[:, 2] = wrap_angle(matched[:, 2])
        score[:] = fields.match_score(fields.distances(matched[:, None, :], particles, pts),
                                      self.cfg.sigma)[:, 0]
        return True

    def _weigh_wall_axis(self, axis: Optional[float], log_gain: np.ndarray) -> bool:
        """Adds the wall-axis prior's term to ``log_gain`` (in place); False if the scan shows
        no straight walls or walls off the reference directions (the gate)."""
        if axis is None:
            return False
        if self.wall_reference is None:  # the first scan with walls: after matching, the
            self.wall_reference = float(wrap_right_angle(self.poses[self.best, 2] + axis))
            self.reference_scans = 1     # best particle's heading
            return False
        err = wrap_right_angle(self.poses[:, 2] + axis - self.wall_reference)
        gate = self.cfg.wall_axis_gate_rad
        if abs(float(np.median(err))) > gate:
            return False
        err = np.minimum(np.abs(err), gate)
        log_gain -= err * err / (2.0 * self.cfg.wall_axis_std_rad ** 2)
        return True

    def _register(self, scan: PreparedScan) -> bool:
        return self.maps.grow_and_register(self.poses, scan, 2.0 * self.cfg.delta,
                                           self.cfg.grow_margin)

    def _fields(self, pts: np.ndarray) -> _LikelihoodFields:
        u, v = self.maps._to_cells(self.poses, pts)
        margin = int(math.ceil((self.cfg.search_margin + self.cfg.match_radius) / self.cfg.delta))
        return _LikelihoodFields(self.maps, self.maps._window(u, v, margin), self.cfg, self._table)

    def _recover(self, matched: np.ndarray, score: np.ndarray, pts: np.ndarray,
                 moved_mask: Optional[np.ndarray] = None) -> int:
        """Wide heading search for the particles whose matched score is below
        recover_score * beams (see RbpfConfig); updates ``matched`` and ``score`` (and
        marks the moved particles in ``moved_mask``) in place and returns how many
        particles it moved."""
        cfg = self.cfg
        beams = pts.shape[0]
        weak = np.nonzero(score < cfg.recover_score * beams)[0]
        if weak.size == 0 or cfg.recover_angle <= 0.0:
            return 0
        # A window that holds the scan in any heading: maxUrange around the weak particles.
        reach = float(np.max(np.hypot(pts[:, 0], pts[:, 1]))) + cfg.search_margin
        u, v = self.maps._to_cells(matched[weak], np.zeros((1, 2)))
        margin = int(math.ceil((reach + cfg.match_radius) / cfg.delta))
        fields = _LikelihoodFields(self.maps, self.maps._window(u, v, margin), cfg, self._table)
        k = int(cfg.recover_angle / cfg.recover_step)
        offsets = cfg.recover_step * np.arange(-k, k + 1)
        cand = np.repeat(matched[weak, None, :], offsets.size, axis=1)
        cand[..., 2] += offsets
        sc = fields.match_score(fields.distances(cand, weak, pts), cfg.sigma)
        best = np.argmax(sc, axis=1)
        # refine every weak particle from its best heading, without the motion prior
        refined, refined_score = self._hill_climb(fields, pts, np.zeros(3),
                                                  cand[np.arange(weak.size), best], weak)
        better = refined_score >= score[weak] + cfg.recover_gain * beams
        moved = weak[better]
        matched[moved] = refined[better]
        score[moved] = refined_score[better]
        if moved_mask is not None:
            moved_mask[moved] = True
        return int(moved.size)

    def _hill_climb(self, fields: _LikelihoodFields, pts: np.ndarray, prior: np.ndarray,
                    start: np.ndarray, particles: np.ndarray,
                    along: float = 0.0, along_angle: float = 0.0
                    ) -> Tuple[np.ndarray, np.ndarray]:
        """gmapping-style greedy search (``climb``, compiled), pose i from start[i] in the
        map of particle particles[i]: the six moves around the current pose, the best taken
        if it improves the objective, else that pose's steps halved, ``iterations``
        halvings. Objective: match score minus sum_k prior[k] * (pose_k - start_k)^2 minus
        along * ((pose - start)_xy . h_i)^2, h_i the unit vector of start[i]'s heading
        turned by ``along_angle``. Returns the poses and their match scores."""
        cfg = self.cfg
        pose, score = hill_climb(fields, pts, prior, start, particles, cfg.lstep, cfg.astep,
                                 cfg.iterations, cfg.sigma, MAX_CLIMB_STEPS, along,
                                 along_angle)
        pose[:, 2] = wrap_angle(pose[:, 2])
        return pose, score
