"""Occupancy grids as numpy arrays: cell values, the one grid geometry type (`GridInfo`),
the thresholding rule for non-trinary maps (`to_trinary`) and OccupancyGrid data <-> array.

No ROS imports: message objects are read duck-typed (``info.resolution``,
``info.origin.position.x`` ...), so ``nav_msgs`` messages and plain stand-ins both work.

Conventions (those of ``nav_msgs/OccupancyGrid``), used by every package of the stack:
  * a grid is a 2-D int8 array of shape ``(height, width)`` = ``GridInfo.shape``, indexed
    ``grid[iy, ix]``; ``OccupancyGrid.data`` is that array row-major (row ``iy = 0`` first);
  * a cell is named ``(ix, iy)``, x index first like the point ``(x, y)`` it holds:
    ``world_to_cell(x, y) -> (ix, iy)``, ``cell_to_world(ix, iy) -> (x, y)``; to index an
    array with a cell write ``grid[iy, ix]``;
  * cell ``(ix, iy)`` covers ``[ix*res, (ix+1)*res) x [iy*res, (iy+1)*res)`` in the grid's
    own frame, whose origin (the outer corner of cell (0, 0)) sits at ``(origin_x,
    origin_y)`` rotated by ``origin_yaw`` in the world (map) frame;
  * values UNKNOWN (-1), FREE (0), OCCUPIED (100).
Code that only handles axis-aligned grids (the mapper, localizer, navigator, simulator)
calls ``GridInfo.check_axis_aligned()``, which raises ValueError for a rotated origin.

Thresholding rule (`to_trinary`) for maps that are not gmapping-style trinary, e.g.
cartographer's 0..100 probabilities:
    value < 0 or value > 100        -> UNKNOWN  (counted as invalid when > 100 or < -1)
    0 <= value <= free_max          -> FREE      (default free_max 19, map_server's 0.196)
    value >= occupied_min           -> OCCUPIED  (default occupied_min 65, map_server's 0.65)
    free_max < value < occupied_min -> UNKNOWN   (too uncertain to plan through or around)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Tuple

import cv2
import numpy as np

UNKNOWN = -1
FREE = 0
OCCUPIED = 100


_SCALARS = (int, float, np.integer, np.floating)


def _out(a):
    """A Python scalar for a 0-d result, the array otherwise."""
    return a.item() if a.ndim == 0 else a


@dataclass(frozen=True)
class GridInfo:
    """Geometry of a grid: metres per cell, size in cells, and the world pose of the outer
    corner of cell (0, 0). Immutable; compares by value."""

    resolution: float        # [m/cell]
    width: int               # [cells] along the grid's x axis (array columns)
    height: int              # [cells] along the grid's y axis (array rows)
    origin_x: float = 0.0    # [m] world x of the outer corner of cell (0, 0)
    origin_y: float = 0.0    # [m]
    origin_yaw: float = 0.0  # [rad] rotation of the grid's x axis in the world frame

    def __post_init__(self):
        res = float(self.resolution)
        if not (res > 0.0 and math.isfinite(res)):
            raise ValueError("grid resolution must be a positive number, got %r"
                             % (self.resolution,))
        if int(self.width) < 0 or int(self.height) < 0:
            raise ValueError("grid size must not be negative, got %dx%d"
                             % (self.width, self.height))
        origin = (float(self.origin_x), float(self.origin_y), float(self.origin_yaw))
        if not all(math.isfinite(v) for v in origin):
            raise ValueError("grid origin must be finite, got %r" % (origin,))
        for name, value in (("resolution", res), ("width", int(self.width)),
                            ("height", int(self.height)), ("origin_x", origin[0]),
                            ("origin_y", origin[1]), ("origin_yaw", origin[2])):
            object.__setattr__(self, name, value)

    # -- construction -----------------------------------------------------------------
    @classmethod
    def from_bounds(cls, resolution: float, xmin: float, ymin: float,
                    xmax: float, ymax: float) -> GridInfo:
        """Smallest axis-aligned grid whose cells cover [xmin, xmax] x [ymin, ymax] [m]."""
        if not (xmax > xmin and ymax > ymin):
            raise ValueError("empty bounds x[%g, %g] y[%g, %g]" % (xmin, xmax, ymin, ymax))
        width = int(math.ceil((xmax - xmin) / resolution))
        height = int(math.ceil((ymax - ymin) / resolution))
        return cls(resolution, width, height, xmin, ymin)

    @classmethod
    def from_msg_info(cls, info) -> GridInfo:
        """From a ``nav_msgs/MapMetaData`` (duck-typed). The origin's orientation must be a
        rotation about z (ValueError otherwise); its yaw becomes ``origin_yaw`` (an all-zero
        quaternion, as in an uninitialised message, counts as yaw 0)."""
        q = info.origin.orientation
        if abs(q.x) > 1e-9 or abs(q.y) > 1e-9:
            raise ValueError("map origin orientation (%g %g %g %g) is not a rotation about z"
                             % (q.x, q.y, q.z, q.w))
        return cls(info.resolution, info.width, info.height, info.origin.position.x,
                   info.origin.position.y, 2.0 * math.atan2(q.z, q.w))

    def grown(self, left: int, bottom: int, right: int, top: int) -> GridInfo:
        """The grid enlarged by whole cells on each side (the cells keep their places)."""
        dx, dy = -left * self.resolution, -bottom * self.resolution
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        return GridInfo(self.resolution, self.width + left + right, self.height + bottom + top,
                        self.origin_x + c * dx - s * dy, self.origin_y + s * dx + c * dy,
                        self.origin_yaw)

    # -- checks and comparisons -------------------------------------------------------
    @property
    def axis_aligned(self) -> bool:
        return abs(self.origin_yaw) <= 1e-9

    def check_axis_aligned(self) -> GridInfo:
        """``self`` if the grid is not rotated; ValueError naming the yaw otherwise."""
        if not self.axis_aligned:
            raise ValueError("a rotated map (origin yaw %g rad) is not supported; use 0"
                             % self.origin_yaw)
        return self

    def same_geometry(self, other: GridInfo, tol: float = 1e-9) -> bool:
        return (self.width == other.width and self.height == other.height
                and abs(self.resolution - other.resolution) <= tol
                and abs(self.origin_x - other.origin_x) <= tol
                and abs(self.origin_y - other.origin_y) <= tol
                and abs(self.origin_yaw - other.origin_yaw) <= tol)

    # -- size and bounds --------------------------------------------------------------
    @property
    def shape(self) -> Tuple[int, int]:
        """numpy shape ``(height, width)`` of arrays on this grid."""
        return (self.height, self.width)

    @property
    def size_m(self) -> Tuple[float, float]:
        """(width, height) [m] along the grid's own axes."""
        return self.width * self.resolution, self.height * self.resolution

    @property
    def bounds(self) -> Tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) [m]: the world-frame box around the grid's corners."""
        w, h = self.size_m
        xs, ys = self._to_world(np.array([0.0, w, w, 0.0]), np.array([0.0, 0.0, h, h]))
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    @property
    def xmax(self) -> float:
        return self.bounds[2]

    @property
    def ymax(self) -> float:
        return self.bounds[3]

    def contains(self, ix, iy):
        """Which cells lie inside the grid: a bool for scalars, a mask for arrays."""
        if isinstance(ix, _SCALARS) and isinstance(iy, _SCALARS):  # fast path (simulator)
            return bool(0 <= ix < self.width and 0 <= iy < self.height)
        ix = np.asarray(ix)
        iy = np.asarray(iy)
        return _out((ix >= 0) & (ix < self.width) & (iy >= 0) & (iy < self.height))

    # -- cell <-> metre ---------------------------------------------------------------
    def _to_world(self, gx, gy):
        """Grid-frame metres -> world metres (arrays)."""
        if self.origin_yaw == 0.0:
            return self.origin_x + gx, self.origin_y + gy
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        return self.origin_x + c * gx - s * gy, self.origin_y + s * gx + c * gy

    def world_to_cell(self, x, y):
        """Cell indices ``(ix, iy)`` of world points [m], possibly outside the grid: Python
        ints for scalars, int64 arrays (broadcast) otherwise."""
        if isinstance(x, _SCALARS) and isinstance(y, _SCALARS):  # fast path, same arithmetic
            dx, dy = float(x) - self.origin_x, float(y) - self.origin_y
            if self.origin_yaw != 0.0:
                c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
                dx, dy = c * dx + s * dy, -s * dx + c * dy
            return math.floor(dx / self.resolution), math.floor(dy / self.resolution)
        dx = np.asarray(x, dtype=float) - self.origin_x
        dy = np.asarray(y, dtype=float) - self.origin_y
        if np.shape(dx) != np.shape(dy):
            dx, dy = np.broadcast_arrays(dx, dy)
        if self.origin_yaw != 0.0:
            c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
            dx, dy = c * dx + s * dy, -s * dx + c * dy
        ix = np.floor(dx / self.resolution).astype(np.int64)
        iy = np.floor(dy / self.resolution).astype(np.int64)
        return _out(np.asarray(ix)), _out(np.asarray(iy))

    def cell_to_world(self, ix, iy):
        """World coordinates [m] of cell centres; indices may be fractional (centroids).
        Floats for scalars, arrays otherwise."""
        gx = (np.asarray(ix, dtype=float) + 0.5) * self.resolution
        gy = (np.asarray(iy, dtype=float) + 0.5) * self.resolution
        if np.shape(gx) != np.shape(gy):
            gx, gy = np.broadcast_arrays(gx, gy)
        x, y = self._to_world(gx, gy)
        return _out(np.asarray(x)), _out(np.asarray(y))


def map_from_msg(msg) -> Tuple[np.ndarray, GridInfo]:
    """A ``nav_msgs/OccupancyGrid`` (duck-typed) -> its int8 array (height, width) and
    GridInfo, values as sent. ValueError if the geometry is invalid or the data and the
    size disagree."""
    info = GridInfo.from_msg_info(msg.info)
    return grid_from_msg_data(msg.data, info.width, info.height), info


def grid_from_msg_data(data, width: int, height: int) -> np.ndarray:
    """``OccupancyGrid.data`` (sequence or bytes of int8) -> int8 array (height, width).

    Values outside int8 (only possible from stand-ins) are clipped. ValueError if the data
    and the size disagree."""
    if isinstance(data, (bytes, bytearray)):
        arr = np.frombuffer(data, dtype=np.int8)
    else:
        arr = np.asarray(data, dtype=np.int16).clip(-128, 127).astype(np.int8)
    if arr.size != width * height:
        raise ValueError("map data has %d cells, expected %d x %d = %d"
                         % (arr.size, width, height, width * height))
    return arr.reshape(height, width).copy()


def grid_to_msg_data(grid: np.ndarray) -> list:
    """int8 grid (height, width) -> the flat list ``OccupancyGrid.data`` wants (row-major)."""
    return np.ascontiguousarray(grid, dtype=np.int8).ravel().tolist()


def _trinary_lut(free_max: int, occupied_min: int) -> Tuple[np.ndarray, np.ndarray]:
    """256-entry tables over the uint8 view of int8 values: trinary value, and 'was odd'."""
    values = np.arange(256, dtype=np.uint8).view(np.int8).astype(np.int16)
    out = np.full(256, UNKNOWN, dtype=np.int8)
    out[(values >= 0) & (values <= free_max)] = FREE
    out[(values >= occupied_min) & (values <= 100)] = OCCUPIED
    odd = ~np.isin(values, (UNKNOWN, FREE, OCCUPIED))
    return out.view(np.uint8), odd.astype(np.uint8)


def to_trinary(
    data: np.ndarray, free_max: int = 19, occupied_min: int = 65
) -> Tuple[np.ndarray, Dict[str, int]]:
    """Apply the thresholding rule above; returns (int8 grid, counts of odd values).

    counts: 'non_trinary' = cells not in {-1, 0, 100}; 'invalid' = cells > 100 or < -1.
    Costs two table look-ups (cv2.LUT), so it is cheap enough to run on every map.
    """
    if not 0 <= free_max < occupied_min <= 100:
        raise ValueError("need 0 <= free_max < occupied_min <= 100")
    grid = np.ascontiguousarray(data, dtype=np.int8)
    if grid.size == 0:
        return grid.copy(), {"non_trinary": 0, "invalid": 0}
    lut, odd = _trinary_lut(int(free_max), int(occupied_min))
    u8 = grid.view(np.uint8)
    flat = u8.reshape(-1, 1) if u8.ndim == 1 else u8
    out = cv2.LUT(flat, lut).reshape(grid.shape).view(np.int8)
    non_trinary = int(cv2.countNonZero(cv2.LUT(flat, odd)))
    invalid = 0
    if non_trinary:
        invalid = int(np.count_nonzero((grid > 100) | (grid < -1)))
    return out, {"non_trinary": non_trinary, "invalid": invalid}
