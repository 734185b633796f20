"""Eq. 3.1-3.5 on hand-computed numbers and on Table 3.1; the information filter; the
covariance intersection's defining property (consistent for any correlation) and the
information filter's overconfidence with correlated inputs."""
import math

import numpy as np
import pytest

from colloc_fusion.estimate import TargetEstimate
from colloc_fusion.fusion import (
    FusionError,
    ci_weights,
    covariance_intersection,
    fuse,
    information_fuse,
    thesis_fuse,
    thesis_weights,
)


def test_weights_eq_3_1_3_3_hand_computed():
    np.testing.assert_allclose(thesis_weights([1.0, 2.0, 4.0]), [4 / 7, 2 / 7, 1 / 7])


def test_eq_3_4_3_5_x_with_ux_and_y_with_uy():
    x, y, vx, vy = thesis_fuse([0.0, 1.0, 2.0], [0.0, 3.0, 6.0], [1.0, 2.0, 4.0],
                               [4.0, 2.0, 1.0])
    assert math.isclose(x, (0 * 4 + 1 * 2 + 2 * 1) / 7)  # 4/7
    assert math.isclose(y, (0 * 1 + 3 * 2 + 6 * 4) / 7)  # 30/7
    assert math.isclose(vx, 4 / 7) and math.isclose(vy, 4 / 7)


# Table 3.1 (thesis), set 2 and set 3: robots A, B, C
SET2 = dict(x=[1.67626, 1.52608, 1.51796], y=[0.70589, 0.6998, 0.7162],
            ux=[0.01248, 0.012039, 0.009264], uy=[0.002561, 0.0012959, 0.000376])
SET3 = dict(x=[1.39862, 1.3822, 1.4641], y=[1.2412, 1.2602, 1.286],
            ux=[0.01476, 0.017079, 0.0225], uy=[0.00780, 0.002451, 0.003677])


def by_hand(v, u):
    return sum(vi / ui for vi, ui in zip(v, u)) / sum(1.0 / ui for ui in u)


@pytest.mark.parametrize("s, printed", [(SET2, (1.56716, 0.71187)),
                                        (SET3, (1.41002, 1.26587))])
def test_table_3_1_inputs(s, printed):
    x, y, _, _ = thesis_fuse(s["x"], s["y"], s["ux"], s["uy"])
    assert math.isclose(x, by_hand(s["x"], s["ux"]), abs_tol=1e-12)
    assert math.isclose(y, by_hand(s["y"], s["uy"]), abs_tol=1e-12)
    # where Table 3.2 follows from Table 3.1 it agrees to 1e-4 m
    assert abs(x - printed[0]) < 1e-4 and abs(y - printed[1]) < 1e-4


def test_table_3_1_set_1_y_does_not_give_the_printed_value():
    x, y, _, _ = thesis_fuse([0.77325, 0.78929, 0.81590], [0.22630, 0.22650, 0.26530],
                             [0.10967, 0.0060329, 0.008578], [0.000935, 0.002237, 0.0015116])
    assert abs(x - 0.79946) < 1e-4
    assert abs(y - 0.23819) < 1e-5 and abs(y - 0.25819) > 0.019  # printed: 0.25819


def est(robot, mean, cov, stamp=0.0):
    return TargetEstimate(robot, float(mean[0]), float(mean[1]), np.asarray(cov), stamp)


def test_information_filter_hand_computed_and_equal_to_thesis_when_diagonal():
    mean, cov = information_fuse([[0.0, 0.0], [2.0, 1.0]], [np.diag([1.0, 4.0]),
                                                             np.diag([3.0, 4.0])])
    np.testing.assert_allclose(cov, np.diag([0.75, 2.0]))
    np.testing.assert_allclose(mean, [0.5, 0.5])
    ests = [est("a", [0.1, 0.2], np.diag([0.01, 0.04])), est("b", [0.3, 0.1],
                                                             np.diag([0.02, 0.01]))]
    t, i = fuse(ests, "thesis"), fuse(ests, "information")
    assert math.isclose(t.x, i.x) and math.isclose(t.y, i.y)
    np.testing.assert_allclose(t.cov, i.cov)


def test_information_filter_uses_the_correlation_within_an_estimate():
    # a long thin ellipse along the diagonal and a round one: the fused x and y move
    # together, which a per-axis weighting cannot do
    thin = np.array([[1.0, 0.99], [0.99, 1.0]])
    mean, cov = information_fuse([[1.0, -1.0], [0.0, 0.0]], [thin, np.eye(2)])
    assert mean[0] > 0.0 and mean[1] < 0.0
    assert cov[0, 1] > 0.0


def random_joint(rng, n, rho):
    """A joint error covariance of n 2D estimates whose blocks are correlated with the
    strength rho in [0, 1] (0: independent, 1: one shared error)."""
    shared = rng.normal(size=(2, 2))
    blocks = []
    for _ in range(n):
        own = rng.normal(size=(2, 2)) * rng.uniform(0.2, 2.0)
        blocks.append((math.sqrt(rho) * shared, math.sqrt(1 - rho) * own))
    a = np.zeros((2 * n, 2 + 2 * n))
    for i, (s, o) in enumerate(blocks):
        a[2 * i:2 * i + 2, :2] = s
        a[2 * i:2 * i + 2, 2 + 2 * i:4 + 2 * i] = o
    joint = a @ a.T + 1e-6 * np.eye(2 * n)
    return joint, [joint[2 * i:2 * i + 2, 2 * i:2 * i + 2] for i in range(n)]


def actual_cov(gains, joint):
    """The true error covariance of sum K_i x_i given the joint error covariance."""
    k = np.hstack(gains)
    return k @ joint @ k.T


@pytest.mark.parametrize("criterion", ["trace", "det"])
def test_ci_consistent_for_any_correlation(criterion):
    rng = np.random.default_rng(0)
    for trial in range(200):
        n = 2 + trial % 3
        joint, covs = random_joint(rng, n, rng.uniform(0.0, 1.0))
        _, p_ci, w = covariance_intersection([[0.0, 0.0]] * n, covs, criterion)
        gains = [w[i] * p_ci @ np.linalg.inv(covs[i]) for i in range(n)]
        slack = np.linalg.eigvalsh(p_ci - actual_cov(gains, joint))
        assert slack.min() > -1e-9 * np.abs(p_ci).max(), (trial, slack)


def test_information_filter_overconfident_where_ci_is_not():
    rng = np.random.default_rng(1)
    overconfident = 0
    for _ in range(50):
        joint, covs = random_joint(rng, 3, 0.9)  # strongly correlated errors
        _, p_if = information_fuse([[0.0, 0.0]] * 3, covs)
        gains = [p_if @ np.linalg.inv(c) for c in covs]
        if np.linalg.eigvalsh(p_if - actual_cov(gains, joint)).min() < -1e-9:
            overconfident += 1
        _, p_ci, w = covariance_intersection([[0.0, 0.0]] * 3, covs)
        gains = [w[i] * p_ci @ np.linalg.inv(covs[i]) for i in range(3)]
        assert np.linalg.eigvalsh(p_ci - actual_cov(gains, joint)).min() > -1e-9
    assert overconfident == 50


def test_identical_estimates_twice_information_halves_ci_keeps():
    cov = np.diag([0.04, 0.01])
    _, p_if = information_fuse([[1.0, 1.0]] * 2, [cov, cov])
    _, p_ci, _ = covariance_intersection([[1.0, 1.0]] * 2, [cov, cov])
    np.testing.assert_allclose(p_if, cov / 2)  # claims twice the information
    np.testing.assert_allclose(p_ci, cov, rtol=1e-6)  # the truth: one error, counted once


@pytest.mark.parametrize("criterion", ["trace", "det"])
def test_ci_weights_minimise_the_criterion(criterion):
    rng = np.random.default_rng(2)
    for _ in range(20):
        covs = []
        for _ in range(3):
            a = rng.normal(size=(2, 2))
            covs.append(a @ a.T + 0.05 * np.eye(2))
        w = ci_weights(covs, criterion)
        assert w.min() >= 0.0 and math.isclose(w.sum(), 1.0)
        infos = [np.linalg.inv(c) for c in covs]

        def value(ws, infos=infos):
            p = np.linalg.inv(sum(wi * i for wi, i in zip(ws, infos)))
            return np.trace(p) if criterion == "trace" else np.linalg.det(p)
        grid = [(a / 100, b / 100, 1 - (a + b) / 100) for a in range(101)
                for b in range(101 - a)]
        best = min(value(g) for g in grid if min(g) >= 0)
        assert value(w) <= best * (1 + 1e-9)


def test_fuse_reports_robots_and_left_out_and_refuses_nothing():
    ests = [est("robotA", [1.0, 2.0], np.eye(2) * 0.01), est("robotC", [1.2, 2.2],
                                                             np.eye(2) * 0.03)]
    for method in ("thesis", "information", "ci"):
        out = fuse(ests, method, left_out={"robotB": "robot robotB: stale"})
        assert out.robots == ["robotA", "robotC"] and "robotB" in out.left_out
        assert np.isfinite([out.x, out.y]).all() and np.isfinite(out.cov).all()
    with pytest.raises(FusionError):
        fuse([], "thesis")
    with pytest.raises(ValueError):
        fuse(ests, "average")


def test_fuse_never_nan_out():
    huge = [est("a", [1e308, 1e308], np.eye(2) * 1e-300), est("b", [-1e308, 1e308],
                                                               np.eye(2) * 1e-300)]
    for method in ("thesis", "information", "ci"):
        try:
            out = fuse(huge, method)
        except FusionError:
            continue
        assert np.isfinite([out.x, out.y]).all() and np.isfinite(out.cov).all()
