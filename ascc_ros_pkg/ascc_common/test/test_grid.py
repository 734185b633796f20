"""ascc_common.grid: GridInfo geometry (cells <-> metres, bounds, growth, messages), the
thresholding rule and OccupancyGrid data <-> arrays."""
import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from ascc_common.grid import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    GridInfo,
    grid_from_msg_data,
    grid_to_msg_data,
    map_from_msg,
    to_trinary,
)


def _msg_info(resolution, width, height, ox, oy, qz=0.0, qw=1.0, qx=0.0):
    return SimpleNamespace(
        resolution=resolution, width=width, height=height,
        origin=SimpleNamespace(position=SimpleNamespace(x=ox, y=oy, z=0.0),
                               orientation=SimpleNamespace(x=qx, y=0.0, z=qz, w=qw)))


def test_cell_values():
    assert (UNKNOWN, FREE, OCCUPIED) == (-1, 0, 100)


def test_world_cell_round_trip_and_bounds():
    info = GridInfo(0.05, 40, 20, -1.0, 2.0)
    ix, iy = info.world_to_cell([-1.0, -0.976, 0.999, -1.0001], [2.0, 2.049, 2.99, 2.0])
    assert ix.tolist() == [0, 0, 39, -1]
    assert iy.tolist() == [0, 0, 19, 0]
    assert info.contains(ix, iy).tolist() == [True, True, True, False]
    x, y = info.cell_to_world([0, 39], [0, 19])
    assert np.allclose(x, [-0.975, 0.975]) and np.allclose(y, [2.025, 2.975])
    back = info.world_to_cell(x, y)
    assert back[0].tolist() == [0, 39] and back[1].tolist() == [0, 19]
    assert info.xmax == pytest.approx(1.0) and info.ymax == pytest.approx(3.0)
    assert info.bounds == pytest.approx((-1.0, 2.0, 1.0, 3.0))
    assert info.shape == (20, 40) and info.size_m == pytest.approx((2.0, 1.0))


def test_scalars_give_python_numbers_and_broadcast():
    info = GridInfo(0.1, 10, 10)
    ix, iy = info.world_to_cell(0.55, 0.25)
    assert (ix, iy) == (5, 2) and type(ix) is int and type(iy) is int
    assert info.contains(ix, iy) is True and info.contains(10, 0) is False
    x, y = info.cell_to_world(5, 2)
    assert type(x) is float and (x, y) == pytest.approx((0.55, 0.25))
    ix, iy = info.world_to_cell(np.array([[0.05, 0.15]]), 0.95)   # broadcasts
    assert ix.tolist() == [[0, 1]] and iy.tolist() == [[9, 9]]
    # fractional indices (centroids) map between centres
    assert info.cell_to_world(0.5, 0.0)[0] == pytest.approx(0.1)


def test_rotated_grid_round_trip():
    info = GridInfo(0.1, 10, 8, origin_x=2.0, origin_y=-1.0, origin_yaw=math.pi / 2)
    # cell (ix 5, iy 3) -> grid x 0.55, grid y 0.35, rotated by 90 deg
    x, y = info.cell_to_world(np.array([5]), np.array([3]))
    assert x[0] == pytest.approx(2.0 - 0.35) and y[0] == pytest.approx(-1.0 + 0.55)
    assert info.world_to_cell(x[0], y[0]) == (5, 3)
    ix, iy = info.world_to_cell(x, y)
    assert (ix[0], iy[0]) == (5, 3)
    assert info.bounds == pytest.approx((2.0 - 0.8, -1.0, 2.0, 0.0))
    # growing keeps every cell where it was in the world
    big = info.grown(2, 1, 0, 0)
    bx, by = big.world_to_cell(x[0], y[0])
    assert (bx, by) == (7, 4) and big.origin_yaw == info.origin_yaw


def test_axis_aligned_check_names_the_yaw():
    assert GridInfo(0.1, 2, 2).check_axis_aligned().width == 2
    with pytest.raises(ValueError, match=r"rotated map \(origin yaw 0.2 rad\)"):
        GridInfo(0.1, 2, 2, origin_yaw=0.2).check_axis_aligned()


def test_invalid_geometry_is_refused():
    for args in ((0.0, 1, 1), (-0.1, 1, 1), (float("nan"), 1, 1), (0.1, -1, 1),
                 (0.1, 1, 1, float("inf"))):
        with pytest.raises(ValueError):
            GridInfo(*args)


def test_value_semantics():
    a = GridInfo(0.05, 4, 3, 1, 2)
    assert a == GridInfo(0.05, 4, 3, 1.0, 2.0) and isinstance(a.origin_x, float)
    assert a.same_geometry(GridInfo(0.05 + 1e-12, 4, 3, 1.0, 2.0))
    assert not a.same_geometry(GridInfo(0.05, 4, 3, 1.0, 2.0, 0.1))
    assert not a.same_geometry(GridInfo(0.05, 5, 3, 1.0, 2.0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.width = 5
    assert "resolution=0.05" in repr(a)


def test_from_bounds_covers_rectangle():
    info = GridInfo.from_bounds(0.1, -1.0, -2.0, 1.05, 0.0)
    assert info.width == 21 and info.height == 20
    assert info.xmax >= 1.05 and info.origin_x == -1.0
    with pytest.raises(ValueError):
        GridInfo.from_bounds(0.1, 1.0, 0.0, 1.0, 1.0)


def test_grown_keeps_world_positions_on_the_lattice():
    info = GridInfo(0.05, 10, 10, 0.0, 0.0)
    big = info.grown(3, 2, 4, 1)
    assert (big.width, big.height) == (17, 13)
    # the same world point maps to the old cell shifted by the growth on the low sides
    ix, iy = info.world_to_cell(0.26, 0.31)
    bx, by = big.world_to_cell(0.26, 0.31)
    assert (bx - ix, by - iy) == (3, 2)


def test_from_msg_info_duck_typed_with_yaw():
    info = GridInfo.from_msg_info(_msg_info(0.05, 7, 9, 1.5, -2.0))
    assert info.shape == (9, 7) and info.origin_x == 1.5 and info.origin_y == -2.0
    assert info.origin_yaw == 0.0 and info.axis_aligned
    turned = GridInfo.from_msg_info(_msg_info(0.05, 7, 9, 0.0, 0.0, qz=math.sin(0.2),
                                              qw=math.cos(0.2)))
    assert turned.origin_yaw == pytest.approx(0.4)
    with pytest.raises(ValueError):  # the mapper/localizer/navigator refuse it this way
        turned.check_axis_aligned()
    # an all-zero quaternion (uninitialised message) is no rotation
    assert GridInfo.from_msg_info(_msg_info(0.05, 1, 1, 0.0, 0.0, qw=0.0)).origin_yaw == 0.0
    with pytest.raises(ValueError):  # tilted out of the plane
        GridInfo.from_msg_info(_msg_info(0.05, 1, 1, 0.0, 0.0, qx=0.3, qw=0.95))
    with pytest.raises(ValueError):  # an uninitialised message has resolution 0
        GridInfo.from_msg_info(_msg_info(0.0, 0, 0, 0.0, 0.0, qw=0.0))


def test_msg_data_round_trip_row_major():
    grid = np.array([[0, 100, -1], [100, 0, 0]], dtype=np.int8)
    data = grid_to_msg_data(grid)
    assert data == [0, 100, -1, 100, 0, 0]  # row 0 (lowest y) first
    assert np.array_equal(grid_from_msg_data(data, 3, 2), grid)
    assert np.array_equal(grid_from_msg_data(bytes(np.int8(data).tobytes()), 3, 2), grid)
    with pytest.raises(ValueError):
        grid_from_msg_data(data, 4, 2)
    # stand-ins with out-of-range values are clipped into int8, not wrapped
    assert grid_from_msg_data([300, -300], 2, 1).tolist() == [[127, -128]]


def test_thresholding_rule():
    raw = np.array([-1, 0, 19, 20, 50, 64, 65, 99, 100, 101, 127, -2, -128], np.int8)
    out, counts = to_trinary(raw)
    assert out.tolist() == [UNKNOWN, FREE, FREE, UNKNOWN, UNKNOWN, UNKNOWN, OCCUPIED,
                            OCCUPIED, OCCUPIED, UNKNOWN, UNKNOWN, UNKNOWN, UNKNOWN]
    assert counts == {"non_trinary": 10, "invalid": 4}
    out2, counts2 = to_trinary(raw, free_max=30, occupied_min=50)
    assert out2[3] == FREE and out2[4] == OCCUPIED
    clean, c = to_trinary(np.array([[-1, 0], [100, 0]], np.int8))
    assert c == {"non_trinary": 0, "invalid": 0} and clean.shape == (2, 2)
    with pytest.raises(ValueError):
        to_trinary(raw, free_max=70, occupied_min=60)


def test_map_from_msg_reads_geometry_and_data():
    grid = np.array([[0, 100, -1], [100, 0, 50]], dtype=np.int8)
    msg = SimpleNamespace(info=_msg_info(0.05, 3, 2, -1.0, 2.0), data=grid_to_msg_data(grid))
    got, info = map_from_msg(msg)
    assert np.array_equal(got, grid)                   # values as sent, not thresholded
    assert info == GridInfo(0.05, 3, 2, -1.0, 2.0)
    msg.data = msg.data[:-1]
    with pytest.raises(ValueError):
        map_from_msg(msg)
