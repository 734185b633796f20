"""The location channel: the human's position, g([X, Y]) and the location types of fig.
5.4 on small maps (against a per-cell reference written from the definition)."""
import math

import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, GridInfo
from semantic_mapping.location import (
    LocationParams,
    grid_index,
    human_location,
    location_type_at,
    location_types,
)

RES = 0.05
P = LocationParams()  # 20 cm threshold, 0.5 m object


def room(w_m=3.0, h_m=3.0):
    """A closed room: walls one cell thick on the border."""
    grid = np.full((int(h_m / RES), int(w_m / RES)), FREE, dtype=np.int8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = OCCUPIED
    return grid, GridInfo(RES, grid.shape[1], grid.shape[0])


def reference_types(grid, params):
    """Per cell, straight from the definition: a side is beside a wall if an occupied cell
    lies within the threshold outside it, in the band as wide as the side."""
    occ = grid == OCCUPIED
    h, w = occ.shape
    half = int(round(params.object_half_size_m / RES))
    band = int(math.ceil(params.wall_threshold_m / RES - 1e-9))
    out = np.zeros((h, w), dtype=np.uint8)
    for iy in range(h):
        for ix in range(w):
            def any_occ(y0, y1, x0, x1):
                return occ[max(y0, 0):max(y1, 0), max(x0, 0):max(x1, 0)].any()
            px = any_occ(iy - half, iy + half + 1, ix + half + 1, ix + half + band + 1)
            nx = any_occ(iy - half, iy + half + 1, ix - half - band, ix - half)
            py = any_occ(iy + half + 1, iy + half + band + 1, ix - half, ix + half + 1)
            ny = any_occ(iy - half - band, iy - half, ix - half, ix + half + 1)
            n = int(px) + int(nx) + int(py) + int(ny)
            out[iy, ix] = (1 if n == 0 else 2 if n == 1 else 5 if n >= 3
                           else 4 if (px and nx) or (py and ny) else 3)
    return out


def test_types_in_a_room():
    grid, info = room()
    cl = location_types(grid, info, P)

    def at(x, y):
        ix, iy = info.world_to_cell(x, y)
        assert location_type_at(grid, info, P, x, y) == cl[iy, ix]
        return int(cl[iy, ix])

    assert at(1.5, 1.5) == 1      # the middle
    assert at(1.5, 0.40) == 2     # object side 0.15 m from the wall's face (< 0.20)
    assert at(1.5, 0.60) == 1     # 0.35 m from it
    assert at(0.40, 0.40) == 3    # a corner
    assert at(0.40, 2.60) == 3
    grid[:, 30] = OCCUPIED        # a wall through the middle: x 1.50..1.55
    cl = location_types(grid, info, P)
    assert at(1.20, 1.5) == 2     # west of it, side 0.05 m away


def test_corridor_and_dead_end():
    grid, info = room(3.0, 0.8)   # a corridor 0.7 m wide between its wall faces
    assert location_type_at(grid, info, P, 1.5, 0.4) == 4
    assert location_type_at(grid, info, P, 0.35, 0.4) == 5  # its closed end


def test_vectorised_equals_the_definition_on_a_random_map():
    rng = np.random.default_rng(3)
    grid = np.where(rng.random((40, 50)) < 0.04, OCCUPIED, FREE).astype(np.int8)
    grid[rng.random(grid.shape) < 0.05] = -1  # unknown cells are not walls
    for params in (P, LocationParams(0.1, 0.15), LocationParams(0.0, 0.25)):
        got = location_types(grid, GridInfo(RES, 50, 40), params)
        assert np.array_equal(got, reference_types(grid, params))
    assert set(np.unique(location_types(grid, GridInfo(RES, 50, 40), P))) == {1, 2, 3, 4, 5}


def reference_cover_types(grid, params):
    """Per cell, from the definition with ``wall_min_cover``: the fraction of a side's
    cells whose line out through the band meets an occupied cell."""
    occ = grid == OCCUPIED
    h, w = occ.shape
    half = int(round(params.object_half_size_m / RES))
    band = int(math.ceil(params.wall_threshold_m / RES - 1e-9))

    def hit(y, x):
        return 0 <= y < h and 0 <= x < w and bool(occ[y, x])

    out = np.zeros((h, w), dtype=np.uint8)
    for iy in range(h):
        for ix in range(w):
            along = range(-half, half + 1)
            out_of = range(half + 1, half + band + 1)
            cover = [np.mean([any(hit(iy + a, ix + sgn * d) for d in out_of) for a in along])
                     for sgn in (1, -1)]
            cover += [np.mean([any(hit(iy + sgn * d, ix + a) for d in out_of) for a in along])
                      for sgn in (1, -1)]
            px, nx, py, ny = (c > params.wall_min_cover for c in cover)
            n = int(px) + int(nx) + int(py) + int(ny)
            out[iy, ix] = (1 if n == 0 else 2 if n == 1 else 5 if n >= 3
                           else 4 if (px and nx) or (py and ny) else 3)
    return out


def test_wall_cover_vectorised_equals_the_definition():
    rng = np.random.default_rng(5)
    grid = np.where(rng.random((30, 36)) < 0.08, OCCUPIED, FREE).astype(np.int8)
    grid[4:6, :] = OCCUPIED  # a wall
    for params in (LocationParams(0.2, 0.25, 0.5), LocationParams(0.1, 0.15, 0.3)):
        got = location_types(grid, GridInfo(RES, 36, 30), params)
        assert np.array_equal(got, reference_cover_types(grid, params))
    # a tiny cover is the thesis's "any cell"
    any_cell = location_types(grid, GridInfo(RES, 36, 30), LocationParams(0.2, 0.25, 1e-9))
    assert np.array_equal(any_cell, location_types(grid, GridInfo(RES, 36, 30), P))


def test_a_long_item_beside_the_object_is_one_side_with_cover():
    """The person beside a bench 1.5 m long (a filled rectangle), 0.22 m from its face:
    with any cell, the bench's edge column reaches into the bands of the two neighbouring
    sides (three sides, CL 5); with cover 0.5 only the side along it counts (CL 2)."""
    grid, info = room(4.0, 4.0)
    grid[int(1.25 / RES):int(2.75 / RES), int(1.5 / RES):int(2.0 / RES)] = OCCUPIED
    x, y = 2.0 + 0.22, 2.0
    assert location_type_at(grid, info, P, x, y) == 5
    assert location_type_at(grid, info, LocationParams(wall_min_cover=0.5), x, y) == 2
    # away from the bench, in the open: no side either way
    assert location_type_at(grid, info, LocationParams(wall_min_cover=0.5), 3.0, 2.0) == 1


def test_human_location_rep103():
    # facing +y, the person on the left (bearing +90 deg) is at -x
    x, y = human_location(1.0, 2.0, math.pi / 2, 1.0, math.pi / 2)
    assert (x, y) == pytest.approx((0.0, 2.0))
    x, y = human_location(1.0, 2.0, 0.3, 2.0, -0.3)  # straight along the map's x
    assert (x, y) == pytest.approx((3.0, 2.0))


def test_grid_index():
    info = GridInfo(0.5, 4, 2, origin_x=-1.0, origin_y=0.0)
    assert grid_index(info, -0.9, 0.1) == (0, 0)
    assert grid_index(info, 0.99, 0.99) == (3, 1)
    with pytest.raises(ValueError, match=r"outside the map \(x -1.00..1.00, y 0.00..1.00"):
        grid_index(info, 1.2, 0.5)
