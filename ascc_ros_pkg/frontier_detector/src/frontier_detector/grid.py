"""Occupancy grids as numpy arrays: the thresholding rule, map geometry, map_server files.

A grid is an int8 array indexed [row, col]; row 0 / col 0 is the cell at the map origin
(as in nav_msgs/OccupancyGrid: data is row-major starting at the origin, +x along a row).
Cells hold UNKNOWN (-1), FREE (0) or OCCUPIED (100) once `to_trinary` has been applied.

Thresholding rule (`to_trinary`) for maps that are not gmapping-style trinary, e.g.
cartographer's 0..100 probabilities:
    value < 0 or value > 100        -> UNKNOWN  (counted as invalid when > 100)
    0 <= value <= free_max          -> FREE      (default free_max 19, map_server's 0.196)
    value >= occupied_min           -> OCCUPIED  (default occupied_min 65, map_server's 0.65)
    free_max < value < occupied_min -> UNKNOWN   (too uncertain to plan through or around)
No ROS import here.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Dict, Tuple

import cv2
import numpy as np

UNKNOWN = -1
FREE = 0
OCCUPIED = 100


@dataclass(frozen=True)
class MapInfo:
    """Geometry of a grid: metres per cell and the world pose of cell (0, 0)'s corner."""

    resolution: float          # [m/cell]
    origin_x: float = 0.0      # [m] world x of the corner of cell (row 0, col 0)
    origin_y: float = 0.0      # [m]
    origin_yaw: float = 0.0    # [rad] rotation of the grid in the world frame

    def world_to_cell(self, x: float, y: float) -> Tuple[int, int]:
        """(row, col) of the cell containing world point (x, y); may lie outside the grid."""
        dx, dy = x - self.origin_x, y - self.origin_y
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        gx, gy = c * dx + s * dy, -s * dx + c * dy
        return int(math.floor(gy / self.resolution)), int(math.floor(gx / self.resolution))

    def world_to_cells(self, x: np.ndarray, y: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Vectorised `world_to_cell`: int64 (rows, cols)."""
        dx = np.asarray(x, dtype=float) - self.origin_x
        dy = np.asarray(y, dtype=float) - self.origin_y
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        gx, gy = c * dx + s * dy, -s * dx + c * dy
        return (np.floor(gy / self.resolution).astype(np.int64),
                np.floor(gx / self.resolution).astype(np.int64))

    def cells_to_world(self, rows: np.ndarray, cols: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """World (x, y) [m] of cell centres; rows/cols may be fractional (centroids)."""
        gx = (np.asarray(cols, dtype=float) + 0.5) * self.resolution
        gy = (np.asarray(rows, dtype=float) + 0.5) * self.resolution
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        return self.origin_x + c * gx - s * gy, self.origin_y + s * gx + c * gy


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


def load_map_yaml(path: str) -> Tuple[np.ndarray, MapInfo]:
    """Read a map_server YAML + image (PGM/PNG) into a trinary int8 grid and its MapInfo.

    Follows map_server's rules: p = (255 - v) / 255 (or v / 255 with negate: 1);
    mode trinary (default) and scale: p > occupied_thresh -> 100, p < free_thresh -> 0,
    else -1 (scale's in-between probabilities are too uncertain to plan with: unknown);
    mode raw: the pixel value is the cell value, then `to_trinary`.
    The image's top row is the map's top (max y).
    """
    import yaml  # local: only the CLI and tests read files

    with open(path, encoding="utf-8") as f:
        meta = yaml.safe_load(f)
    if not isinstance(meta, dict) or "image" not in meta or "resolution" not in meta:
        raise ValueError(f"{path}: not a map_server YAML (needs image and resolution)")
    image_path = meta["image"]
    if not os.path.isabs(image_path):
        image_path = os.path.join(os.path.dirname(os.path.abspath(path)), image_path)
    img = cv2.imread(image_path, cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise ValueError(f"{path}: cannot read image {image_path}")
    img = np.flipud(img)                     # image row 0 is the top; grid row 0 the origin
    origin = list(meta.get("origin", [0.0, 0.0, 0.0])) + [0.0, 0.0, 0.0]
    info = MapInfo(float(meta["resolution"]), float(origin[0]), float(origin[1]),
                   float(origin[2]))
    mode = str(meta.get("mode", "trinary"))
    if mode == "raw":
        return to_trinary(img.astype(np.int16).clip(-1, 127).astype(np.int8))[0], info
    p = img.astype(np.float32) / 255.0
    if not int(meta.get("negate", 0)):
        p = 1.0 - p
    occ_t = float(meta.get("occupied_thresh", 0.65))
    free_t = float(meta.get("free_thresh", 0.196))
    grid = np.full(img.shape, UNKNOWN, dtype=np.int8)
    grid[p > occ_t] = OCCUPIED
    grid[p < free_t] = FREE
    return np.ascontiguousarray(grid), info


def save_map_yaml(path: str, grid: np.ndarray, info: MapInfo) -> None:
    """Write a trinary grid as map_server YAML + PGM (free 254, occupied 0, unknown 205)."""
    img = np.full(grid.shape, 205, dtype=np.uint8)
    img[grid == FREE] = 254
    img[grid == OCCUPIED] = 0
    base = os.path.splitext(path)[0]
    cv2.imwrite(base + ".pgm", np.flipud(img))
    with open(path, "w", encoding="utf-8") as f:
        f.write(f"image: {os.path.basename(base)}.pgm\nresolution: {info.resolution}\n"
                f"origin: [{info.origin_x}, {info.origin_y}, {info.origin_yaw}]\n"
                "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
