"""ascc_common.pose2d: compose/inverse/relative, angle wrapping, quaternions."""
import math
from collections import namedtuple

import numpy as np
import pytest

from ascc_common import pose2d as P

Quat = namedtuple("Quat", "x y z w")


def test_pose_compose_inverse_relative():
    a = np.array([1.0, -2.0, 0.7])
    b = np.array([0.3, 0.4, -2.0])
    assert np.allclose(P.compose(a, P.inverse(a)), 0.0, atol=1e-12)
    assert np.allclose(P.compose(a, P.relative(a, b)), b)
    # a point 1 m ahead of a robot at (1, -2) facing 0.7 rad
    assert np.allclose(P.transform_points(a, [[1.0, 0.0]]), [[1 + math.cos(0.7),
                                                             -2 + math.sin(0.7)]])


def test_compose_broadcasts_over_particles():
    a = np.array([[0.0, 0.0, math.pi / 2], [1.0, 0.0, 0.0]])
    out = P.compose(a, [1.0, 0.0, 0.0])
    assert np.allclose(out, [[0.0, 1.0, math.pi / 2], [2.0, 0.0, 0.0]], atol=1e-12)


def test_wrap_angle_scalar_and_array():
    assert P.wrap_angle(3 * math.pi) == pytest.approx(-math.pi)
    assert isinstance(P.wrap_angle(7.0), float)
    assert P.wrap_angle(7.0) == pytest.approx(7.0 - 2 * math.pi)
    assert P.wrap_angle(-0.5) == pytest.approx(-0.5)
    out = P.wrap_angle(np.array([0.0, 2 * math.pi + 0.1, -math.pi - 0.1]))
    assert np.allclose(out, [0.0, 0.1, math.pi - 0.1])


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.5, math.pi - 1e-9])
def test_yaw_quaternion_round_trip(yaw):
    q = P.quaternion_from_yaw(yaw)
    assert math.isclose(sum(c * c for c in q), 1.0)
    assert P.yaw_from_quaternion(*q) == pytest.approx(yaw)
    assert P.yaw_of(Quat(*q)) == pytest.approx(yaw)
    assert np.allclose(P.z_axis_from_quaternion(*q), (0.0, 0.0, 1.0))


@pytest.mark.parametrize("theta", [0.0, 3.0, -3.0, math.pi, -math.pi, 7.5, -7.5, 1e3,
                                   -1e3, 2 * math.pi, 1e-17])
def test_scalar_wrap_matches_the_array_wrap(theta):
    scalar = P.wrap_angle(theta)
    assert isinstance(scalar, float)
    assert scalar == float(P.wrap_angle(np.array([theta]))[0])


def test_mean_yaw_across_pi_and_weighted():
    assert abs(P.wrap_angle(P.mean_yaw([math.pi - 0.1, -math.pi + 0.1]) - math.pi)) < 1e-12
    assert P.mean_yaw([0.2, 0.4]) == pytest.approx(0.3)
    # the weights pull the mean towards the heavier angle; weights of one angle only: it
    assert P.mean_yaw([0.0, 1.0], [3.0, 1.0]) == pytest.approx(math.atan2(math.sin(1.0),
                                                                         3 + math.cos(1.0)))
    assert P.mean_yaw([0.0, 1.0], [0.0, 2.0]) == pytest.approx(1.0)
