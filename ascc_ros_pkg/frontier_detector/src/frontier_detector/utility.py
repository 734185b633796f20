"""Utility of frontier candidates, thesis eq. (2.1)/(2.2):

    U(x) = wS * wI * U_I(x) + wE * wN * U_N(x) + wL * U_L(x),     x* = argmax_x U(x)

U_I  information gain: unknown area visible from x, by ray casting on the grid within the
     laser range (rays pass free and unknown cells and stop at the first occupied cell),
     as a fraction of the full disc pi * range^2; each ray sample stands for the area
     r * dtheta * dr it covers. In [0, 1].
U_N  navigation term: exp(-L / distance_scale_m), L = path length [m] on the grid from the
     robot (see paths.py), so shorter paths are more appealing. In (0, 1].
U_L  localizability: fraction of `loc_sectors` equal angular sectors around x in which a
     ray meets an occupied cell through free cells only (known structure the laser can
     match against; structure on several sides constrains the pose). In [0, 1].
wS   scenario coefficient (room or corridor, see scenario.py); wI, wN, wL weights.
wE   entropy coefficient: 1 + entropy_gain * max(0, H - entropy_ref), H = pose entropy
     from slam_gmapping/entropy [nats]: an uncertain pose makes long trips less attractive.

Candidates whose visible unknown area U_I * pi * range^2 is below `min_info_gain_m2` are not
chosen by the utility strategy (a corner the laser missed is not worth a long trip).
`nearest` strategy: the candidate with the shortest path (ties: larger cluster), like
explore_lite's pure nearest-frontier rule. No ROS import.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, Optional

import numpy as np
from numba import njit

from ascc_common.grid import OCCUPIED, UNKNOWN
from ascc_common.params import param

STRATEGIES = ("utility", "nearest")


@dataclass
class UtilityParams:
    """Weights and sensor model of eq. (2.1) (``ascc_common.params``)."""

    w_info: float = param(1.0, "wI")
    w_nav: float = param(1.0, "wN")
    w_loc: float = param(0.1, "wL")
    sensor_range_m: float = param(4.0, "[m] ray length (Hokuyo URG-04LX: 4.0 m)")
    n_rays: int = param(72, "rays per candidate over 360 deg")
    loc_sectors: int = param(8, "angular sectors for U_L")
    distance_scale_m: float = param(4.0, "[m] U_N = exp(-L / distance_scale_m)")
    entropy_gain: float = param(0.5, "[1/nat] wE slope")
    entropy_ref: float = param(0.0, "[nat] entropy at which wE starts to grow")
    min_info_gain_m2: float = param(1.0, "[m^2] utility strategy: skip candidates seeing less")

    def validate(self) -> None:
        if self.sensor_range_m <= 0.0 or self.distance_scale_m <= 0.0:
            raise ValueError("sensor_range_m and distance_scale_m must be > 0")
        if self.n_rays < 4 or self.loc_sectors < 1 or self.loc_sectors > self.n_rays:
            raise ValueError("need n_rays >= 4 and 1 <= loc_sectors <= n_rays")
        if self.entropy_gain < 0.0:
            raise ValueError("entropy_gain must be >= 0")


@dataclass
class Scores:
    """Per-candidate terms and the total; `best` is the chosen index or -1."""

    info: np.ndarray
    nav: np.ndarray
    loc: np.ndarray
    path_m: np.ndarray
    total: np.ndarray
    w_scenario: float
    w_entropy: float
    best: int
    timings_ms: Dict[str, float] = field(default_factory=dict)


def entropy_weight(entropy: Optional[float], params: UtilityParams) -> float:
    """wE from the pose entropy [nats]; 1.0 when unknown or not finite."""
    if entropy is None or not math.isfinite(entropy):
        return 1.0
    return 1.0 + params.entropy_gain * max(0.0, float(entropy) - params.entropy_ref)


def ray_offsets(resolution: float, params: UtilityParams):
    """Integer cell offsets (dr, dc) of every ray sample, (n_rays, n_steps), and the area
    [m^2] each sample stands for, per step."""
    n_steps = max(1, int(math.ceil(params.sensor_range_m / resolution)))
    theta = np.arange(params.n_rays) * (2.0 * math.pi / params.n_rays)
    s = np.arange(1, n_steps + 1, dtype=np.float64)                      # [cells]
    dr = np.rint(np.sin(theta)[:, None] * s[None, :]).astype(np.int64)
    dc = np.rint(np.cos(theta)[:, None] * s[None, :]).astype(np.int64)
    area = (s * resolution) * (2.0 * math.pi / params.n_rays) * resolution
    return dr, dc, area


def cast_rays(grid: np.ndarray, resolution: float, rows: np.ndarray, cols: np.ndarray,
              params: UtilityParams):
    """Ray cast from candidate cells; returns (U_I, U_L), one value per candidate.

    Samples off the map end their ray (nothing to see there) and are not landmarks.
    """
    rows = np.asarray(rows, dtype=np.int64).ravel()
    cols = np.asarray(cols, dtype=np.int64).ravel()
    n = rows.size
    if n == 0:
        return np.zeros(0), np.zeros(0)
    dr, dc, area = ray_offsets(resolution, params)
    # The rays are marched (compiled) up to their first stop; the unknown samples before
    # it are summed in float32 by one matrix product, as numpy always has summed them.
    seen = np.zeros((n,) + dr.shape, bool)                              # (C, R, S)
    hit = np.zeros((n, dr.shape[0]), bool)                              # (C, R)
    _march_rays(np.asarray(grid, dtype=np.int8), rows, cols, dr, dc, seen, hit)
    ray_info = seen.astype(np.float32) @ area.astype(np.float32)              # (C, R)
    info = ray_info.sum(axis=1) / (math.pi * params.sensor_range_m ** 2)
    starts = (np.arange(params.loc_sectors) * params.n_rays) // params.loc_sectors
    per_sector = np.logical_or.reduceat(hit, starts, axis=1)             # (C, sectors)
    loc = per_sector.mean(axis=1)
    return np.minimum(info.astype(np.float64), 1.0), loc


@njit(cache=True, nogil=True)
def _march_rays(grid, rows, cols, dr, dc, seen, hit):
    """For candidate i and ray j, walk the samples (rows[i] + dr[j, s], cols[i] + dc[j, s])
    until the first OCCUPIED one or the first off the map: seen[i, j, s] = the sample
    before it is UNKNOWN; hit[i, j] = the ray stopped at an OCCUPIED cell with no UNKNOWN
    before it (a landmark reached through free cells only)."""
    h, w = grid.shape
    n_rays, n_steps = dr.shape
    for i in range(rows.size):
        for j in range(n_rays):
            unknown = False
            for s in range(n_steps):
                r = rows[i] + dr[j, s]
                c = cols[i] + dc[j, s]
                if r < 0 or r >= h or c < 0 or c >= w:
                    break
                v = grid[r, c]
                if v == OCCUPIED:
                    hit[i, j] = not unknown
                    break
                if v == UNKNOWN:
                    seen[i, j, s] = True
                    unknown = True


def score_candidates(grid: np.ndarray, resolution: float, rows: np.ndarray, cols: np.ndarray,
                     path_m: np.ndarray, cluster_cells: np.ndarray, params: UtilityParams,
                     strategy: str = "utility", w_scenario: float = 1.0,
                     entropy: Optional[float] = None,
                     allowed: Optional[np.ndarray] = None) -> Scores:
    """Evaluate eq. (2.1) for every candidate and pick x* (or the nearest one).

    path_m: path length [m] per candidate (inf = unreachable, never chosen);
    allowed: optional boolean mask (e.g. not blacklisted); disallowed ones are never chosen.
    """
    params.validate()
    if strategy not in STRATEGIES:
        raise ValueError(f"strategy must be one of {STRATEGIES}, not {strategy!r}")
    t0 = time.perf_counter()
    path_m = np.asarray(path_m, dtype=np.float64)
    n = path_m.size
    w_e = entropy_weight(entropy, params)
    ok = np.isfinite(path_m)
    if allowed is not None:
        ok &= np.asarray(allowed, dtype=bool)
    if strategy == "nearest":
        info = np.zeros(n)
        loc = np.zeros(n)
    else:
        info, loc = cast_rays(grid, resolution, rows, cols, params)
    t_rays = (time.perf_counter() - t0) * 1e3
    nav = np.exp(-np.where(np.isfinite(path_m), path_m, np.inf) / params.distance_scale_m)
    if strategy == "nearest":
        total = -path_m.copy()
        key = np.lexsort((-np.asarray(cluster_cells, dtype=np.float64), path_m))
        candidates = [int(i) for i in key if ok[i]]
        best = candidates[0] if candidates else -1
    else:
        total = (w_scenario * params.w_info * info + w_e * params.w_nav * nav
                 + params.w_loc * loc)
        # Visible unknown area [m^2] too small to be worth the trip (0 disables the rule).
        ok &= info * (math.pi * params.sensor_range_m ** 2) >= params.min_info_gain_m2
        masked = np.where(ok, total, -np.inf)
        best = int(np.argmax(masked)) if ok.any() else -1
    timings = {"rays": t_rays, "utility": (time.perf_counter() - t0) * 1e3}
    return Scores(info, nav, loc, path_m, total, w_scenario, w_e, best, timings)
