"""The odometry scale calibration's pure code (irobot_create_2_1.calibration): the wall fit
on simulated scans, and the factor from stops with a known scale error."""
import math

import numpy as np
import pytest

from irobot_create_2_1.calibration import Stop, WallFit, fit_wall, run_ratio, scale_factor

ANGLE_MIN = math.radians(-120.0)
INC = math.radians(240.0) / 682


def wall_scan(distance_m, tilt_rad=0.0, noise=0.0, seed=0, extra=None):
    """A URG-like scan of a flat wall whose normal points ``tilt_rad`` off straight ahead,
    ``distance_m`` from the laser along it; nothing else in range (inf)."""
    a = ANGLE_MIN + INC * np.arange(683)
    c = np.cos(a - tilt_rad)
    with np.errstate(divide="ignore"):
        r = np.where(c > 0.1, distance_m / c, np.inf)
    r = r + noise * np.random.default_rng(seed).standard_normal(r.size) * np.isfinite(r)
    if extra is not None:
        r[extra[0]] = extra[1]
    return r


def test_fit_wall_distance_and_angle():
    fit = fit_wall(wall_scan(2.5, math.radians(5.0)), ANGLE_MIN, INC, 0.02, 4.0, 0.26)
    assert fit.distance_m == pytest.approx(2.5, abs=1e-9)
    assert fit.angle_rad == pytest.approx(math.radians(5.0), abs=1e-9)
    # 1 % range noise (the URG model's) over the 85 beams within +-15 deg: mm
    noisy = fit_wall(wall_scan(2.5, 0.0, noise=0.025, seed=1), ANGLE_MIN, INC, 0.02, 4.0, 0.26)
    assert noisy.distance_m == pytest.approx(2.5, abs=0.005) and noisy.points > 80
    # a chair leg in front of the wall is an outlier, not a shift of the wall
    leg = fit_wall(wall_scan(2.5, extra=(np.arange(338, 345), 1.2)), ANGLE_MIN, INC, 0.02,
                   4.0, 0.26)
    assert leg.distance_m == pytest.approx(2.5, abs=1e-6)


def test_fit_wall_needs_a_wall_ahead():
    assert fit_wall(np.full(683, np.inf), ANGLE_MIN, INC, 0.02, 4.0, 0.26) is None
    assert fit_wall(wall_scan(5.0), ANGLE_MIN, INC, 0.02, 4.0, 0.26) is None  # out of range
    # a wall seen only far off to the side does not face the laser
    assert fit_wall(wall_scan(1.0, math.radians(70.0)), ANGLE_MIN, INC, 0.02, 4.0, 0.26) is None


def _stop(x, wall_m, angle=0.0, theta=0.0):
    return Stop((x, 0.0, theta), [WallFit(wall_m, angle, 0.001, 100)])


def test_scale_factor_from_odometry_that_overstates_distance():
    # the robot really moves 1.5 m per run; its odometry says 1.5 * 1.004
    stops, x, wall = [], 0.0, 3.4
    for i in range(7):
        stops.append(_stop(x, wall))
        step = 1.5 if i % 2 == 0 else -1.5
        x += 1.004 * step
        wall -= step
    factor, stderr, ratios = scale_factor(stops)
    assert factor == pytest.approx(1 / 1.004, abs=1e-9)
    assert len(ratios) == 6 and stderr == pytest.approx(0.0, abs=1e-9)


def test_a_run_not_square_to_the_wall_counts_its_full_length():
    # the wall's normal 10 deg off the heading, the robot drives straight 1.5 m along its
    # heading: the perpendicular distance changes by 1.5 cos(10 deg)
    tilt = math.radians(10.0)
    a = _stop(0.0, 3.0, angle=tilt)
    b = _stop(1.5, 3.0 - 1.5 * math.cos(tilt), angle=tilt)
    laser, odom = run_ratio(a, b)
    assert laser == pytest.approx(1.5) and odom == pytest.approx(1.5)
    with pytest.raises(ValueError, match="two stops"):
        scale_factor([a])
    with pytest.raises(ValueError, match="flat wall|no scan"):
        Stop((0.0, 0.0, 0.0), [])
