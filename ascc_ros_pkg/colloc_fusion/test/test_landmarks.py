"""Desk corners measured in a grid, and the calibration from them (thesis 3.4.1)."""
import math
import os

import numpy as np
import pytest

from ascc_common.grid import GridInfo
from ascc_sim.world import load_world
from colloc_fusion.landmarks import calibrate, desk_corner, measure, occupied_points

WORLD = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "ascc_sim",
                     "worlds", "three_robots.yaml")


def block_grid(x0, y0, x1, y1, res=0.05, size=4.0):
    info = GridInfo(res, int(size / res), int(size / res))
    occ = np.zeros((info.height, info.width), dtype=np.int8)
    occ[int(round(y0 / res)):int(round(y1 / res)), int(round(x0 / res)):int(round(x1 / res))] \
        = 100
    return occ, info


@pytest.mark.parametrize("guess, corner", [((2.65, 2.45), (2.5, 2.3)),
                                           ((0.9, 0.95), (1.0, 1.0)),
                                           ((2.4, 1.15), (2.5, 1.0)),
                                           ((1.1, 2.2), (1.0, 2.3))])
def test_each_corner_of_a_block_within_half_a_cell(guess, corner):
    occ, info = block_grid(1.0, 1.0, 2.5, 2.3)
    got, why = desk_corner(occupied_points(occ, info), info.resolution, guess)
    assert why == "" and np.hypot(*(got - corner)) <= 0.5 * info.resolution * math.sqrt(2)


def test_no_corner_far_away_or_inside():
    occ, info = block_grid(1.0, 1.0, 2.5, 2.3)
    pts = occupied_points(occ, info)
    assert desk_corner(pts, 0.05, (3.5, 3.5))[0] is None
    corner, why = desk_corner(pts, 0.05, (1.75, 1.625), radius_m=0.2)
    assert corner is None and "inside" in why


def test_three_robots_world_desk_corners_and_calibration():
    world = load_world(WORLD)
    grid = world.truth_map
    truth = {o.name: (o.pose.x, o.pose.y) for o in world.objects if o.type == "landmark"}
    assert len(truth) == 4
    rng = np.random.default_rng(0)
    guesses = {n: np.array(p) + rng.uniform(-0.1, 0.1, 2) for n, p in truth.items()}
    found, failed = measure(grid.occupancy, grid.info, guesses)
    assert failed == {}
    for n, p in found.items():
        assert np.hypot(*(p - truth[n])) <= 0.05, (n, p, truth[n])
    fit, names = calibrate(truth, found)
    assert names == sorted(truth) and fit.rms_m < 0.05
    assert abs(fit.theta) < 0.02 and math.hypot(fit.tx, fit.ty) < 0.1


def test_calibration_of_a_moved_map():
    # the same desks in a map whose frame is rotated and shifted (a SLAM map starts at
    # the robot's pose): the corners measured there calibrate the truth into it
    world = load_world(WORLD)
    truth = {o.name: np.array((o.pose.x, o.pose.y)) for o in world.objects
             if o.type == "landmark"}
    theta, t = 0.3, np.array([-1.0, 0.5])
    r = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    in_map = {n: r @ p + t + np.random.default_rng(1).normal(0, 0.02, 2)
              for n, p in truth.items()}
    fit, _ = calibrate(truth, in_map)
    assert abs(fit.theta - theta) < 0.02 and np.hypot(fit.tx - t[0], fit.ty - t[1]) < 0.05
