"""Gesture motion control (telepresence.gesture_control): come close to the laser's stop
distance, back off by the odometry's distance, time-outs, no motion without measuring."""
import math
import warnings

import numpy as np
import pytest

from ascc_common.params import ParamError, from_params
from telepresence.gesture_control import (
    BACKING,
    COMING,
    IDLE,
    GestureController,
    GestureControlParams,
    distance_ahead,
)

P = GestureControlParams()
ANGLES = np.linspace(-2.0, 2.0, 401)


def wall_scan(x_m):
    """Ranges of a wall across the path at x_m ahead of a laser at the origin."""
    with np.errstate(divide="ignore"):
        r = x_m / np.cos(ANGLES)
    r[np.cos(ANGLES) <= 0.05] = np.inf
    return np.minimum(r, 5.6)


def test_distance_ahead_is_the_nearest_point_in_the_path():
    assert distance_ahead(wall_scan(2.0), ANGLES, (0.0, 0.0), 0.02, 5.6, 0.2) == \
        pytest.approx(2.0)
    assert distance_ahead(wall_scan(2.0), ANGLES, (0.1, 0.0), 0.02, 5.6, 0.2) == \
        pytest.approx(2.1)  # the mount's offset counts
    post = np.full(ANGLES.size, 5.6)
    post[np.abs(ANGLES - math.atan2(0.5, 1.0)) < 0.02] = math.hypot(1.0, 0.5)  # beside
    assert distance_ahead(post, ANGLES, (0.0, 0.0), 0.02, 5.6, 0.2) == pytest.approx(5.6,
                                                                                     abs=0.01)
    nothing = np.full(ANGLES.size, np.nan)
    assert distance_ahead(nothing, ANGLES, (0.05, 0.0), 0.02, 5.6, 0.2) == pytest.approx(5.65)


def test_distance_ahead_of_nan_and_inf_readings_warns_nothing():
    """numpy 1.17 (Ubuntu 20.04) warns on every comparison with NaN: robot logs."""
    scan = wall_scan(2.0)
    scan[::3] = np.nan
    scan[1::3] = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert distance_ahead(scan, ANGLES, (0.0, 0.0), 0.02, 5.6, 0.2) == pytest.approx(
            2.0, abs=0.01)


def run_come_close(x0, dt=0.1, scan_ok=lambda t: True, steps=400):
    """The robot at x (1D) drives toward a wall at x0; returns (x trajectory, commands)."""
    ctl = GestureController(P)
    ctl.on_gesture("come_close", 0.0)
    x, xs, cmds = 0.0, [], []
    for i in range(steps):
        t = i * dt
        ok = scan_ok(t)
        c = ctl.step(t, x0 - x if ok else None, t if ok else None, (x, 0.0), t)
        cmds.append(c)
        x += c.v * dt
        xs.append(x)
        if c.state == IDLE:
            break
    return xs, cmds


def test_come_close_stops_at_the_stop_distance():
    xs, cmds = run_come_close(2.5)
    assert cmds[-1].state == IDLE and "from the person" in cmds[-1].ended
    assert cmds[-1].v == 0.0
    assert 2.5 - xs[-1] == pytest.approx(P.stop_distance_m, abs=P.approach_min_speed_mps * 0.1
                                         + 1e-9)
    assert max(c.v for c in cmds) == pytest.approx(P.approach_speed_mps)
    assert all(c.state == COMING for c in cmds[:-1])


def test_come_close_does_not_move_when_already_close():
    xs, cmds = run_come_close(P.stop_distance_m - 0.1)
    assert len(cmds) == 1 and cmds[0].v == 0.0 and cmds[0].ended


def test_come_close_stops_without_a_fresh_scan():
    xs, cmds = run_come_close(4.0, scan_ok=lambda t: t < 1.0)
    assert "no fresh scan" in cmds[-1].ended
    assert len(cmds) <= 1.0 / 0.1 + 1 + P.scan_timeout_s / 0.1 + 1


def test_come_close_times_out():
    ctl = GestureController(P)
    ctl.on_gesture("come_close", 0.0)
    assert ctl.step(P.approach_timeout_s - 0.1, 3.0, P.approach_timeout_s - 0.1, None,
                    None).state == COMING
    c = ctl.step(P.approach_timeout_s + 0.1, 3.0, P.approach_timeout_s + 0.1, None, None)
    assert c.state == IDLE and "timed out" in c.ended


def test_go_away_backs_off_the_set_distance_slowly():
    ctl = GestureController(P)
    ctl.on_gesture("go_away", 0.0)
    x, dt, t, cmds = 1.0, 0.1, 0.0, []
    while True:
        c = ctl.step(t, 0.5, t, (x, 2.0), t)
        cmds.append(c)
        if c.state == IDLE:
            break
        assert c.v == -P.backoff_speed_mps and c.state == BACKING
        x += c.v * dt
        t += dt
    assert 1.0 - x == pytest.approx(P.backoff_distance_m, abs=P.backoff_speed_mps * dt)
    assert "backed off" in cmds[-1].ended


def test_go_away_without_odometry_or_too_long():
    ctl = GestureController(P)
    ctl.on_gesture("go_away", 0.0)
    c = ctl.step(0.1, 1.0, 0.1, None, None)
    assert c.state == IDLE and "odometry" in c.ended and c.v == 0.0
    ctl.on_gesture("go_away", 0.0)
    ctl.step(0.1, 1.0, 0.1, (0.0, 0.0), 0.1)
    c = ctl.step(P.backoff_timeout_s + 0.2, 1.0, 0.0, (0.0, 0.1), P.backoff_timeout_s + 0.2)
    assert c.state == IDLE and "timed out" in c.ended


def test_a_new_command_replaces_the_running_one_and_idle_sends_nothing():
    ctl = GestureController(P)
    assert ctl.step(0.0, 2.0, 0.0, (0, 0), 0.0) == (0.0, IDLE, None)
    ctl.on_gesture("come_close", 0.0)
    assert ctl.step(0.1, 2.0, 0.1, (0, 0), 0.1).state == COMING
    ctl.on_gesture("go_away", 0.2)
    assert ctl.step(0.3, 2.0, 0.3, (0, 0), 0.3).v < 0.0
    with pytest.raises(ValueError, match="unknown gesture command 'dance'"):
        ctl.on_gesture("dance", 0.4)


def test_params_reject_a_backoff_timeout_shorter_than_the_motion():
    with pytest.raises(ParamError, match="backoff_timeout_s"):
        from_params(GestureControlParams, {"backoff_timeout_s": 2.0}.get)
