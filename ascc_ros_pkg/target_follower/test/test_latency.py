"""The camera latency estimate (target_follower.latency), on synthetic runs with a known
latency and on a recorded run (held-out apartment, seed 1, before the estimate: the robot
weaved and fell back; data/follow_latency_apartment_seed1.json, written by
ascc_eval/scripts/plot_follow_run.py --fixture from bench_follow.py --record)."""
import json
import math
import os

import numpy as np
import pytest

from ascc_common.params import ParamError, from_params
from target_follower.following import OdomHistory, TargetFollowerParams
from target_follower.latency import LatencyEstimator, LatencyParams, place, poses_at, roughness

DATA = os.path.join(os.path.dirname(__file__), "data", "follow_latency_apartment_seed1.json")


def weaving_run(latency_s, seconds=20.0, rate_hz=8.0, weave_radps=0.5, seed=0):
    """A person walking straight along +x at 0.3 m/s, 1.2 m ahead of a robot that drives
    behind it and weaves (turn rate weave_radps * sin); the camera sees the person
    latency_s before each stamp. Returns (odom stamps, odom poses, detections
    [(stamp, x, y) base_link])."""
    rng = np.random.default_rng(seed)
    dt = 0.02
    t = np.arange(0.0, seconds, dt)
    yaw = -(weave_radps / 1.3) * np.cos(1.3 * t)  # yaw rate weave_radps * sin(1.3 t)
    x = 0.3 * t
    y = 0.15 * np.sin(0.7 * t)
    odom_t, odom = t, np.column_stack([x, y, yaw])
    stamps = np.arange(1.0, seconds - 0.1, 1.0 / rate_hz)
    taken = stamps - latency_s
    pose = poses_at(odom_t, odom, taken)
    person = np.column_stack([0.3 * taken + 1.2, np.zeros_like(taken)])
    d = person - pose[:, :2]
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    xb = c * d[:, 0] + s * d[:, 1]
    yb = -s * d[:, 0] + c * d[:, 1]
    rng_m = np.hypot(xb, yb) + rng.normal(0.0, 0.01, len(xb))  # laser range noise
    b = np.arctan2(yb, xb) + rng.normal(0.0, 0.005, len(xb))  # bearing noise
    return odom_t, odom, np.column_stack([stamps, rng_m * np.cos(b), rng_m * np.sin(b)])


def replay(est, odom_t, odom, detections):
    """Feed the detections as the node does (odometry known up to each stamp)."""
    out = []
    for t, xb, yb in detections:
        n = int(np.searchsorted(odom_t, t, side="right"))
        out.append(est.add(t, (xb, yb), odom_t[:n], odom[:n]))
    return np.array(out)


@pytest.mark.parametrize("latency_s", [0.0, 0.15, 0.3, 0.45])
def test_estimates_a_known_latency(latency_s):
    odom_t, odom, det = weaving_run(latency_s)
    est = LatencyEstimator(LatencyParams(latency_s=0.1))
    history = replay(est, odom_t, odom, det)
    assert est.estimates > 20  # of the 37 windows (one per latency_update_s)
    assert est.latency_std_s < est.p.max_latency_std_s
    # 0.05 s: at 0.5 rad/s and 1.2 m, 3 cm sideways
    assert abs(est.latency_s - latency_s) < 0.05, history[-10:]


def test_no_estimate_without_turn_rate_changes():
    """Driving straight, every candidate places the target alike: the start value stays."""
    odom_t, odom, det = weaving_run(0.3, weave_radps=0.0)
    odom[:, 1] = 0.0  # no weave at all
    est = LatencyEstimator(LatencyParams(latency_s=0.1))
    replay(est, odom_t, odom, det)
    assert est.estimates == 0
    assert est.latency_s == pytest.approx(0.1)


def gap_run(latency_s, seed=1):
    """A weave with detections (20 s), then a detection gap of 5 s during which the robot
    turns in place (0.6 rad/s for 1 s, back for 1 s, ending 0.2 s before the gap ends),
    then 15 s of driving straight behind the person, seen again. The
    windows after the gap hold positions taken while driving straight only: every
    latency that does not reach back into the turn places them alike."""
    rng = np.random.default_rng(seed)
    dt = 0.02
    t = np.arange(0.0, 40.0, dt)
    w = 0.5 * np.sin(1.3 * t) * (t < 20.0)
    w = np.where((t >= 22.8) & (t < 23.8), 0.6, w)
    w = np.where((t >= 23.8) & (t < 24.8), -0.6, w)
    yaw = np.cumsum(w) * dt
    v = np.where((t >= 22.8) & (t < 24.8), 0.0, 0.3)
    x = np.cumsum(v * np.cos(yaw)) * dt
    y = np.cumsum(v * np.sin(yaw)) * dt
    odom = np.column_stack([x, y, yaw])
    stamps = np.arange(1.0, 39.9, 0.125)
    stamps = stamps[(stamps < 20.0) | (stamps >= 25.0)]
    taken = stamps - latency_s
    pose = poses_at(t, odom, taken)
    ahead = 1.2  # the person keeps 1.2 m ahead of the robot along its heading line
    person = np.column_stack([np.interp(taken, t, x) + ahead, np.interp(taken, t, y)])
    d = person - pose[:, :2]
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    xb, yb = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    xb = xb + rng.normal(0.0, 0.01, len(xb))
    yb = yb + rng.normal(0.0, 0.01, len(yb))
    return t, odom, np.column_stack([stamps, xb, yb])


def test_straight_windows_after_a_turn_do_not_move_the_estimate():
    """After the gap the windows' positions were taken driving straight: the estimate
    keeps its value, but for the first windows, whose larger candidates reach back into
    the turn (they may move it by one bounded step, max_latency_change_s 0.05 s). The
    earlier rule (a turn-rate change anywhere in the window's odometry) took every such
    window and moved the estimate by 0.16 s."""
    odom_t, odom, det = gap_run(0.3)
    est = LatencyEstimator(LatencyParams(latency_s=0.3))  # the truth
    lat = replay(est, odom_t, odom, det[det[:, 0] >= 25.0])
    assert np.max(np.abs(lat - 0.3)) <= 0.05 + 1e-9, (lat.min(), lat.max())
    assert np.all(lat[-60:] == lat[-1])  # the straight windows did not move it


def test_straight_driving_is_not_excitation():
    """Driving straight, a latency error only shifts the positions: excitation 0."""
    odom_t, odom, det = weaving_run(0.3, weave_radps=0.0)
    odom[:, 1] = 0.0
    est = LatencyEstimator(LatencyParams(latency_s=0.1))
    replay(est, odom_t, odom, det)
    assert est.windows > 20
    assert est.last_excitation_m < 1e-9
    assert est.confidence == 0.0


def test_fixed_latency_when_estimate_is_off():
    odom_t, odom, det = weaving_run(0.3)
    est = LatencyEstimator(LatencyParams(latency_s=0.2, estimate_latency=False))
    assert np.all(replay(est, odom_t, odom, det) == 0.2)


def test_bad_positions_and_old_stamps_are_ignored():
    odom_t, odom, det = weaving_run(0.3)
    est = LatencyEstimator(LatencyParams())
    replay(est, odom_t, odom, det[:30])
    n = len(est._obs)
    est.add(float(det[29, 0]), (1.0, 0.0), odom_t, odom)  # not newer
    est.add(float(det[29, 0]) + 0.1, (math.nan, 0.0), odom_t, odom)
    assert len(est._obs) == n
    est.reset_track()
    assert est._obs == []


def test_roughness_is_zero_on_a_straight_walk():
    t = np.array([0.0, 0.1, 0.3, 0.35, 0.6])
    xy = np.column_stack([0.3 * t + 1.0, -0.2 * t])
    assert roughness(t, xy) == pytest.approx(0.0, abs=1e-12)


def test_params():
    with pytest.raises(ParamError):
        from_params(LatencyParams, {"latency_s": 0.8, "max_latency_s": 0.6}.get)
    p = from_params(TargetFollowerParams, {}.get)
    # the odometry kept covers the estimate's window at the largest latency
    assert p.odom_keep_s() >= p.latency.latency_window_s + p.latency.max_latency_s


def _distance_to_path(points, path):
    a, b = path[:-1], path[1:]
    ab = b - a
    ab2 = np.maximum((ab ** 2).sum(axis=1), 1e-12)
    out = []
    for p in points:
        u = np.clip(((p - a) * ab).sum(axis=1) / ab2, 0.0, 1.0)
        out.append(np.min(np.hypot(*(a + u[:, None] * ab - p).T)))
    return np.array(out)


def _placed(params, data):
    """The followed person's positions in odom as the node places them: each detection at
    the odometry pose at stamp - the latency estimate of that moment (target_follower_node
    ._take_target), and the estimates."""
    odom = np.asarray(data["odom"])
    history = OdomHistory(TargetFollowerParams(latency=params).odom_keep_s())
    est = LatencyEstimator(params)
    placed, latencies, k = [], [], 0
    for t, xb, yb in data["detections"]:
        while k < len(odom) and odom[k, 0] <= t:  # the odometry that has arrived
            history.add(float(odom[k, 0]), tuple(odom[k, 1:4]))
            k += 1
        pose = np.asarray(history.pose_at(t - est.latency_s))
        placed.append(place(pose[None, :], np.array([[xb, yb]]))[0])
        latencies.append(est.latency_s)
        est.add(t, (xb, yb), np.asarray(history.stamps), np.asarray(history.poses))
    return np.array(placed), np.array(latencies), est


def test_recorded_run_reproduces_the_weave_without_the_estimate():
    """The failure, from the recording: placed at the stamp, the person is off its path by
    more than the trail's 0.25 m gate (trail_max_innovation_m) in 1 of 10 frames, 0.3 m
    at the 95th percentile (the trail and the steering swing with the robot's turns: it
    weaves)."""
    with open(DATA) as f:
        data = json.load(f)
    pts, _, _ = _placed(LatencyParams(estimate_latency=False), data)
    err = _distance_to_path(pts, np.asarray(data["person_odom"])[:, 1:3])
    assert np.percentile(err, 95) > 0.25
    assert np.mean(err > 0.25) > 0.05


def test_recorded_run_estimate():
    """With the estimate (from 0, as the node starts), after a settling time of 10 s the
    positions stay near the person's true path: 95 % within the trail's 0.25 m gate; the
    estimate agrees with the latency measured on the truth."""
    with open(DATA) as f:
        data = json.load(f)
    pts, latencies, est = _placed(LatencyParams(), data)
    t = np.asarray(data["detections"])[:, 0]
    settled = t >= t[0] + 10.0
    err = _distance_to_path(pts[settled], np.asarray(data["person_odom"])[:, 1:3])
    assert np.percentile(err, 95) < 0.25, np.percentile(err, 95)
    assert np.mean(err > 0.25) <= 0.05
    assert abs(np.median(latencies[settled]) - data["latency_truth_fit_s"]) < 0.08
    assert est.estimates > 20
