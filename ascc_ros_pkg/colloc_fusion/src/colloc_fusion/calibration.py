"""Calibration (thesis 3.4.1): the rigid 2D transform between an external frame (the Vicon
in the thesis; the simulator's ground truth here) and the robots' map, from three or more
landmark correspondences (the desk corners), by least squares with the SVD.

``fit_rigid_2d(src, dst)`` finds the rotation R (det +1) and translation t minimising
sum |R src_i + t - dst_i|^2 (Kabsch / Umeyama without scale): centre both point sets, take
the SVD U S V^T of the 2x2 cross-covariance H = sum (src_i - s)(dst_i - d)^T, R = V diag(1,
sign det(V U^T)) U^T, t = d - R s. The residuals |R src_i + t - dst_i| are reported.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


class CalibrationError(ValueError):
    """Too few, non-finite or degenerate (collinear) correspondences."""


@dataclass
class Rigid2D:
    """p_dst = R(theta) p_src + (tx, ty); ``residuals_m`` of the fit's landmarks [m]."""

    theta: float
    tx: float
    ty: float
    residuals_m: np.ndarray

    @property
    def rotation(self) -> np.ndarray:
        c, s = math.cos(self.theta), math.sin(self.theta)
        return np.array([[c, -s], [s, c]])

    @property
    def rms_m(self) -> float:
        return float(np.sqrt(np.mean(self.residuals_m ** 2)))

    def apply(self, pts) -> np.ndarray:
        """Points (..., 2) from the source frame to the destination frame."""
        pts = np.asarray(pts, dtype=float)
        return pts @ self.rotation.T + np.array([self.tx, self.ty])

    def apply_pose(self, pose) -> np.ndarray:
        """A pose (x, y, yaw) from the source frame to the destination frame."""
        pose = np.asarray(pose, dtype=float)
        x, y = self.apply(pose[:2])
        yaw = math.atan2(math.sin(pose[2] + self.theta), math.cos(pose[2] + self.theta))
        return np.array([x, y, yaw])


def fit_rigid_2d(src, dst) -> Rigid2D:
    """The least-squares rigid transform taking ``src`` (n, 2) onto ``dst`` (n, 2), n >= 3."""
    src = np.asarray(src, dtype=float)
    dst = np.asarray(dst, dtype=float)
    if src.ndim != 2 or src.shape[1] != 2 or src.shape != dst.shape:
        raise CalibrationError("need two (n, 2) point sets of the same size, got %s and %s"
                               % (src.shape, dst.shape))
    if len(src) < 3:
        raise CalibrationError("need at least 3 correspondences, got %d" % len(src))
    if not (np.isfinite(src).all() and np.isfinite(dst).all()):
        raise CalibrationError("correspondences must be finite")
    s_mean, d_mean = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - s_mean, dst - d_mean
    if np.linalg.svd(a, compute_uv=False)[-1] < 1e-9 * max(1.0, np.abs(a).max()):
        raise CalibrationError("the landmarks are collinear: the rotation is not determined")
    u, _, vt = np.linalg.svd(a.T @ b)
    sign = 1.0 if np.linalg.det(vt.T @ u.T) >= 0.0 else -1.0
    rot = vt.T @ np.diag([1.0, sign]) @ u.T
    t = d_mean - rot @ s_mean
    res = np.linalg.norm(src @ rot.T + t - dst, axis=1)
    return Rigid2D(math.atan2(rot[1, 0], rot[0, 0]), float(t[0]), float(t[1]), res)
