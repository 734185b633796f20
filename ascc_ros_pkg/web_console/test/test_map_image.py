"""The map PNG: map_server's shades, north up, geometry header."""
import cv2
import numpy as np

from ascc_common.grid import GridInfo
from web_console.map_image import UNKNOWN_GREY, grid_to_png, map_header


def test_shades_and_flip():
    grid = np.array([[0, 100, -1],     # row iy = 0 (south)
                     [50, 0, 0]], dtype=np.int8)
    png = grid_to_png(grid)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    assert img.shape == (2, 3)
    # the image's bottom row is the grid's first (south) row
    assert list(img[1]) == [254, 0, UNKNOWN_GREY]
    assert list(img[0]) == [127, 254, 254]


def test_out_of_range_values_are_unknown():
    grid = np.array([[101, -50, 127]], dtype=np.int8)
    img = cv2.imdecode(np.frombuffer(grid_to_png(grid), np.uint8), cv2.IMREAD_UNCHANGED)
    assert (img == UNKNOWN_GREY).all()


def test_header():
    info = GridInfo(0.05, 320, 220, -1.0, -2.5)
    h = map_header(info)
    assert h == {"width": 320, "height": 220, "resolution": 0.05, "origin_x": -1.0,
                 "origin_y": -2.5}
