"""Occupancy grid of the simulated world and disc-footprint collision queries.

Cells are stored as in ``nav_msgs/OccupancyGrid``: ``occupancy[iy, ix]`` with row 0 at the
lowest y, cell (ix, iy) covering ``[ox + ix*res, ox + (ix+1)*res) x [oy + iy*res, ...)``
[m]. Values: -1 unknown, 0 free, 100 occupied. Only occupied cells are *solid* (stop the
robot, reflect the laser); unknown cells (outside the building) are not, and everything
outside the grid counts as solid for collisions, so a robot cannot leave the map.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import cv2
import numpy as np

FREE = 0
OCCUPIED = 100
UNKNOWN = -1


class GridMap:
    """A 2D occupancy grid with its geometry and a distance field for fast collision tests.

    Args:
        occupancy: int8 array (height, width) of -1/0/100, row 0 = lowest y.
        resolution_m: cell edge [m].
        origin_xy_m: map-frame position of the outer corner of cell (0, 0) [m].
    """

    def __init__(self, occupancy: np.ndarray, resolution_m: float,
                 origin_xy_m: Sequence[float]):
        if occupancy.ndim != 2:
            raise ValueError("occupancy must be a 2D array")
        if not resolution_m > 0.0:
            raise ValueError("resolution_m must be > 0")
        self.occupancy = np.ascontiguousarray(occupancy, dtype=np.int8)
        self.resolution = float(resolution_m)
        self.origin_x = float(origin_xy_m[0])
        self.origin_y = float(origin_xy_m[1])
        self.height, self.width = self.occupancy.shape
        self._update_derived()

    def _update_derived(self) -> None:
        self.solid = self.occupancy == OCCUPIED
        # Flat lookup with one extra False entry: index width*height means "outside".
        self.solid_flat = np.append(self.solid.ravel(), False)
        # Distance [m] from every cell centre to the nearest solid cell centre, where the
        # ring of cells just outside the map counts as solid.
        free = np.pad(~self.solid, 1, constant_values=False).astype(np.uint8)
        dist = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        self.clearance_m = dist[1:-1, 1:-1].astype(np.float32) * self.resolution
        self._solid_pad: Optional[np.ndarray] = None
        self._pad = 0

    def copy(self) -> GridMap:
        return GridMap(self.occupancy.copy(), self.resolution, (self.origin_x, self.origin_y))

    def set_occupancy(self, occupancy: np.ndarray) -> None:
        """Replace the cells (same shape) and recompute the derived layers."""
        if occupancy.shape != self.occupancy.shape:
            raise ValueError("shape mismatch")
        self.occupancy = np.ascontiguousarray(occupancy, dtype=np.int8)
        self._update_derived()

    @property
    def size_m(self) -> Tuple[float, float]:
        return self.width * self.resolution, self.height * self.resolution

    def cell_of(self, x: float, y: float) -> Tuple[int, int]:
        """Cell (ix, iy) containing map point (x, y) [m]; may be outside the grid."""
        return (int(math.floor((x - self.origin_x) / self.resolution)),
                int(math.floor((y - self.origin_y) / self.resolution)))

    def in_bounds(self, ix: int, iy: int) -> bool:
        return 0 <= ix < self.width and 0 <= iy < self.height

    def contains(self, x: float, y: float) -> bool:
        return self.in_bounds(*self.cell_of(x, y))

    def value_at(self, x: float, y: float) -> int:
        """Occupancy value at (x, y) [m]; OCCUPIED outside the grid."""
        ix, iy = self.cell_of(x, y)
        if not self.in_bounds(ix, iy):
            return OCCUPIED
        return int(self.occupancy[iy, ix])

    def disc_contact(self, x: float, y: float, radius_m: float
                     ) -> Optional[Tuple[float, float, float]]:
        """Closest solid point to a disc that overlaps solid cells (or leaves the map).

        Returns ``(px, py, distance_m)`` of the solid point nearest to the disc centre when
        that distance is below ``radius_m``, else None. Exact for the cell squares.
        """
        res = self.resolution
        ix, iy = self.cell_of(x, y)
        if self.in_bounds(ix, iy):
            # Conservative fast path: centre-to-centre clearance minus both half diagonals.
            if self.clearance_m[iy, ix] - res * math.sqrt(2.0) > radius_m:
                return None
        ix0 = int(math.floor((x - radius_m - self.origin_x) / res))
        ix1 = int(math.floor((x + radius_m - self.origin_x) / res))
        iy0 = int(math.floor((y - radius_m - self.origin_y) / res))
        iy1 = int(math.floor((y + radius_m - self.origin_y) / res))
        pad = self._pad_cells(max(ix1 - ix0, iy1 - iy0) + 1)
        if ix0 < -pad or iy0 < -pad or ix1 >= self.width + pad or iy1 >= self.height + pad:
            # Wholly or partly beyond the padding: far outside the map, which is solid.
            return x, y, 0.0
        sub = self._solid_pad[iy0 + pad:iy1 + pad + 1, ix0 + pad:ix1 + pad + 1]
        jy, jx = np.nonzero(sub)
        if len(jx) == 0:
            return None
        cx0 = self.origin_x + (jx + ix0) * res
        cy0 = self.origin_y + (jy + iy0) * res
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


def rasterize_polygon(occupancy: np.ndarray, grid: GridMap, polygon_xy: np.ndarray,
                      value: int) -> None:
    """Set the cells whose centres lie inside the polygon (N, 2) [m] to ``value``.

    A polygon thinner than a cell that contains no cell centre marks the cells of its
    vertices instead, so thin solid things do not vanish.
    """
    poly = np.asarray(polygon_xy, dtype=np.float64).reshape(-1, 2)
    res = grid.resolution
    ix0, iy0 = grid.cell_of(poly[:, 0].min(), poly[:, 1].min())
    ix1, iy1 = grid.cell_of(poly[:, 0].max(), poly[:, 1].max())
    ix0, iy0 = max(ix0, 0), max(iy0, 0)
    ix1, iy1 = min(ix1, grid.width - 1), min(iy1, grid.height - 1)
    if ix0 > ix1 or iy0 > iy1:
        return
    gx, gy = np.meshgrid(np.arange(ix0, ix1 + 1), np.arange(iy0, iy1 + 1))
    cx = grid.origin_x + (gx + 0.5) * res
    cy = grid.origin_y + (gy + 0.5) * res
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
    for px, py in poly:
        ix, iy = grid.cell_of(px, py)
        if grid.in_bounds(ix, iy):
            occupancy[iy, ix] = value


def rasterize_disc(occupancy: np.ndarray, grid: GridMap, x: float, y: float,
                   radius_m: float, value: int) -> None:
    """Set the cells whose centres lie within ``radius_m`` of (x, y) (at least the cell
    containing the centre) to ``value``."""
    ix, iy = grid.cell_of(x, y)
    r = int(math.ceil(radius_m / grid.resolution)) + 1
    gx, gy = np.meshgrid(np.arange(ix - r, ix + r + 1), np.arange(iy - r, iy + r + 1))
    cx = grid.origin_x + (gx + 0.5) * grid.resolution
    cy = grid.origin_y + (gy + 0.5) * grid.resolution
    mask = np.hypot(cx - x, cy - y) <= radius_m
    mask |= (gx == ix) & (gy == iy)
    mask &= (gx >= 0) & (gx < grid.width) & (gy >= 0) & (gy < grid.height)
    occupancy[gy[mask], gx[mask]] = value
