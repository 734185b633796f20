"""Hokuyo URG-04LX model: vectorised ray casting on the grid and on circles, plus noise.

Geometry (datasheet, thesis section 2.2): 240 deg field of view, 1024 steps per turn
(0.352 deg, the "0.36 deg" of the datasheet), so 683 beams from -120 deg to +119.77 deg,
0.02-4.094 m, 100 ms per scan, range accuracy +-3 %. Returns follow REP 117: no return
within ``range_max`` -> +inf, closer than ``range_min`` -> -inf, dropped return -> NaN.

Ray casting walks all beams at once (numpy, no per-beam loop) through exactly the cells
each beam passes (see :class:`RayCaster`) and computes the exact entry distance into the
first solid one, so ranges are exact for the cell squares. Circles (cones, legs, people,
other robots) are intersected analytically.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

import cv2
import numpy as np

from ascc_common.params import param

from .grid import GridMap


@dataclass(frozen=True)
class LaserConfig:
    """The laser model's parameters (the simulator's ``~laser/*``, config/urg04lx.yaml);
    angles may be given in degrees (``angle_min_deg`` for ``angle_min_rad``)."""

    angle_min_rad: float = param(-120.0 * math.pi / 180.0, "[rad] first beam", degrees=True)
    angle_max_rad: float = param(120.0 * math.pi / 180.0, "[rad] last beam at most",
                                 degrees=True)
    angle_increment_rad: float = param(2.0 * math.pi / 1024.0, "[rad] between beams",
                                       degrees=True, gt=0.0)
    range_min_m: float = param(0.02, "[m] closer returns are -inf", ge=0.0)
    range_max_m: float = param(4.094, "[m] no return within it is +inf")
    scan_period_s: float = param(0.1, "[s] time per scan", gt=0.0)
    noise_sigma_frac: float = param(0.01, "[-] Gaussian range noise, fraction of the range")
    noise_max_frac: float = param(0.03, "[-] noise clipped to +- this (datasheet accuracy)")
    range_quantum_m: float = param(0.001, "[m] the sensor reports millimetres")
    far_dropout_start_m: float = param(3.0, "[m] dropout probability rises from here ...")
    far_dropout_prob: float = param(0.3, "[-] ... quadratically to this at range_max")
    grazing_start_rad: float = param(70.0 * math.pi / 180.0, "[rad] incidence where "
                                     "dropouts start", degrees=True)
    grazing_dropout_prob: float = param(0.8, "[-] dropout probability at 90 deg incidence")
    step_cells: float = param(0.95, "[cells] ray-casting sample spacing, < 1", gt=0.0)

    def validate(self) -> None:
        if self.angle_max_rad <= self.angle_min_rad:
            raise ValueError("laser angles: need angle_max > angle_min")
        if not self.range_min_m < self.range_max_m:
            raise ValueError("laser ranges: need range_min_m < range_max_m")
        if not self.step_cells < 1.0:
            raise ValueError("laser step_cells must be within (0, 1)")

    @property
    def n_beams(self) -> int:
        """Beams from angle_min within angle_max (the last beam may end short of it)."""
        return int(math.floor((self.angle_max_rad - self.angle_min_rad)
                              / self.angle_increment_rad + 1e-6)) + 1

    @property
    def angles(self) -> np.ndarray:
        return self.angle_min_rad + np.arange(self.n_beams) * self.angle_increment_rad


class RayCaster:
    """Exact ray casting against a grid's solid cells, all beams at once.

    Beams are sampled every ``step_cells`` (< 1 cell): between two samples a beam crosses
    at most one vertical and one horizontal cell border, so the cells it passes through
    are the sample cells plus, where a step changes both row and column, the one corner
    cell in between (which one follows from which border comes first). Checking both
    gives the exact cell traversal without a per-beam loop. The solid layer is padded
    with empty cells as wide as the maximum range (no bounds checks), samples are taken
    in chunks, and beams that hit something leave the working set.
    """

    def __init__(self, grid: GridMap, max_range_m: float, step_cells: float = 0.95,
                 chunk: int = 48):
        if not 0.0 < step_cells < 1.0:
            raise ValueError("step_cells must be within (0, 1)")
        self.grid = grid
        self.max_range = float(max_range_m)
        self._pad = int(math.ceil(self.max_range / grid.info.resolution)) + 2
        padded = np.pad(grid.solid, self._pad, constant_values=False)
        self._pw = padded.shape[1]
        # One byte per cell: bit 1 = solid, bit 0 = solid or next to a solid cell (only
        # there can a corner cell between two samples be solid).
        near = cv2.dilate(padded.astype(np.uint8), np.ones((3, 3), np.uint8))
        self._codes = (near | (padded.astype(np.uint8) << 1)).ravel()
        self._flat = padded.ravel()
        self._step = float(step_cells)
        n = int(math.ceil(self.max_range / grid.info.resolution / self._step)) + 1
        # Sample distances in cells (float32 keeps the (beams x samples) arrays small).
        self._t_cells = np.arange(1, n + 1, dtype=np.float32) * np.float32(self._step)
        self._chunk = max(1, int(chunk))

    def cast(self, x: float, y: float, angles: np.ndarray
             ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cast rays from map point (x, y) [m] along absolute angles [rad].

        Returns ``(ranges_m, cos_incidence, cell_index)``: range to the first solid cell
        (+inf when none within max range), |cos| of the angle between the ray and the hit
        face's normal, and the flat cell index hit (-1 when none).
        """
        g = self.grid.info
        n = len(angles)
        ranges = np.full(n, np.inf)
        cos_inc = np.ones(n)
        cell = np.full(n, -1, dtype=np.int64)
        u0 = (x - g.origin_x) / g.resolution
        v0 = (y - g.origin_y) / g.resolution
        if not (0.0 <= u0 < g.width and 0.0 <= v0 < g.height):
            return ranges, cos_inc, cell  # the laser is outside the world
        c = np.cos(angles)
        s = np.sin(angles)
        # Nothing solid lies closer than the clearance at the laser's cell (minus both
        # half diagonals): start sampling there.
        clear_cells = self.grid.clearance_m[int(v0), int(u0)] / g.resolution - math.sqrt(2.0)
        k_start = max(0, int(clear_cells / self._step) - 1)
        # Padded cell coordinates are always >= 0, so a cast to int is the floor.
        k, hu_p, hv_p = self._first_hits(c.astype(np.float32), s.astype(np.float32),
                                         np.float32(u0 + self._pad),
                                         np.float32(v0 + self._pad), k_start)
        b = np.nonzero(k >= 0)[0]
        if len(b) == 0:
            return ranges, cos_inc, cell
        hu = (hu_p[b] - self._pad).astype(np.float64)
        hv = (hv_p[b] - self._pad).astype(np.float64)
        cb, sb = c[b], s[b]
        # Slab test: entry parameter (in cells) into the hit cell's square, kept within
        # the step where the traversal found it.
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(cb > 0, (hu - u0) / cb, np.where(cb < 0, (hu + 1 - u0) / cb,
                                                            -np.inf))
            ty = np.where(sb > 0, (hv - v0) / sb, np.where(sb < 0, (hv + 1 - v0) / sb,
                                                            -np.inf))
        t_hit = np.clip(np.maximum(tx, ty), k[b] * self._step, (k[b] + 1) * self._step)
        r = t_hit * g.resolution
        keep = r <= self.max_range
        idx = b[keep]
        ranges[idx] = r[keep]
        cos_inc[idx] = np.where(tx >= ty, np.abs(cb), np.abs(sb))[keep]
        cell[idx] = (hv * g.width + hu).astype(np.int64)[keep]
        return ranges, cos_inc, cell

    def _first_hits(self, c32: np.ndarray, s32: np.ndarray, up: np.float32,
                    vp: np.float32, k_start: int = 0
                    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per beam: index k of the step (from sample k-1 to sample k, sample -1 being the
        origin) in which the first solid cell is entered (-1: none), and that cell
        (padded coordinates)."""
        nb = len(c32)
        first = np.full(nb, -1, dtype=np.int64)
        hit_u = np.zeros(nb, dtype=np.int32)
        hit_v = np.zeros(nb, dtype=np.int32)
        active = np.arange(nb)
        t_all = np.concatenate((np.zeros(1, dtype=np.float32), self._t_cells))
        pw = self._pw
        for k0 in range(min(k_start, len(self._t_cells)), len(self._t_cells), self._chunk):
            t = t_all[k0:k0 + self._chunk + 1]  # the previous sample and this chunk's
            ca, sa = c32[active], s32[active]
            u_all = (np.outer(ca, t) + up).astype(np.int32)
            v_all = (np.outer(sa, t) + vp).astype(np.int32)
            iu, iv = u_all[:, 1:], v_all[:, 1:]
            codes = self._codes[iv * pw + iu]
            hits = codes >= 2
            na, nk = hits.shape
            rows = np.arange(na)
            k = np.where(hits.any(axis=1), hits.argmax(axis=1), nk)
            kk = np.minimum(k, nk - 1)
            ku, kv = iu[rows, kk], iv[rows, kk]
            # A step that changes row and column passes one corner cell in between (the
            # column changes first when the vertical border is reached first). It can be
            # solid only where the sample cell is next to a solid cell.
            dr, dc = np.nonzero(codes & 1)
            keep = dc <= k[dr]
            dr, dc = dr[keep], dc[keep]
            cu, cv = iu[dr, dc], iv[dr, dc]
            pu, pv = u_all[dr, dc], v_all[dr, dc]
            diag = (cu != pu) & (cv != pv)
            if diag.any():
                dr, dc, cu, cv, pu, pv = (a[diag] for a in (dr, dc, cu, cv, pu, pv))
                col_first = ((np.maximum(cu, pu) - up) / ca[dr]
                             < (np.maximum(cv, pv) - vp) / sa[dr])
                mu = np.where(col_first, cu, pu)
                mv = np.where(col_first, pv, cv)
                mh = self._flat[mv * pw + mu]
                if mh.any():
                    # First corner hit per beam (np.nonzero is row-major: first per row).
                    r_m, idx = np.unique(dr[mh], return_index=True)
                    kc = dc[mh][idx]
                    earlier = kc <= k[r_m]  # the corner cell comes before sample k
                    r_e = r_m[earlier]
                    k[r_e] = kc[earlier]
                    ku[r_e] = mu[mh][idx][earlier]
                    kv[r_e] = mv[mh][idx][earlier]
            has = k < nk
            sel = active[has]
            first[sel] = k[has] + k0
            hit_u[sel] = ku[has]
            hit_v[sel] = kv[has]
            active = active[~has]
            if len(active) == 0:
                break
        return first, hit_u, hit_v


def cast_circles(x: float, y: float, angles: np.ndarray, circles: np.ndarray,
                 max_range_m: Optional[float] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Ranges [m] from (x, y) to the nearest of the circles (K, 3) [x, y, r] along each
    angle (+inf where none is hit; circles containing the origin are ignored), and the
    |cos| of the incidence angle. Circles beyond ``max_range_m`` are skipped."""
    n = len(angles)
    if len(circles) and max_range_m is not None:
        near = np.hypot(circles[:, 0] - x, circles[:, 1] - y) - circles[:, 2] <= max_range_m
        circles = circles[near]
    if len(circles) == 0:
        return np.full(n, np.inf), np.ones(n)
    c = np.cos(angles)[:, None]
    s = np.sin(angles)[:, None]
    dx = circles[None, :, 0] - x
    dy = circles[None, :, 1] - y
    r = circles[None, :, 2]
    proj = c * dx + s * dy
    perp2 = dx * dx + dy * dy - proj * proj
    half2 = r * r - perp2
    with np.errstate(invalid="ignore"):
        half = np.sqrt(np.maximum(half2, 0.0))
    t = proj - half
    valid = (half2 >= 0.0) & (t > 0.0)
    t = np.where(valid, t, np.inf)
    k = np.argmin(t, axis=1)
    rows = np.arange(n)
    best = t[rows, k]
    cos_inc = np.where(np.isfinite(best), half[rows, k] / r[0, k], 1.0)
    return best, cos_inc


class LaserModel:
    """URG-04LX on a grid world: ``scan()`` returns one noisy LaserScan ``ranges`` array."""

    def __init__(self, grid: GridMap, config: Optional[LaserConfig] = None,
                 dropout_grid: Optional[np.ndarray] = None):
        config = config if config is not None else LaserConfig()
        self.config = config
        self.grid = grid
        self.caster = RayCaster(grid, config.range_max_m, config.step_cells)
        self.angles = config.angles
        self._dropout_flat = (np.append(dropout_grid.ravel(), 0.0).astype(np.float64)
                              if dropout_grid is not None else None)

    def true_ranges(self, x: float, y: float, yaw: float, circles: np.ndarray
                    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise-free ranges from a laser at map pose (x, y, yaw): grid and circles.
        Returns ``(ranges, cos_incidence, material_dropout_prob)``."""
        a = yaw + self.angles
        r_grid, cos_grid, cell = self.caster.cast(x, y, a)
        r_circ, cos_circ = cast_circles(x, y, a, circles, self.config.range_max_m)
        circ_first = r_circ < r_grid
        ranges = np.where(circ_first, r_circ, r_grid)
        cos_inc = np.where(circ_first, cos_circ, cos_grid)
        material = np.zeros(len(a))
        if self._dropout_flat is not None:
            material = np.where(circ_first | (cell < 0), 0.0, self._dropout_flat[cell])
        return ranges, cos_inc, material

    def apply_noise(self, ranges: np.ndarray, cos_inc: np.ndarray, material: np.ndarray,
                    rng: np.random.Generator) -> np.ndarray:
        """Range noise, dropouts and REP 117 codes on true ranges [m]."""
        cfg = self.config
        n = len(ranges)
        noise = np.clip(rng.normal(0.0, cfg.noise_sigma_frac, n),
                        -cfg.noise_max_frac, cfg.noise_max_frac)
        u = rng.random(n)
        finite = np.isfinite(ranges)
        out = np.where(finite, ranges * (1.0 + noise), ranges)
        if cfg.range_quantum_m > 0:
            out = np.where(finite, np.round(out / cfg.range_quantum_m) * cfg.range_quantum_m,
                           out)
        span = max(cfg.range_max_m - cfg.far_dropout_start_m, 1e-9)
        far = np.clip((ranges - cfg.far_dropout_start_m) / span, 0.0, 1.0)
        p_far = cfg.far_dropout_prob * np.where(finite, far, 0.0) ** 2
        incidence = np.arccos(np.clip(cos_inc, 0.0, 1.0))
        graze_span = max(math.pi / 2 - cfg.grazing_start_rad, 1e-9)
        p_graze = cfg.grazing_dropout_prob * np.clip(
            (incidence - cfg.grazing_start_rad) / graze_span, 0.0, 1.0)
        p_keep = (1.0 - p_far) * (1.0 - p_graze) * (1.0 - material)
        dropped = finite & (u >= p_keep)
        out = np.where(out > cfg.range_max_m, np.inf, out)
        out = np.where(finite & (out < cfg.range_min_m), -np.inf, out)
        out[dropped] = np.nan
        return out

    def scan(self, x: float, y: float, yaw: float, circles: np.ndarray,
             rng: np.random.Generator) -> np.ndarray:
        ranges, cos_inc, material = self.true_ranges(x, y, yaw, circles)
        return self.apply_noise(ranges, cos_inc, material, rng)
