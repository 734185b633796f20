"""The human location channel (thesis 5.2.2): where the person is, its grid, its location
type CL in {1..5} (fig. 5.4).

Human location. The thesis writes L_h = [x_r + d cos(alpha - theta_r), y_r + d sin(alpha -
theta_r)]. With REP 103 angles (theta_r the robot's yaw in the map frame and alpha the
target's bearing in base_link, both counter-clockwise from x), a target at bearing alpha
lies at the map angle theta_r + alpha, so `human_location` uses cos/sin(theta_r + alpha);
the thesis's form is the same only for a clockwise bearing (alpha_cw = -alpha) and a
clockwise yaw, or when theta_r = 0.

Location type (fig. 5.4). An object is a square of half side ``object_half_size_m`` centred
on the location, sides along the map's x and y axes. A side is "beside a wall" when an
occupied cell lies within ``wall_threshold_m`` (20 cm in 5.5) outside that side, in the
band as wide as the side ("only if any side of an object is within 20 cm of a wall, it is
counted as beside the wall"). Occupied cells under the object itself are the object (the
furniture is an obstacle in the laser map), not walls. Then, by the sides beside walls:

    none                          -> 1  not adjacent to a wall
    one                           -> 2  at the wall side
    two adjacent (e.g. +x and +y) -> 3  two-sided corner
    two opposite (+x and -x)      -> 4  between two walls
    three or four                 -> 5  three-sided corner

`location_types` computes CL for every cell of a map at once from an integral image of the
occupied cells (four box sums per cell, numpy; no per-cell loop). Cells outside the map
and unknown cells are not walls. Walls not aligned with the map axes are seen by the side
bands only partly (a known limitation: the thesis's rooms and our worlds are axis-aligned).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import numpy as np

from ascc_common.grid import OCCUPIED, GridInfo
from ascc_common.params import param

NOT_ADJACENT, WALL_SIDE, TWO_SIDED_CORNER, BETWEEN_TWO_WALLS, THREE_SIDED_CORNER = 1, 2, 3, 4, 5


@dataclass
class LocationParams:
    wall_threshold_m: float = param(0.20, "[m] a side within this of a wall is beside it "
                                    "(5.5: 20 cm)", ge=0.0)
    object_half_size_m: float = param(0.25, "[m] half the side of the square object at the "
                                      "person's location", ge=0.0)
    wall_min_cover: float = param(0.0, "a side is beside a wall when occupied cells in its "
                                  "band lie along more than this fraction of its length (0: "
                                  "any cell, the thesis's rule)", ge=0.0, le=1.0)


def human_location(x_r: float, y_r: float, theta_r: float, range_m: float,
                   bearing_rad: float) -> Tuple[float, float]:
    """L_h [m] in the map frame from the robot pose (x_r, y_r [m], theta_r [rad]) and the
    target's range [m] and bearing [rad, counter-clockwise from the robot's x axis]."""
    a = theta_r + bearing_rad
    return x_r + range_m * math.cos(a), y_r + range_m * math.sin(a)


def grid_index(info: GridInfo, x: float, y: float) -> Tuple[int, int]:
    """G = g([X, Y]): the cell ``(ix, iy)`` of the semantic grid ``info`` holding the point;
    ValueError if it lies outside the grid."""
    ix, iy = info.world_to_cell(x, y)
    if not info.contains(ix, iy):
        raise ValueError("location (%.2f, %.2f) m is outside the map (x %.2f..%.2f, y "
                         "%.2f..%.2f m)" % ((x, y) + (info.bounds[0], info.bounds[2],
                                                      info.bounds[1], info.bounds[3])))
    return ix, iy


def _box_sums(integral: np.ndarray, y0, y1, x0, x1) -> np.ndarray:
    """Sums over rows [y0, y1) and columns [x0, x1) of the padded image whose integral
    image (with a leading zero row and column) is ``integral``; index arrays broadcast."""
    return integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]


def side_walls(occupied: np.ndarray, resolution: float,
               params: LocationParams) -> np.ndarray:
    """(4, h, w) bool: for every cell as the object's centre, whether its +x, -x, +y, -y
    side is beside a wall (``occupied`` is a (h, w) bool array, ``grid[iy, ix]``)."""
    occ = np.asarray(occupied, dtype=bool)
    h, w = occ.shape
    half = int(round(params.object_half_size_m / resolution))   # [cells] centre to side
    band = int(math.ceil(params.wall_threshold_m / resolution - 1e-9))  # [cells] side to wall
    reach = half + band
    pad = np.pad(occ, reach).astype(np.int32)
    integral = np.zeros((pad.shape[0] + 1, pad.shape[1] + 1), dtype=np.int32)
    integral[1:, 1:] = pad.cumsum(0).cumsum(1)
    iy, ix = np.mgrid[0:h, 0:w]
    cy, cx = iy + reach, ix + reach  # the centre in the padded image
    out = np.zeros((4, h, w), dtype=bool)
    if band == 0:
        return out
    if params.wall_min_cover > 0.0:
        return _covered_sides(pad, reach, half, band, (h, w), params.wall_min_cover)
    # +x: columns (cx+half, cx+half+band], rows [cy-half, cy+half]; the others alike
    out[0] = _box_sums(integral, cy - half, cy + half + 1, cx + half + 1, cx + reach + 1) > 0
    out[1] = _box_sums(integral, cy - half, cy + half + 1, cx - reach, cx - half) > 0
    out[2] = _box_sums(integral, cy + half + 1, cy + reach + 1, cx - half, cx + half + 1) > 0
    out[3] = _box_sums(integral, cy - reach, cy - half, cx - half, cx + half + 1) > 0
    return out


def _covered_sides(pad: np.ndarray, reach: int, half: int, band: int, shape,
                   min_cover: float) -> np.ndarray:
    """`side_walls` with ``wall_min_cover``: per side, the fraction of its 2 half + 1 cells
    (rows for the x sides, columns for the y sides) whose line out through the band meets
    an occupied cell, > ``min_cover``. Cumulative sums only (no per-cell loop)."""
    h, w = shape
    n = 2 * half + 1
    # hit_x[r, c]: an occupied cell in row r, columns (c, c + band]; hit_xm: [c - band, c)
    cs = np.zeros((pad.shape[0], pad.shape[1] + 1), dtype=np.int32)
    cs[:, 1:] = pad.cumsum(1)
    c = np.arange(pad.shape[1])
    hit_xp = (cs[:, np.minimum(c + band + 1, pad.shape[1])] - cs[:, c + 1]) > 0
    hit_xm = (cs[:, c] - cs[:, np.maximum(c - band, 0)]) > 0
    rs = np.zeros((pad.shape[0] + 1, pad.shape[1]), dtype=np.int32)
    rs[1:, :] = pad.cumsum(0)
    r = np.arange(pad.shape[0])
    hit_yp = (rs[np.minimum(r + band + 1, pad.shape[0]), :] - rs[r + 1, :]) > 0
    hit_ym = (rs[r, :] - rs[np.maximum(r - band, 0), :]) > 0
    iy, ix = np.mgrid[0:h, 0:w]
    cy, cx = iy + reach, ix + reach

    def run_sum(hit, axis):  # number of hits over the side's n cells along ``axis``
        cum = np.zeros((hit.shape[0] + (axis == 0), hit.shape[1] + (axis == 1)), np.int32)
        if axis == 0:
            cum[1:, :] = hit.cumsum(0)
            return lambda rows, cols: cum[rows + half + 1, cols] - cum[rows - half, cols]
        cum[:, 1:] = hit.cumsum(1)
        return lambda rows, cols: cum[rows, cols + half + 1] - cum[rows, cols - half]

    out = np.zeros((4, h, w), dtype=bool)
    # +x side: column cx + half, its rows cy - half .. cy + half
    out[0] = run_sum(hit_xp, 0)(cy, cx + half) / n > min_cover
    out[1] = run_sum(hit_xm, 0)(cy, cx - half) / n > min_cover
    out[2] = run_sum(hit_yp, 1)(cy + half, cx) / n > min_cover
    out[3] = run_sum(hit_ym, 1)(cy - half, cx) / n > min_cover
    return out


def types_from_sides(sides: np.ndarray) -> np.ndarray:
    """CL (1..5, uint8, fig. 5.4) from the (4, ...) side flags +x, -x, +y, -y."""
    px, nx, py, ny = (np.asarray(s, dtype=bool) for s in sides)
    n = px.astype(np.uint8) + nx + py + ny
    cl = np.full(n.shape, NOT_ADJACENT, dtype=np.uint8)
    cl[n == 1] = WALL_SIDE
    opposite = (px & nx) | (py & ny)
    cl[(n == 2) & ~opposite] = TWO_SIDED_CORNER
    cl[(n == 2) & opposite] = BETWEEN_TWO_WALLS
    cl[n >= 3] = THREE_SIDED_CORNER
    return cl


def location_types(grid: np.ndarray, info: GridInfo, params: LocationParams) -> np.ndarray:
    """CL (1..5) of every cell of an occupancy grid (``grid[iy, ix]``, OCCUPIED = wall)."""
    return types_from_sides(side_walls(np.asarray(grid) == OCCUPIED, info.resolution, params))


def location_type_at(grid: np.ndarray, info: GridInfo, params: LocationParams,
                     x: float, y: float) -> int:
    """CL_t = C(L_h): the location type (1..5) of the point (x, y) [m]; ValueError if it is
    outside the map. Computes only a window around the point."""
    ix, iy = grid_index(info, x, y)
    reach = int(round(params.object_half_size_m / info.resolution)) + int(
        math.ceil(params.wall_threshold_m / info.resolution - 1e-9))
    y0, x0 = max(iy - reach, 0), max(ix - reach, 0)
    window = np.asarray(grid)[y0:iy + reach + 1, x0:ix + reach + 1] == OCCUPIED
    sides = side_walls(window, info.resolution, params)
    return int(types_from_sides(sides[:, iy - y0, ix - x0]))
