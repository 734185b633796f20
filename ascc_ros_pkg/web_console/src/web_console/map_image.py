"""The map as a PNG for the page (no rospy): map_server's shades, north up.

OccupancyGrid values -1 (unknown), 0..100 (occupancy %) become grey 205, white 254 ..
black 0 (as map_saver writes them); rows are flipped so that the image's top row is the
grid's last (largest y). One table lookup over the whole grid, no per-cell loop.
"""
from __future__ import annotations

from typing import Any, Dict, Tuple

import cv2
import numpy as np

from ascc_common.grid import GridInfo

UNKNOWN_GREY = 205  # map_server's shade of unknown cells

_LUT = np.full(256, UNKNOWN_GREY, dtype=np.uint8)
_LUT[:101] = np.round(254.0 - np.arange(101) * 254.0 / 100.0).astype(np.uint8)


def grid_to_png(grid: np.ndarray) -> bytes:
    """PNG bytes of ``grid[iy, ix]`` (int8/int values -1..100; others: unknown)."""
    values = np.asarray(grid).astype(np.int16)
    values = np.where((values < 0) | (values > 100), 255, values).astype(np.uint8)
    image = _LUT[values][::-1]
    ok, png = cv2.imencode(".png", np.ascontiguousarray(image))
    if not ok:
        raise ValueError("PNG encoding of a %dx%d map failed" % values.shape[::-1])
    return png.tobytes()


def map_header(info: GridInfo) -> Dict[str, Any]:
    """The page's description of the map image: size [cells], resolution [m/cell], the
    lower-left corner [m] (the map must be axis aligned)."""
    width, height = info.width, info.height
    return {"width": int(width), "height": int(height), "resolution": float(info.resolution),
            "origin_x": float(info.origin_x), "origin_y": float(info.origin_y)}


def crop_known(grid: np.ndarray, info: GridInfo, margin_cells: int) -> Tuple[np.ndarray, GridInfo]:
    """The part of ``grid[iy, ix]`` that holds known cells (values 0..100), grown by
    ``margin_cells`` and clipped to the grid, with its GridInfo (an axis-aligned grid; the
    origin moves to the crop's corner). A grid without known cells is returned whole: a
    mapper's large, mostly unknown canvas shows as its explored part on a small screen."""
    known = (grid >= 0) & (grid <= 100)
    rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
    if rows.size == 0:
        return grid, info
    y0, y1 = max(0, rows[0] - margin_cells), min(grid.shape[0], rows[-1] + 1 + margin_cells)
    x0, x1 = max(0, cols[0] - margin_cells), min(grid.shape[1], cols[-1] + 1 + margin_cells)
    cropped = GridInfo(info.resolution, x1 - x0, y1 - y0,
                       info.origin_x + x0 * info.resolution,
                       info.origin_y + y0 * info.resolution)
    return grid[y0:y1, x0:x1], cropped
