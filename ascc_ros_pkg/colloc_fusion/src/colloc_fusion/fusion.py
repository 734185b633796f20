"""Fusion of the robots' target estimates (thesis 3.4.2) and two covariance-based options.

``thesis``: the inverse-uncertainty weighting exactly as printed (eq. 3.1-3.5): the
weights of x from the x uncertainties U_x (variances [m^2], as in Table 3.1), those of y
from the y uncertainties, each normalised to sum to one:

    W_i = (1/U_i) / sum_j (1/U_j)       (3.1-3.3)
    X = sum_i X_i W_i,  Y = sum_i Y_i W_i   (3.4-3.5, W from U_x and from U_y)

Its covariance (not in the thesis) is what the rule implies for independent estimates:
diag(1 / sum 1/U_x, 1 / sum 1/U_y).

``information``: the information filter, P = (sum P_i^-1)^-1, x = P sum P_i^-1 x_i. It
is optimal for independent estimates and, with diagonal covariances, gives the thesis's
numbers. It is overconfident when the estimates are correlated.

``ci``: covariance intersection, P^-1 = sum w_i P_i^-1, x = P sum w_i P_i^-1 x_i, with the
weights w on the simplex chosen to minimise the trace of P (``criterion="trace"``, the
default: the bound on the expected squared position error) or its determinant
(``"det"``). P is consistent (P >= the true error covariance) whatever the correlation.
Both criteria are convex in w; two estimates are solved by golden-section search, more by
a pattern search along the simplex's edge directions with a shrinking step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .estimate import TargetEstimate

METHODS = ("thesis", "information", "ci")
CI_CRITERIA = ("trace", "det")
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


class FusionError(ValueError):
    """Nothing could be fused (no estimate, or a result that is not finite)."""


@dataclass
class Fused:
    """The fused target position (x, y) [m] with covariance ``cov`` [m^2], the robots it
    is made of and their weights (thesis: the x weights; ci: w; information: none, its
    weights are matrices), the robots left out with why."""

    x: float
    y: float
    cov: np.ndarray
    robots: List[str]
    weights: List[float]
    left_out: Dict[str, str] = field(default_factory=dict)


def thesis_weights(u: Sequence[float]) -> np.ndarray:
    """Eq. 3.1-3.3: W_i = (1/U_i) / sum_j (1/U_j) for positive uncertainties U."""
    inv = 1.0 / np.asarray(u, dtype=float)
    return inv / inv.sum()


def thesis_fuse(x: Sequence[float], y: Sequence[float], ux: Sequence[float],
                uy: Sequence[float]) -> Tuple[float, float, float, float]:
    """Eq. 3.4-3.5: (X, Y) with the x weights from ``ux`` and the y weights from ``uy``;
    also the variances (1/sum 1/ux, 1/sum 1/uy) the rule implies for independent inputs."""
    wx, wy = thesis_weights(ux), thesis_weights(uy)
    var_x = 1.0 / float(np.sum(1.0 / np.asarray(ux, dtype=float)))
    var_y = 1.0 / float(np.sum(1.0 / np.asarray(uy, dtype=float)))
    return (float(np.dot(wx, np.asarray(x, dtype=float))),
            float(np.dot(wy, np.asarray(y, dtype=float))), var_x, var_y)


def information_fuse(means: Sequence[Sequence[float]],
                     covs: Sequence[np.ndarray]) -> Tuple[np.ndarray, np.ndarray]:
    """The information filter: (x, P) with P = (sum P_i^-1)^-1, x = P sum P_i^-1 x_i."""
    infos = [np.linalg.inv(np.asarray(c, dtype=float)) for c in covs]
    cov = np.linalg.inv(sum(infos))
    mean = cov @ sum(i @ np.asarray(m, dtype=float) for i, m in zip(infos, means))
    return mean, 0.5 * (cov + cov.T)


def _ci_objective(infos: np.ndarray, criterion: str):
    """f(w) for weight vectors w (..., n): trace or det of (sum w_i I_i)^-1, vectorised."""
    def f(w: np.ndarray) -> np.ndarray:
        info = np.einsum("...i,ijk->...jk", w, infos)
        det = info[..., 0, 0] * info[..., 1, 1] - info[..., 0, 1] * info[..., 1, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            if criterion == "det":
                val = 1.0 / det
            else:
                val = (info[..., 0, 0] + info[..., 1, 1]) / det
        return np.where(det > 0.0, val, np.inf)
    return f


def ci_weights(covs: Sequence[np.ndarray], criterion: str = "trace",
               tol: float = 1e-10) -> np.ndarray:
    """The covariance-intersection weights w (on the simplex) minimising ``criterion``
    ("trace" or "det") of the fused 2x2 covariance."""
    if criterion not in CI_CRITERIA:
        raise ValueError("criterion must be one of %s, not %r" % (CI_CRITERIA, criterion))
    infos = np.array([np.linalg.inv(np.asarray(c, dtype=float)) for c in covs])
    n = len(infos)
    if n == 1:
        return np.ones(1)
    f = _ci_objective(infos, criterion)
    if n == 2:  # golden-section search on w_0 in [0, 1]
        lo, hi = 0.0, 1.0
        while hi - lo > tol:
            a, b = hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo)
            fa, fb = f(np.array([a, 1.0 - a])), f(np.array([b, 1.0 - b]))
            if fa <= fb:
                hi = b
            else:
                lo = a
        cands = np.array([[0.0, 1.0], [1.0, 0.0], [(lo + hi) / 2, 1.0 - (lo + hi) / 2]])
        return cands[int(np.argmin(f(cands)))]
    # pattern search along the edge directions e_i - e_j, shrinking step
    dirs = np.array([np.eye(n)[i] - np.eye(n)[j] for i in range(n) for j in range(n)
                     if i != j])
    w = np.full(n, 1.0 / n)
    best = float(f(w))
    step = 0.5
    while step > tol:
        cands = w + step * dirs
        cands = cands[(cands >= 0.0).all(axis=1)]
        vals = f(cands) if len(cands) else np.array([np.inf])
        k = int(np.argmin(vals))
        if vals[k] < best:
            w, best = np.clip(cands[k], 0.0, None), float(vals[k])
            w = w / w.sum()
        else:
            step *= 0.5
    return w


def covariance_intersection(means: Sequence[Sequence[float]], covs: Sequence[np.ndarray],
                            criterion: str = "trace") -> Tuple[np.ndarray, np.ndarray,
                                                              np.ndarray]:
    """Covariance intersection: (x, P, w) with P^-1 = sum w_i P_i^-1 and
    x = P sum w_i P_i^-1 x_i, w minimising ``criterion`` of P."""
    w = ci_weights(covs, criterion)
    infos = [np.linalg.inv(np.asarray(c, dtype=float)) for c in covs]
    info = sum(wi * i for wi, i in zip(w, infos))
    cov = np.linalg.inv(info)
    mean = cov @ sum(wi * i @ np.asarray(m, dtype=float) for wi, i, m in zip(w, infos, means))
    return mean, 0.5 * (cov + cov.T), w


def fuse(estimates: Sequence[TargetEstimate], method: str = "thesis",
         ci_criterion: str = "trace", left_out: Optional[Dict[str, str]] = None) -> Fused:
    """The estimates (already checked: see ``association``) fused by ``method``;
    FusionError when there is none or the result is not finite (never a NaN out)."""
    if method not in METHODS:
        raise ValueError("method must be one of %s, not %r" % (METHODS, method))
    if not estimates:
        raise FusionError("no estimate to fuse")
    robots = [e.robot for e in estimates]
    means = [e.mean for e in estimates]
    covs = [np.asarray(e.cov, dtype=float) for e in estimates]
    try:
        with np.errstate(all="ignore"):  # an overflow shows as non-finite: checked below
            if method == "thesis":
                ux = [c[0, 0] for c in covs]
                x, y, vx, vy = thesis_fuse([m[0] for m in means], [m[1] for m in means], ux,
                                           [c[1, 1] for c in covs])
                mean, cov, weights = np.array([x, y]), np.diag([vx, vy]), thesis_weights(ux)
            elif method == "information":
                mean, cov = information_fuse(means, covs)
                weights = np.zeros(0)  # matrix weights: no scalar per robot
            else:
                mean, cov, weights = covariance_intersection(means, covs, ci_criterion)
    except np.linalg.LinAlgError as err:
        raise FusionError("fusion failed: %s" % err) from err
    if not (np.isfinite(mean).all() and np.isfinite(cov).all()):
        raise FusionError("fusion of %s gave a non-finite result" % ", ".join(robots))
    return Fused(float(mean[0]), float(mean[1]), cov, robots, [float(w) for w in weights],
                 dict(left_out or {}))
