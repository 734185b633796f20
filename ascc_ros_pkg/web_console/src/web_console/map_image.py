"""The map as a PNG for the page (no rospy): map_server's shades, north up.

OccupancyGrid values -1 (unknown), 0..100 (occupancy %) become grey 205, white 254 ..
black 0 (as map_saver writes them); rows are flipped so that the image's top row is the
grid's last (largest y). One table lookup over the whole grid, no per-cell loop.
"""
from __future__ import annotations

from typing import Any, Dict

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
