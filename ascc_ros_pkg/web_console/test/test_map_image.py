"""The map PNG: map_server's shades, north up, geometry header."""
import cv2
import numpy as np

from ascc_common.grid import GridInfo
from web_console.map_image import UNKNOWN_GREY, crop_known, grid_to_png, map_header


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


def test_crop_to_the_known_part_with_a_margin():
    grid = np.full((100, 200), -1, dtype=np.int8)
    grid[40:50, 120:150] = 0
    grid[45, 130] = 100
    info = GridInfo(0.05, 200, 100, -5.0, -2.5)
    part, sub = crop_known(grid, info, margin_cells=5)
    assert part.shape == (20, 40) and (sub.width, sub.height) == (40, 20)
    assert sub.origin_x == -5.0 + 115 * 0.05 and sub.origin_y == -2.5 + 35 * 0.05
    # the same world point is the same cell in both
    assert sub.world_to_cell(*info.cell_to_world(130, 45)) == (15, 10)
    assert part[10, 15] == 100
    # clipped at the edges, and an unknown grid stays whole
    grid[0, 0] = 0
    part, sub = crop_known(grid, info, margin_cells=5)
    assert (sub.origin_x, sub.origin_y) == (info.origin_x, info.origin_y)
    assert part.shape == (55, 155)
    empty = np.full((10, 10), -1, dtype=np.int8)
    assert crop_known(empty, info, 5)[1] is info
