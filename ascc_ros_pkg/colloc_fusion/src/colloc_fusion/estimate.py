"""One robot's target estimate in map (thesis eq. 3.6-3.7) and its first-order covariance.

    X = x_robot + d cos(theta_robot + beta)        (3.6)
    Y = y_robot + d sin(theta_robot + beta)        (3.7)

with the robot pose (x, y, theta) [m, m, rad] from the localizer, the target bearing beta
[rad] in base_link and its range d [m]. The covariance is propagated to first order:
Sigma = J_p P J_p^T + J_m diag(sigma_d^2, sigma_beta^2) J_m^T, with P the pose covariance
(x, y, theta) and J_p, J_m the Jacobians of (3.6-3.7) in the pose and in (d, beta);
derivation in docs/design/colloc_fusion.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

UNKNOWN_VARIANCE = 1e6  # [m^2, rad^2] of what a target position does not say (z, rotations)


@dataclass
class TargetEstimate:
    """One robot's target position (x, y) [m] in ``frame_id`` with covariance ``cov``
    (2x2) [m^2], for the target seen at ``stamp_s`` [s] by ``robot``."""

    robot: str
    x: float
    y: float
    cov: np.ndarray
    stamp_s: float
    frame_id: str = "map"

    @property
    def mean(self) -> np.ndarray:
        return np.array([self.x, self.y], dtype=float)


def pose_cov3(cov36: Sequence[float]) -> np.ndarray:
    """The (x, y, yaw) 3x3 block of a 6x6 row-major ROS pose covariance (x y z roll pitch
    yaw): rows/columns 0, 1 and 5."""
    full = np.asarray(cov36, dtype=float).reshape(6, 6)
    idx = [0, 1, 5]
    return full[np.ix_(idx, idx)]


def cov6_of_xy(cov) -> list:
    """A ROS 6x6 row-major pose covariance (x y z roll pitch yaw) of a target position with
    the 2x2 x-y covariance ``cov``: z and the rotations are unknown (UNKNOWN_VARIANCE)."""
    c = [0.0] * 36
    c[0], c[1], c[6], c[7] = (float(v) for v in np.asarray(cov, dtype=float).ravel())
    for i in (14, 21, 28, 35):
        c[i] = UNKNOWN_VARIANCE
    return c


def jacobians(theta: float, d: float, beta: float):
    """J_p (2x3, in x, y, theta) and J_m (2x2, in d, beta) of eq. 3.6-3.7."""
    c, s = math.cos(theta + beta), math.sin(theta + beta)
    jp = np.array([[1.0, 0.0, -d * s], [0.0, 1.0, d * c]])
    jm = np.array([[c, -d * s], [s, d * c]])
    return jp, jm


def estimate_target(robot: str, pose, pose_cov: np.ndarray, range_m: float,
                    bearing_rad: float, range_sigma_m: float, bearing_sigma_rad: float,
                    stamp_s: float, frame_id: str = "map") -> TargetEstimate:
    """Eq. 3.6-3.7 and the first-order covariance. ``pose`` (x, y, theta) [m, m, rad] in
    ``frame_id``, ``pose_cov`` its 3x3 covariance; range and bearing of the target from
    base_link with their standard deviations [m], [rad]. No check here: see
    ``association.check_estimate``."""
    x, y, theta = (float(v) for v in pose)
    a = theta + bearing_rad
    jp, jm = jacobians(theta, range_m, bearing_rad)
    meas = np.diag([range_sigma_m ** 2, bearing_sigma_rad ** 2])
    cov = jp @ np.asarray(pose_cov, dtype=float) @ jp.T + jm @ meas @ jm.T
    cov = 0.5 * (cov + cov.T)
    return TargetEstimate(robot, x + range_m * math.cos(a), y + range_m * math.sin(a), cov,
                          stamp_s, frame_id)


def bad_measurement(range_m: float, bearing_rad: float, range_sigma_m: float,
                    bearing_sigma_rad: float) -> Optional[str]:
    """Why a range/bearing measurement cannot make an estimate (None: it can)."""
    if not (math.isfinite(range_m) and range_m > 0.0):
        return "range %r m is not a positive finite number" % range_m
    if not math.isfinite(bearing_rad):
        return "bearing %r rad is not finite" % bearing_rad
    if not (math.isfinite(range_sigma_m) and range_sigma_m > 0.0
            and math.isfinite(bearing_sigma_rad) and bearing_sigma_rad > 0.0):
        return "range/bearing noise (%r m, %r rad) must be positive and finite" \
            % (range_sigma_m, bearing_sigma_rad)
    return None


def pick_detection(detections, kind: str, laser_only: bool, range_laser: int,
                   range_size: int):
    """The best (first) detection of ``kind`` with a usable range: laser, or also a size
    estimate unless ``laser_only``; None if there is none."""
    sources = (range_laser,) if laser_only else (range_laser, range_size)
    for det in detections:
        if det.kind == kind and det.range_source in sources:
            return det
    return None
