"""Occupancy-grid helpers shared by the mapper, the localizer and the navigator.

No ROS imports: message objects are read duck-typed (``info.resolution``, ``info.width``,
``info.origin.position.x`` ...), so ``nav_msgs`` messages and plain stand-ins both work.

Conventions (those of ``nav_msgs/OccupancyGrid``):
  * a grid is a 2-D array indexed ``[iy, ix]``; row 0 is the row at ``origin_y``;
  * cell ``(ix, iy)`` covers ``[origin_x + ix*res, origin_x + (ix+1)*res)`` in x, same in y;
  * values -1 = unknown, 0 = free, 100 = occupied (``UNKNOWN``, ``FREE``, ``OCCUPIED``).
The origin's rotation must be zero (what map_server and gmapping produce).
"""

from __future__ import annotations

import math
import os
from typing import Optional, Tuple

import cv2
import numpy as np

UNKNOWN = -1
FREE = 0
OCCUPIED = 100
RAYCAST_BISECT_STEPS = 6  # refinement of ray-cast ranges: step / 64


class GridInfo:
    """Geometry of a grid: resolution [m/cell], size [cells] and the world pose of cell (0, 0)."""

    __slots__ = ("resolution", "width", "height", "origin_x", "origin_y")

    def __init__(self, resolution: float, width: int, height: int,
                 origin_x: float = 0.0, origin_y: float = 0.0):
        if not (resolution > 0.0 and math.isfinite(resolution)):
            raise ValueError("grid resolution must be a positive number, got %r" % resolution)
        if width < 0 or height < 0:
            raise ValueError("grid size must not be negative, got %dx%d" % (width, height))
        self.resolution = float(resolution)
        self.width = int(width)
        self.height = int(height)
        self.origin_x = float(origin_x)
        self.origin_y = float(origin_y)

    @classmethod
    def from_msg_info(cls, info) -> GridInfo:
        """From a ``nav_msgs/MapMetaData`` (duck-typed). Raises ValueError on a rotated origin."""
        q = info.origin.orientation
        yaw = 2.0 * math.atan2(q.z, q.w) if (q.x == 0.0 and q.y == 0.0) else float("nan")
        if not abs(yaw) < 1e-6:
            raise ValueError("rotated map origins are not supported (origin orientation "
                             "%.3f %.3f %.3f %.3f)" % (q.x, q.y, q.z, q.w))
        return cls(info.resolution, info.width, info.height,
                   info.origin.position.x, info.origin.position.y)

    @classmethod
    def from_bounds(cls, resolution: float, xmin: float, ymin: float,
                    xmax: float, ymax: float) -> GridInfo:
        """Smallest grid whose cells cover the rectangle [xmin, xmax] x [ymin, ymax] [m]."""
        if not (xmax > xmin and ymax > ymin):
            raise ValueError("empty bounds x[%g, %g] y[%g, %g]" % (xmin, xmax, ymin, ymax))
        width = int(math.ceil((xmax - xmin) / resolution))
        height = int(math.ceil((ymax - ymin) / resolution))
        return cls(resolution, width, height, xmin, ymin)

    @property
    def shape(self) -> Tuple[int, int]:
        """numpy shape ``(height, width)`` of arrays on this grid."""
        return (self.height, self.width)

    @property
    def xmax(self) -> float:
        return self.origin_x + self.width * self.resolution

    @property
    def ymax(self) -> float:
        return self.origin_y + self.height * self.resolution

    def world_to_cell(self, x, y) -> Tuple[np.ndarray, np.ndarray]:
        """Cell indices ``(ix, iy)`` (int64, possibly outside the grid) of world points [m]."""
        ix = np.floor((np.asarray(x, dtype=float) - self.origin_x) / self.resolution)
        iy = np.floor((np.asarray(y, dtype=float) - self.origin_y) / self.resolution)
        return ix.astype(np.int64), iy.astype(np.int64)

    def cell_to_world(self, ix, iy) -> Tuple[np.ndarray, np.ndarray]:
        """World coordinates [m] of cell centres."""
        x = self.origin_x + (np.asarray(ix, dtype=float) + 0.5) * self.resolution
        y = self.origin_y + (np.asarray(iy, dtype=float) + 0.5) * self.resolution
        return x, y

    def contains(self, ix, iy) -> np.ndarray:
        """Boolean mask: which cells lie inside the grid."""
        ix = np.asarray(ix)
        iy = np.asarray(iy)
        return (ix >= 0) & (ix < self.width) & (iy >= 0) & (iy < self.height)

    def grown(self, left: int, bottom: int, right: int, top: int) -> GridInfo:
        """The grid enlarged by whole cells on each side (origin stays on the same lattice)."""
        return GridInfo(self.resolution, self.width + left + right, self.height + bottom + top,
                        self.origin_x - left * self.resolution,
                        self.origin_y - bottom * self.resolution)

    def same_geometry(self, other: GridInfo, tol: float = 1e-9) -> bool:
        return (self.width == other.width and self.height == other.height
                and abs(self.resolution - other.resolution) <= tol
                and abs(self.origin_x - other.origin_x) <= tol
                and abs(self.origin_y - other.origin_y) <= tol)

    def __repr__(self) -> str:
        return ("GridInfo(resolution=%g, width=%d, height=%d, origin=(%g, %g))"
                % (self.resolution, self.width, self.height, self.origin_x, self.origin_y))


def grid_from_msg_data(data, width: int, height: int) -> np.ndarray:
    """``OccupancyGrid.data`` (sequence or bytes of int8) -> int8 array of shape (height, width)."""
    if isinstance(data, (bytes, bytearray)):
        arr = np.frombuffer(data, dtype=np.int8)
    else:
        arr = np.asarray(data, dtype=np.int8)
    if arr.size != width * height:
        raise ValueError("map data has %d cells, expected %d x %d = %d"
                         % (arr.size, width, height, width * height))
    return arr.reshape(height, width).copy()


def grid_to_msg_data(grid: np.ndarray) -> list:
    """int8 grid (height, width) -> the flat list ``OccupancyGrid.data`` wants (row-major)."""
    return np.ascontiguousarray(grid, dtype=np.int8).ravel().tolist()


def occupancy_from_counts(hits: np.ndarray, visits: np.ndarray, occ_thresh: float) -> np.ndarray:
    """gmapping's cell rule: unknown if never visited, else occupied iff hits/visits > occ_thresh.

    ``hits``/``visits`` are integer count arrays of one shape; returns an int8 -1/0/100 grid.
    """
    out = np.full(visits.shape, FREE, dtype=np.int8)
    out[hits.astype(np.float32) > np.float32(occ_thresh) * visits] = OCCUPIED
    out[visits == 0] = UNKNOWN
    return out


def sample_segments(x0, y0, x1, y1, step: float,
                    include_end: bool = False) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every ``step`` [m] along each segment (x0,y0)->(x1,y1), all segments at once.

    Broadcasts scalars against arrays (e.g. one start point, many end points). Returns
    ``(xs, ys, seg)`` where ``seg`` holds the index of the segment each point belongs to. The
    end point itself is included only with ``include_end``. Used to trace free space along
    laser beams: a cell the segment crosses for less than ``step`` may be skipped, so choose
    ``step`` well below the resolution when every cell matters.
    """
    x0, y0, x1, y1 = np.broadcast_arrays(*(np.asarray(v, dtype=float).ravel()
                                           for v in (x0, y0, x1, y1)))
    length = np.hypot(x1 - x0, y1 - y0)
    inner = np.ceil(length / step - 1e-9).astype(np.int64)  # samples k*step < length
    counts = inner + (1 if include_end else 0)
    seg = np.repeat(np.arange(x0.size), counts)
    # position of each sample inside its own segment: 0, 1, 2, ...
    starts = np.cumsum(counts) - counts
    k = np.arange(seg.size) - np.repeat(starts, counts)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(length[seg] > 0.0, k * step / length[seg], 1.0)
    frac = np.minimum(frac, 1.0)  # the extra sample of include_end is the end point itself
    xs = x0[seg] + frac * (x1[seg] - x0[seg])
    ys = y0[seg] + frac * (y1[seg] - y0[seg])
    return xs, ys, seg


def raycast(occupied: np.ndarray, info: GridInfo, x: float, y: float, angles,
            max_range: float, step: Optional[float] = None) -> np.ndarray:
    """Range [m] to the first occupied cell along each ray from (x, y); ``inf`` if none.

    ``occupied`` is a boolean (height, width) grid; cells outside it count as free. Rays are
    marched in steps of ``step`` (default resolution/4), all rays and steps at once, then the
    crossing into the occupied cell is bisected, so ranges are exact to step/64 (a wall thinner
    than ``step`` can be missed). A ray starting inside an occupied cell has range 0.
    Handy for simulating scans and for expected-range models.
    """
    angles = np.asarray(angles, dtype=float).ravel()
    if step is None:
        step = info.resolution / 4.0
    t = np.arange(0.0, max_range + step, step)
    t = t[t <= max_range + 1e-12]
    px = x + np.outer(np.cos(angles), t)
    py = y + np.outer(np.sin(angles), t)
    ix, iy = info.world_to_cell(px, py)
    inside = info.contains(ix, iy)
    hit = np.zeros(ix.shape, dtype=bool)
    hit[inside] = occupied[iy[inside], ix[inside]]
    found = hit.any(axis=1)
    first = np.argmax(hit, axis=1)
    # The cell boundary lies between the last free sample and the first occupied one:
    # bisect that interval (all rays at once) down to step / 2**BISECT_STEPS.
    lo = t[np.maximum(first - 1, 0)]
    hi = t[first]
    c = np.cos(angles)
    s = np.sin(angles)
    for _ in range(RAYCAST_BISECT_STEPS):
        mid = 0.5 * (lo + hi)
        mx, my = info.world_to_cell(x + c * mid, y + s * mid)
        ok = info.contains(mx, my)
        occ = np.zeros(mid.shape, dtype=bool)
        occ[ok] = occupied[my[ok], mx[ok]]
        hi = np.where(occ, mid, hi)
        lo = np.where(occ, lo, mid)
    return np.where(found & (first > 0), hi, np.where(found, 0.0, np.inf))


def load_map_yaml(path: str) -> Tuple[np.ndarray, GridInfo]:
    """Read a map_server map (YAML + image) into an int8 -1/0/100 grid and its GridInfo.

    Follows map_server's trinary interpretation: p = (255 - v)/255 (or v/255 with
    ``negate: 1``); p > occupied_thresh -> 100, p < free_thresh -> 0, else -1. The image's
    top row is the map's last row (map_server flips it).
    """
    import yaml  # only this loader needs PyYAML

    with open(path) as f:
        meta = yaml.safe_load(f)
    image_path = meta["image"]
    if not os.path.isabs(image_path):
        image_path = os.path.join(os.path.dirname(os.path.abspath(path)), image_path)
    img = cv2.imread(image_path, cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise OSError("cannot read map image %s" % image_path)
    value = img.astype(np.float64) / 255.0
    occ_p = value if int(meta.get("negate", 0)) else 1.0 - value
    grid = np.full(img.shape, UNKNOWN, dtype=np.int8)
    grid[occ_p > float(meta.get("occupied_thresh", 0.65))] = OCCUPIED
    grid[occ_p < float(meta.get("free_thresh", 0.196))] = FREE
    grid = np.flipud(grid).copy()
    origin = meta.get("origin", [0.0, 0.0, 0.0])
    if len(origin) > 2 and abs(float(origin[2])) > 1e-6:
        raise ValueError("rotated map origins are not supported (%s)" % path)
    info = GridInfo(float(meta["resolution"]), grid.shape[1], grid.shape[0],
                    float(origin[0]), float(origin[1]))
    return grid, info


def map_agreement(estimate: np.ndarray, est_info: GridInfo, truth: np.ndarray,
                  truth_info: GridInfo, offset=(0.0, 0.0, 0.0)) -> dict:
    """Compare a -1/0/100 map with ground truth, cell by cell.

    Every cell the estimate marks known (0 or 100) is looked up in the truth grid at its
    centre, mapped through ``offset`` = (x [m], y [m], yaw [rad]), the pose of the
    estimate's frame in the truth's frame (e.g. the robot's start pose for a SLAM map).
    Returns a dict:
      ``known``: estimated known cells that fall on known truth cells (the compared set);
      ``agree``: how many of those have the same value; ``accuracy`` = agree/known;
      ``free_accuracy`` / ``occupied_accuracy``: the same restricted to estimated free /
      occupied cells; ``unmatched``: estimated known cells that fall outside the truth grid or
      on its unknown cells (not compared, reported so nothing hides).
    """
    iy, ix = np.nonzero(estimate != UNKNOWN)
    est_vals = estimate[iy, ix]
    wx, wy = est_info.cell_to_world(ix, iy)
    ox, oy = float(offset[0]), float(offset[1])
    yaw = float(offset[2]) if len(offset) > 2 else 0.0
    c, s = math.cos(yaw), math.sin(yaw)
    tx, ty = truth_info.world_to_cell(ox + c * wx - s * wy, oy + s * wx + c * wy)
    inside = truth_info.contains(tx, ty)
    truth_vals = np.full(est_vals.shape, UNKNOWN, dtype=np.int8)
    truth_vals[inside] = truth[ty[inside], tx[inside]]
    compared = truth_vals != UNKNOWN
    agree = compared & (truth_vals == est_vals)
    result = {"known": int(compared.sum()), "agree": int(agree.sum()),
              "unmatched": int((~compared).sum())}
    result["accuracy"] = result["agree"] / result["known"] if result["known"] else float("nan")
    for name, value in (("free", FREE), ("occupied", OCCUPIED)):
        sel = compared & (est_vals == value)
        n = int(sel.sum())
        result[name + "_cells"] = n
        result[name + "_accuracy"] = float((agree & sel).sum()) / n if n else float("nan")
    return result
