"""Calibration (3.4.1): a known rigid transform recovered from landmarks, with noise."""
import math

import numpy as np
import pytest

from colloc_fusion.calibration import CalibrationError, fit_rigid_2d

# the four desk corners of worlds/three_robots.yaml
CORNERS = np.array([[2.2, 6.15], [6.6, 6.15], [7.65, 2.8], [1.35, 3.2]])


def transform(theta, t, pts):
    c, s = math.cos(theta), math.sin(theta)
    return pts @ np.array([[c, -s], [s, c]]).T + np.asarray(t)


def test_exact_transform_recovered():
    dst = transform(0.7, (1.5, -2.0), CORNERS)
    fit = fit_rigid_2d(CORNERS, dst)
    assert math.isclose(fit.theta, 0.7, abs_tol=1e-12)
    assert math.isclose(fit.tx, 1.5, abs_tol=1e-12) and math.isclose(fit.ty, -2.0,
                                                                       abs_tol=1e-12)
    assert fit.rms_m < 1e-12
    np.testing.assert_allclose(fit.apply(CORNERS), dst, atol=1e-12)


@pytest.mark.parametrize("theta", [-3.0, -1.2, 0.0, 0.4, 2.9])
def test_known_transform_with_noise(theta):
    rng = np.random.default_rng(int(theta * 10) + 40)
    sigma = 0.01
    errs = []
    for _ in range(200):
        dst = transform(theta, (-0.3, 0.8), CORNERS) + rng.normal(0, sigma, CORNERS.shape)
        fit = fit_rigid_2d(CORNERS, dst)
        errs.append(np.abs(fit.apply(CORNERS) - transform(theta, (-0.3, 0.8), CORNERS)).max())
        dtheta = math.remainder(fit.theta - theta, 2 * math.pi)
        assert abs(dtheta) < 6 * sigma / 3.0  # lever arm ~3 m
        # 4 points, 3 parameters: the residual rms is about sigma * sqrt(5/8)
        assert fit.rms_m < 5 * sigma
    # the fitted transform is closer to the truth than the landmarks' own noise
    assert np.mean(errs) < 2.5 * sigma


def test_residual_reports_a_moved_landmark():
    dst = transform(0.2, (0.0, 0.0), CORNERS)
    dst[2] += [0.3, 0.0]
    fit = fit_rigid_2d(CORNERS, dst)
    assert int(np.argmax(fit.residuals_m)) == 2 and fit.rms_m > 0.1


def test_no_reflection():
    mirrored = CORNERS * [1.0, -1.0]
    fit = fit_rigid_2d(CORNERS, mirrored)
    r = fit.rotation
    assert math.isclose(np.linalg.det(r), 1.0) and fit.rms_m > 0.5


@pytest.mark.parametrize("src, dst", [
    (CORNERS[:2], CORNERS[:2]),
    (np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), np.array([[0.0, 0.0], [1.0, 1.0],
                                                               [2.0, 2.0]])),
    (CORNERS, CORNERS[:3]),
    (CORNERS, CORNERS * [1.0, float("nan")]),
])
def test_bad_correspondences(src, dst):
    with pytest.raises(CalibrationError):
        fit_rigid_2d(src, dst)


def test_apply_pose_turns_the_heading_too():
    fit = fit_rigid_2d([[0, 0], [1, 0], [0, 1]], [[1, 1], [1, 2], [0, 1]])  # +90 deg, (1, 1)
    assert fit.apply_pose([1.0, 0.0, 3.0]) == pytest.approx([1.0, 2.0, 3.0 + np.pi / 2
                                                             - 2 * np.pi])
