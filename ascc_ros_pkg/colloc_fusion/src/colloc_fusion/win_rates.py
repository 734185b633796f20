"""How often can an ideal fusion beat a single robot? The benchmark's yardstick.

Model: each robot i's error (its estimate minus the truth) in a trial is an independent,
unbiased 2D Gaussian with covariance sigma_i^2 I (its per-trial error is then Rayleigh
with scale sigma_i); the ideal fusion weights the estimates by 1 / sigma_i^2, the
information filter with the true variances. Three readings of "below the best single
robot in a trial":

- ``per_trial_best``: below the smallest of the robots' errors in that trial, the robot
  chosen afterwards with the truth. Out of reach of any fusion: with three equal robots
  the fused error (Rayleigh scale sigma / sqrt(3)) is below that minimum in about half
  of the trials, whatever the robots' relative accuracies.
- ``best_on_average``: below the error of one robot fixed in advance, the one with the
  smallest sigma (the robot best on average).
- ``median_robot``: below the middle one of the robots' errors in that trial.

The fused estimate contains the compared robot's own estimate, so their errors are
correlated; ``p_closer`` gives P(|X| < |Y|) in closed form for jointly Gaussian
isotropic 2D errors X, Y with any correlation, and ``p_fused_beats_robot`` the fixed
robot case. With independent errors instead (the fused error compared with another
draw of the robot's), equal robots give the simple P(R_{s/sqrt(n)} < R_s) = n / (n + 1):
3/4 for three robots; with the correlation (the real comparison) it is
1/2 + sqrt((n - 1) / (n + 3)) / 2: 0.789 for three.
"""
from __future__ import annotations

import math
from typing import Dict, Optional, Sequence

import numpy as np

# the per-trial error of a 2D isotropic Gaussian is Rayleigh: median = sigma sqrt(2 ln 2)
RAYLEIGH_MEDIAN = math.sqrt(2.0 * math.log(2.0))


def rayleigh_sigma(errors: Sequence[float]) -> float:
    """The Rayleigh scale sigma [m] of error magnitudes [m] from their median (robust to
    a few far-off robots, e.g. a wrong amcl convergence, which the model has not)."""
    e = np.asarray(errors, dtype=float)
    e = e[np.isfinite(e)]
    if e.size == 0:
        raise ValueError("no finite errors")
    return float(np.median(e)) / RAYLEIGH_MEDIAN


def p_closer(var_x: float, var_y: float, cov_xy: float) -> float:
    """P(|X| < |Y|) for 2D errors X, Y whose x components (and, independently of those,
    their y components) are jointly Gaussian, zero mean, with variances ``var_x``,
    ``var_y`` and covariance ``cov_xy``.

    |Y|^2 - |X|^2 summed over the two components is lam1 G1 + lam2 G2 with G1, G2
    independent chi-square(2) (exponential) and lam1 > 0 > lam2 the eigenvalues of
    diag(-1, 1) C, C = [[var_x, cov_xy], [cov_xy, var_y]]; so P = lam1 / (lam1 - lam2)
    = 1/2 + (var_y - var_x) / (2 sqrt((var_x + var_y)^2 - 4 cov_xy^2)).
    """
    disc = (var_x + var_y) ** 2 - 4.0 * cov_xy ** 2
    if var_x < 0.0 or var_y < 0.0 or disc <= 0.0:
        raise ValueError("not a valid non-degenerate covariance: %r %r %r"
                         % (var_x, var_y, cov_xy))
    return 0.5 + (var_y - var_x) / (2.0 * math.sqrt(disc))


def fused_variance(sigmas: Sequence[float]) -> float:
    """The ideal (inverse-variance) fusion's per-axis variance [m^2]."""
    s = np.asarray(sigmas, dtype=float)
    return float(1.0 / np.sum(1.0 / s ** 2))


def p_fused_beats_robot(sigmas: Sequence[float], k: int, independent: bool = False
                        ) -> float:
    """P(ideal fusion's error < robot k's error) in closed form. The fused error
    f = sum w_i e_i, w_i = vf / sigma_i^2 and vf the fused variance, has
    cov(f, e_k) = w_k sigma_k^2 = vf; ``independent``: as if it were 0."""
    vf = fused_variance(sigmas)
    return p_closer(vf, float(sigmas[k]) ** 2, 0.0 if independent else vf)


def simulate_errors(sigmas: Sequence[float], trials: int, rng: np.random.Generator
                    ) -> Dict[str, np.ndarray]:
    """Per trial: each robot's error magnitude (``robots``: trials x n) and the ideal
    fusion's (``fused``), drawn from the model."""
    s = np.asarray(sigmas, dtype=float)
    e = rng.standard_normal((trials, s.size, 2)) * s[None, :, None]
    w = (1.0 / s ** 2) / np.sum(1.0 / s ** 2)
    f = np.einsum("i,tij->tj", w, e)
    return {"robots": np.linalg.norm(e, axis=2), "fused": np.linalg.norm(f, axis=1)}


def win_rates(sigmas: Sequence[float], trials: int = 200000, seed: int = 0,
              fused_errors: Optional[np.ndarray] = None) -> Dict[str, float]:
    """Monte Carlo share of trials in which the ideal fusion of robots with Rayleigh scales
    ``sigmas`` [m] is below (a) ``per_trial_best``, (b) ``best_on_average`` (the robot
    with the smallest sigma, fixed in advance), (c) ``median_robot``; ``closed_form_b``:
    (b) from ``p_fused_beats_robot``. ``fused_errors``: compare these (trials) instead
    of the ideal fusion's (e.g. an independent draw)."""
    sim = simulate_errors(sigmas, trials, np.random.default_rng(seed))
    r = sim["robots"]
    f = sim["fused"] if fused_errors is None else np.asarray(fused_errors, dtype=float)
    k = int(np.argmin(np.asarray(sigmas, dtype=float)))
    return {"per_trial_best": float(np.mean(f < r.min(axis=1))),
            "best_on_average": float(np.mean(f < r[:, k])),
            "median_robot": float(np.mean(f < np.median(r, axis=1))),
            "closed_form_b": p_fused_beats_robot(sigmas, k),
            "trials": trials}


def p_majority(n: int, p: float) -> float:
    """P(more than half of ``n`` independent trials are wins) at a win rate ``p``: the
    chance that "in most trials" is met over a benchmark of n trials."""
    return float(sum(math.comb(n, k) * p ** k * (1.0 - p) ** (n - k)
                     for k in range(n // 2 + 1, n + 1)))
