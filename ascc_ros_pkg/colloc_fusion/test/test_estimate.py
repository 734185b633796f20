"""Eq. 3.6-3.7 and the first-order covariance on hand-computed numbers, the Jacobians
against finite differences, the covariance against Monte Carlo."""
import math

import numpy as np

from colloc_fusion.estimate import (
    UNKNOWN_VARIANCE,
    bad_measurement,
    cov6_of_xy,
    estimate_target,
    jacobians,
    pose_cov3,
)


def test_eq_3_6_3_7_hand_computed():
    # robot at (1, 2) facing +y; target 2 m away at bearing -90 deg: straight along +x
    est = estimate_target("robotA", (1.0, 2.0, math.pi / 2), np.diag([0.01, 0.04, 0.0025]),
                          2.0, -math.pi / 2, 0.1, 0.05, 7.0)
    assert math.isclose(est.x, 3.0, abs_tol=1e-12) and math.isclose(est.y, 2.0, abs_tol=1e-12)
    # J_p = [[1, 0, 0], [0, 1, 2]], J_m = [[1, 0], [0, 2]]:
    # var x = 0.01 + 0.1^2 = 0.02; var y = 0.04 + 2^2 * 0.0025 + 2^2 * 0.05^2 = 0.06
    np.testing.assert_allclose(est.cov, [[0.02, 0.0], [0.0, 0.06]], atol=1e-12)
    assert est.robot == "robotA" and est.stamp_s == 7.0 and est.frame_id == "map"


def test_eq_3_6_3_7_oblique():
    est = estimate_target("r", (0.5, -1.0, 0.3), np.zeros((3, 3)), 1.7, 0.4, 0.01, 0.01, 0.0)
    assert math.isclose(est.x, 0.5 + 1.7 * math.cos(0.7))
    assert math.isclose(est.y, -1.0 + 1.7 * math.sin(0.7))


def f(v):
    x, y, th, d, b = v
    return np.array([x + d * math.cos(th + b), y + d * math.sin(th + b)])


def test_jacobians_against_finite_differences():
    v = np.array([0.3, -0.2, 2.1, 1.4, -0.6])
    jp, jm = jacobians(v[2], v[3], v[4])
    num = np.zeros((2, 5))
    for k in range(5):
        dv = np.zeros(5)
        dv[k] = 1e-6
        num[:, k] = (f(v + dv) - f(v - dv)) / 2e-6
    np.testing.assert_allclose(np.hstack([jp, jm]), num, atol=1e-8)


def test_covariance_against_monte_carlo():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(3, 3)) * 0.05
    p = a @ a.T + np.diag([1e-4, 1e-4, 1e-5])  # correlated pose covariance
    pose, d, b, sd, sb = np.array([1.0, 2.0, 0.4]), 2.5, 0.8, 0.03, 0.02
    est = estimate_target("r", pose, p, d, b, sd, sb, 0.0)
    n = 200000
    poses = rng.multivariate_normal(pose, p, size=n)
    ds = d + sd * rng.standard_normal(n)
    bs = b + sb * rng.standard_normal(n)
    pts = np.stack([poses[:, 0] + ds * np.cos(poses[:, 2] + bs),
                    poses[:, 1] + ds * np.sin(poses[:, 2] + bs)], axis=1)
    mc = np.cov(pts.T)
    # first order: agrees to a few per cent for these small angular errors
    np.testing.assert_allclose(est.cov, mc, rtol=0.05, atol=2e-5)


def test_pose_cov3_picks_x_y_yaw():
    cov = np.arange(36, dtype=float)
    np.testing.assert_array_equal(pose_cov3(cov), [[0, 1, 5], [6, 7, 11], [30, 31, 35]])


def test_bad_measurements_named():
    assert bad_measurement(1.0, 0.1, 0.01, 0.01) is None
    assert "range" in bad_measurement(float("nan"), 0.1, 0.01, 0.01)
    assert "range" in bad_measurement(0.0, 0.1, 0.01, 0.01)
    assert "bearing" in bad_measurement(1.0, float("inf"), 0.01, 0.01)
    assert "noise" in bad_measurement(1.0, 0.1, 0.0, 0.01)


def test_cov6_of_xy():
    c = np.array(cov6_of_xy(np.array([[0.02, 0.005], [0.005, 0.03]]))).reshape(6, 6)
    np.testing.assert_array_equal(c[:2, :2], [[0.02, 0.005], [0.005, 0.03]])
    np.testing.assert_array_equal(np.diag(c)[2:], [UNKNOWN_VARIANCE] * 4)
    assert np.count_nonzero(c) == 8
