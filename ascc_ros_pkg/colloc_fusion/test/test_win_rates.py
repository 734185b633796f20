"""The benchmark's yardstick: how often an ideal fusion can beat a single robot."""
import math

import numpy as np
import pytest

from colloc_fusion.win_rates import (
    p_closer,
    p_fused_beats_robot,
    rayleigh_sigma,
    simulate_errors,
    win_rates,
)

N = 200000  # Monte Carlo draws: standard error of a share <= 0.0012
TOL = 0.006  # 5 standard errors


def test_p_closer_closed_forms():
    assert p_closer(1.0, 1.0, 0.0) == pytest.approx(0.5)
    assert p_closer(1.0, 1.0, 0.9) == pytest.approx(0.5)
    # independent Rayleighs: P(R_a < R_b) = b^2 / (a^2 + b^2); three equal robots 3/4
    assert p_closer(1.0 / 3.0, 1.0, 0.0) == pytest.approx(0.75)
    assert p_closer(0.2, 0.7, 0.0) == pytest.approx(0.7 / 0.9)
    # the fused error contains the robot's own: 1/2 + sqrt(2/6)/2 for three equal robots
    assert p_closer(1.0 / 3.0, 1.0, 1.0 / 3.0) == pytest.approx(0.5 + math.sqrt(2 / 6) / 2)
    with pytest.raises(ValueError):
        p_closer(1.0, 1.0, 1.0)  # X = Y: degenerate


def test_p_closer_against_monte_carlo_with_any_correlation():
    rng = np.random.default_rng(3)
    for vx, vy, c in ((0.3, 1.0, 0.4), (2.0, 0.5, -0.6), (1.0, 1.5, 0.0)):
        cov = np.array([[vx, c], [c, vy]])
        z = rng.multivariate_normal([0.0, 0.0], cov, size=(N, 2))  # N x axis x (X, Y)
        mc = np.mean(np.hypot(z[:, 0, 0], z[:, 1, 0]) < np.hypot(z[:, 0, 1], z[:, 1, 1]))
        assert mc == pytest.approx(p_closer(vx, vy, c), abs=TOL)


def test_three_equal_robots_monte_carlo_against_closed_forms():
    r = win_rates([0.01, 0.01, 0.01], trials=N, seed=1)
    assert r["closed_form_b"] == pytest.approx(0.5 + math.sqrt(2 / 6) / 2)
    assert r["best_on_average"] == pytest.approx(r["closed_form_b"], abs=TOL)
    # the fused error drawn independently of the robots': P(R_{s/sqrt3} < R_s) = 3/4
    sim = simulate_errors([0.01] * 3, N, np.random.default_rng(2))
    indep = win_rates([0.01] * 3, trials=N, seed=1, fused_errors=sim["fused"])
    assert indep["best_on_average"] == pytest.approx(0.75, abs=TOL)
    assert p_fused_beats_robot([0.01] * 3, 0, independent=True) == pytest.approx(0.75)
    # the best of three chosen afterwards: about half of the trials only
    assert 0.46 < r["per_trial_best"] < 0.51
    assert r["median_robot"] > r["best_on_average"] > r["per_trial_best"]


def test_unequal_robots():
    for sigmas in ([0.005, 0.007, 0.009], [1.0, 2.0, 4.0], [3.0, 1.0, 1.0]):
        r = win_rates(sigmas, trials=N, seed=4)
        assert r["best_on_average"] == pytest.approx(r["closed_form_b"], abs=TOL)
        # whatever the relative accuracies: near half against the best chosen afterwards
        assert 0.46 < r["per_trial_best"] < 0.52
    # one robot far better than the others: the fusion is that robot, ties half the time
    r = win_rates([0.001, 1.0, 1.0], trials=N, seed=5)
    assert r["best_on_average"] == pytest.approx(0.5, abs=TOL)


def test_rayleigh_sigma_recovers_the_scale():
    rng = np.random.default_rng(6)
    e = np.linalg.norm(rng.standard_normal((20000, 2)) * 0.004, axis=1)
    assert rayleigh_sigma(e) == pytest.approx(0.004, rel=0.03)
    # a wrong convergence among twenty trials hardly moves it
    assert rayleigh_sigma(np.r_[e[:19], 1.4]) == pytest.approx(rayleigh_sigma(e[:20]),
                                                              rel=0.25)
    with pytest.raises(ValueError):
        rayleigh_sigma([float("nan")])


def test_p_majority():
    from colloc_fusion.win_rates import p_majority
    assert p_majority(1, 0.3) == pytest.approx(0.3)
    assert p_majority(2, 0.5) == pytest.approx(0.25)  # both: a tie is not most
    assert p_majority(3, 0.5) == pytest.approx(0.5)
    assert p_majority(20, 0.5) == pytest.approx(0.4119, abs=1e-4)  # 1 - P(<= 10)
    assert p_majority(20, 0.79) > 0.99
