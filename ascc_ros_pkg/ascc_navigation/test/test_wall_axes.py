"""Tests of the wall-direction measurement (``ascc_navigation.wall_axes``; no ROS master)."""

import math

import numpy as np
import pytest

from ascc_common.grid import OCCUPIED
from ascc_navigation import synthetic as S
from ascc_navigation.laser import LaserMount, prepare_scan
from ascc_navigation.wall_axes import scan_wall_axis, wrap_right_angle


def _rotate(pts, angle):
    c, s = math.cos(angle), math.sin(angle)
    return pts @ np.array([[c, -s], [s, c]]).T


def _corridor_points(rng, n=600, half_width=1.2, noise=0.01):
    """A corridor's two side walls (y = +-half_width, x in -4..4) and an end wall at x 3.5."""
    x = rng.uniform(-4.0, 4.0, n)
    y = np.where(rng.random(n) < 0.5, half_width, -half_width) + rng.normal(0.0, noise, n)
    end = np.c_[3.5 + rng.normal(0.0, noise, 60), rng.uniform(-half_width, half_width, 60)]
    return np.r_[np.c_[x, y], end]


def test_wrap_right_angle_takes_directions_modulo_a_right_angle():
    a = np.array([0.0, 0.1, math.pi / 2 + 0.1, -math.pi + 0.1, math.pi / 4, -math.pi / 4])
    w = wrap_right_angle(a)
    assert np.allclose(w[:4], 0.1 * np.array([0, 1, 1, 1]))
    assert np.all((w >= -math.pi / 4) & (w < math.pi / 4))


@pytest.mark.parametrize("angle", [0.0, 0.004, 0.3, -0.7, 1.0, math.pi / 4 - 0.01])
def test_corridor_walls_give_their_direction_to_a_fraction_of_a_milliradian(angle):
    rng = np.random.default_rng(1)
    axis = scan_wall_axis(_rotate(_corridor_points(rng), angle))
    assert axis is not None
    assert abs(float(wrap_right_angle(axis.angle - angle))) < 5e-4
    assert axis.points > 500 and axis.spread_m2 > 1000.0


def test_a_scan_of_the_synthetic_office_shows_the_robots_heading():
    # The office's walls lie along the map's axes, so in the robot's frame they lie at minus
    # its heading (modulo a right angle); the scan comes from the laser model with 1 cm noise.
    truth, info = S.office_world()
    spec, mount = S.LaserSpec(), LaserMount(0.05, 0.0, 0.0)
    for heading in (0.0, 0.37, 2.0, -1.2):
        pose = np.array([4.0, 1.8, heading])
        ranges = S.simulate_scan(truth == OCCUPIED, info, pose, mount, spec,
                                 np.random.default_rng(2), noise_std=0.01)
        scan = prepare_scan(ranges, spec.angle_min, spec.angle_increment, spec.range_min,
                            spec.range_max, mount, 3.9)
        axis = scan_wall_axis(scan.hits)
        assert axis is not None
        assert abs(float(wrap_right_angle(axis.angle + heading))) < 2e-3


def test_no_straight_walls_no_direction():
    rng = np.random.default_rng(3)
    assert scan_wall_axis(rng.uniform(-3.0, 3.0, (400, 2))) is None   # clutter
    assert scan_wall_axis(np.zeros((5, 2))) is None                     # too few points
    short = np.c_[rng.uniform(0.0, 0.3, 100), np.full(100, 1.0)]        # a 0.3 m wall
    assert scan_wall_axis(short) is None


def test_a_stretch_of_wall_a_few_degrees_off_shows_as_disagreement():
    # A corridor whose left wall bends by 3.6 degrees (the held-out annex world's skewed
    # side) after x = 1: the bent stretch near the left wall's line is caught by its
    # histogram peak, and the common direction is a mix. Straight walls of one direction
    # disagree by nothing beyond their own fits' noise.
    rng = np.random.default_rng(4)
    straight = scan_wall_axis(_corridor_points(rng))
    assert straight is not None and straight.disagreement < 1e-3
    pts = _corridor_points(rng)
    bent = (pts[:, 1] > 1.0) & (pts[:, 0] > 1.0)
    pts[bent, 1] += (pts[bent, 0] - 1.0) * math.tan(math.radians(3.6))
    mixed = scan_wall_axis(pts)
    assert mixed is not None and mixed.disagreement > 0.02
