"""The simulated world's occupancy grid and disc-footprint collision queries.

Grids, their geometry and cell values follow ``ascc_common.grid``: ``occupancy[iy, ix]``
with row 0 at the lowest y, cell (ix, iy) covering ``[ox + ix*res, ox + (ix+1)*res) x
[oy + iy*res, ...)`` [m]; values -1 unknown, 0 free, 100 occupied. The simulator handles
axis-aligned grids only. Only occupied cells are *solid* (stop the robot, reflect the
laser); unknown cells (outside the building) are not, and everything outside the grid
counts as solid for collisions, so a robot cannot leave the map.
"""
from __future__ import annotations

import math
from typing import Optional, Tuple

import cv2
import numpy as np

from ascc_common.grid import OCCUPIED, GridInfo


class GridMap:
    """An occupancy grid on its geometry, with a distance field for fast collision tests.

    Args:
        occupancy: int8 array (height, width) of -1/0/100, row 0 = lowest y.
        info: its geometry (``info.shape`` must match; axis-aligned, else ValueError).
    """

    def __init__(self, occupancy: np.ndarray, info: GridInfo):
        if occupancy.ndim != 2:
            raise ValueError("occupancy must be a 2D array")
        if occupancy.shape != info.shape:
            raise ValueError("occupancy of shape %s does not match %r" % (occupancy.shape, info))
        self.info = info.check_axis_aligned()
        self.occupancy = np.ascontiguousarray(occupancy, dtype=np.int8)
        self._update_derived()

    def _update_derived(self) -> None:
        self.solid = self.occupancy == OCCUPIED
        # Flat lookup with one extra False entry: index width*height means "outside".
        self.solid_flat = np.append(self.solid.ravel(), False)
        # Distance [m] from every cell centre to the nearest solid cell centre, where the
        # ring of cells just outside the map counts as solid.
        free = np.pad(~self.solid, 1, constant_values=False).astype(np.uint8)
        dist = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        self.clearance_m = dist[1:-1, 1:-1].astype(np.float32) * self.info.resolution
        self._solid_pad: Optional[np.ndarray] = None
        self._pad = 0

    def copy(self) -> GridMap:
        return GridMap(self.occupancy.copy(), self.info)

    def set_occupancy(self, occupancy: np.ndarray) -> None:
        """Replace the cells (same shape) and recompute the derived layers."""
        if occupancy.shape != self.occupancy.shape:
            raise ValueError("shape mismatch")
        self.occupancy = np.ascontiguousarray(occupancy, dtype=np.int8)
        self._update_derived()

    def value_at(self, x: float, y: float) -> int:
        """Occupancy value at (x, y) [m]; OCCUPIED outside the grid."""
        ix, iy = self.info.world_to_cell(x, y)
        if not self.info.contains(ix, iy):
            return OCCUPIED
        return int(self.occupancy[iy, ix])

    def disc_contact(self, x: float, y: float, radius_m: float
                     ) -> Optional[Tuple[float, float, float]]:
        """Closest solid point to a disc that overlaps solid cells (or leaves the map).

        Returns ``(px, py, distance_m)`` of the solid point nearest to the disc centre when
        that distance is below ``radius_m``, else None. Exact for the cell squares.
        """
        info = self.info
        res = info.resolution
        ix, iy = info.world_to_cell(x, y)
        if info.contains(ix, iy):
            # Conservative fast path: centre-to-centre clearance minus both half diagonals.
            if self.clearance_m[iy, ix] - res * math.sqrt(2.0) > radius_m:
                return None
        ix0, iy0 = info.world_to_cell(x - radius_m, y - radius_m)
        ix1, iy1 = info.world_to_cell(x + radius_m, y + radius_m)
        pad = self._pad_cells(max(ix1 - ix0, iy1 - iy0) + 1)
        if ix0 < -pad or iy0 < -pad or ix1 >= info.width + pad or iy1 >= info.height + pad:
            # Wholly or partly beyond the padding: far outside the map, which is solid.
            return x, y, 0.0
        sub = self._solid_pad[iy0 + pad:iy1 + pad + 1, ix0 + pad:ix1 + pad + 1]
        jy, jx = np.nonzero(sub)
        if len(jx) == 0:
            return None
        cx0 = info.origin_x + (jx + ix0) * res  # lower-left corners of the solid cells
        cy0 = info.origin_y + (jy + iy0) * res
        px = np.minimum(np.maximum(x, cx0), cx0 + res)
        py = np.minimum(np.maximum(y, cy0), cy0 + res)
        d = np.hypot(px - x, py - y)
        k = int(np.argmin(d))
        if d[k] >= radius_m:
            return None
        return float(px[k]), float(py[k]), float(d[k])

    def _pad_cells(self, needed: int) -> int:
        """The solid layer padded with solid cells (outside the map) at least ``needed``
        cells wide, built on first use."""
        if self._solid_pad is None or self._pad < needed:
            self._pad = max(needed, 8)
            self._solid_pad = np.pad(self.solid, self._pad, constant_values=True)
        return self._pad


def rasterize_polygon(occupancy: np.ndarray, info: GridInfo, polygon_xy: np.ndarray,
                      value: int) -> None:
    """Set the cells (of ``occupancy`` on ``info``) whose centres lie inside the polygon
    (N, 2) [m] to ``value``.

    A polygon thinner than a cell that contains no cell centre marks the cells of its
    vertices instead, so thin solid things do not vanish.
    """
    poly = np.asarray(polygon_xy, dtype=np.float64).reshape(-1, 2)
    ix0, iy0 = info.world_to_cell(poly[:, 0].min(), poly[:, 1].min())
    ix1, iy1 = info.world_to_cell(poly[:, 0].max(), poly[:, 1].max())
    ix0, iy0 = max(ix0, 0), max(iy0, 0)
    ix1, iy1 = min(ix1, info.width - 1), min(iy1, info.height - 1)
    if ix0 > ix1 or iy0 > iy1:
        return
    gx, gy = np.meshgrid(np.arange(ix0, ix1 + 1), np.arange(iy0, iy1 + 1))
    cx, cy = info.cell_to_world(gx, gy)
    inside = np.zeros(gx.shape, dtype=bool)
    for (ax, ay), (bx, by) in zip(poly, np.roll(poly, -1, axis=0)):  # even-odd rule
        if ay == by:
            continue
        crosses = (ay > cy) != (by > cy)
        x_at = ax + (cy - ay) * (bx - ax) / (by - ay)
        inside ^= crosses & (cx < x_at)
    if inside.any():
        occupancy[gy[inside], gx[inside]] = value
        return
    ix, iy = info.world_to_cell(poly[:, 0], poly[:, 1])
    ok = info.contains(ix, iy)
    occupancy[iy[ok], ix[ok]] = value


def rasterize_disc(occupancy: np.ndarray, info: GridInfo, x: float, y: float,
                   radius_m: float, value: int) -> None:
    """Set the cells whose centres lie within ``radius_m`` of (x, y) (at least the cell
    containing the centre) to ``value``."""
    ix, iy = info.world_to_cell(x, y)
    r = int(math.ceil(radius_m / info.resolution)) + 1
    gx, gy = np.meshgrid(np.arange(ix - r, ix + r + 1), np.arange(iy - r, iy + r + 1))
    cx, cy = info.cell_to_world(gx, gy)
    mask = np.hypot(cx - x, cy - y) <= radius_m
    mask |= (gx == ix) & (gy == iy)
    mask &= info.contains(gx, gy)
    occupancy[gy[mask], gx[mask]] = value
