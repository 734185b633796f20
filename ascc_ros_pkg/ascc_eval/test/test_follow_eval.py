"""follow_eval: distance, straight segments, corners, re-acquisition from synthetic runs."""
import json
import math

import numpy as np
import pytest

from ascc_eval.follow_eval import FollowMonitorParams, FollowRecord, FollowSample

R = 0.2  # person radius [m]


def l_route_run(gap_m, state_of=lambda t: "following", dt=0.1):
    """A person walking east 6 m then north 6 m at 0.3 m/s, the robot on the same path
    ``gap_m(t)`` metres (centre to centre) behind."""
    rec = FollowRecord(FollowMonitorParams())
    v = 0.3
    route = np.array([[0.0, 0.0], [6.0, 0.0], [6.0, 6.0]])

    def at(s):
        s = max(0.0, s)
        if s <= 6.0:
            return route[0] + [s, 0.0], 0.0
        return route[1] + [0.0, min(s - 6.0, 6.0)], math.pi / 2

    for k in range(int(40.0 / dt) + 1):
        t = k * dt
        s = v * t
        p, heading = at(s)
        q, robot_yaw = at(s - gap_m(t))
        speed = v if s < 12.0 else 0.0
        rec.add(FollowSample(t, (q[0], q[1], robot_yaw), (p[0], p[1], heading), speed, R,
                             state_of(t)))
    return rec


def test_constant_gap_gives_zero_error_on_straight_segments():
    rec = l_route_run(lambda t: 1.2 + R)
    s = rec.summary()
    assert s["straight_samples"] > 100
    assert s["straight_error_mean_m"] == pytest.approx(0.0, abs=1e-6)
    assert s["straight_error_p95_m"] == pytest.approx(0.0, abs=1e-6)
    assert s["person_path_m"] == pytest.approx(12.0, abs=0.05)
    assert len(s["corners"]) == 1 and s["corners"][0]["t_s"] == pytest.approx(20.0, abs=0.15)
    assert s["corners_reacquired"] == 1 and s["bumps"] == 0


def test_error_is_measured_from_the_set_point():
    rec = l_route_run(lambda t: 1.2 + R + 0.5)
    s = rec.summary()
    assert s["straight_error_mean_m"] == pytest.approx(0.5, abs=1e-6)
    assert s["straight_within_band"] == 0.0


def test_samples_right_after_a_corner_are_not_straight():
    rec = l_route_run(lambda t: 1.2 + R)
    a = rec.arrays()
    straight = rec.straight_mask(a["t"], a["person"][:, 2], a["speed"] > 1e-3)
    t = a["t"]
    assert not straight[(t > 20.0) & (t < 27.9)].any()
    assert straight[(t > 28.1) & (t < 39.0)].all()
    assert not straight[t < 7.9].any()


def test_a_lost_person_after_the_corner_is_reported():
    rec = l_route_run(lambda t: 1.4, state_of=lambda t: "searching" if 21 <= t < 25 else
                      "following")
    c = rec.summary()["corners"][0]
    assert c["not_following_s"] == pytest.approx(4.0, abs=0.15)
    assert c["reacquired"]
    rec = l_route_run(lambda t: 1.4, state_of=lambda t: "lost" if t >= 21 else "following")
    assert not rec.summary()["corners"][0]["reacquired"]


def test_files_are_written(tmp_path):
    rec = l_route_run(lambda t: 1.4)
    rec.add_bump(3.0)
    files = rec.write(str(tmp_path), "run")
    assert [f.rsplit("/", 1)[1] for f in files] == ["run.json", "run.csv", "run.png"]
    assert json.load(open(files[0]))["bumps"] == 1
    rows = (tmp_path / "run.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert header[:9] == ["t_s", "robot_x_m", "robot_y_m", "robot_yaw_rad", "person_x_m",
                          "person_y_m", "person_heading_rad", "distance_m", "state"]
    assert header[9:] == ["bearing_rad", "detected_range_m", "detected_bearing_rad",
                          "range_source", "followed_range_m", "followed_bearing_rad"]
    assert len(rows) == len(rec.samples) + 1
    last = rows[-1].split(",")
    assert float(last[0]) == pytest.approx(rec.samples[-1].t, abs=1e-3)
    assert float(last[7]) == pytest.approx(rec.arrays()["distance"][-1], abs=1e-3)
    assert last[8] == rec.samples[-1].state
    assert last[10:] == ["", "", "", "", ""]  # no belief recorded: empty cells
    assert (tmp_path / "run.png").stat().st_size > 1000


def with_belief(rec, detected=lambda s, k: None, followed=lambda s, k: None):
    """The record's samples with the follower's view: detected(sample, k) -> (range [m],
    bearing [rad], source) or None, followed(sample, k) -> (range, bearing) or None."""
    a = rec.arrays()
    for k, smp in enumerate(rec.samples):
        d = detected(a, k)
        if d is not None:
            smp.detected_range_m, smp.detected_bearing_rad, smp.range_source = d
        f = followed(a, k)
        if f is not None:
            smp.followed_range_m, smp.followed_bearing_rad = f
    return rec


def test_true_bearing_is_in_the_robots_frame():
    rec = l_route_run(lambda t: 1.2 + R)
    a = rec.arrays()
    t = a["t"]
    # behind the person on the same straight leg: straight ahead, whichever the leg
    assert np.abs(a["bearing"][(t > 5.0) & (t < 19.0)]).max() < 1e-9
    assert np.abs(a["bearing"][(t > 28.0) & (t < 38.0)]).max() < 1e-9
    # the robot still on the east leg, the person already north of the corner: to the left
    turning = (t > 20.5) & (t < 24.0)
    assert (a["bearing"][turning] > 0.1).all() and (a["bearing"][turning] < math.pi / 2).all()


def test_belief_errors_compare_the_followers_view_with_the_truth():
    rec = with_belief(
        l_route_run(lambda t: 1.2 + R),
        # the detector 0.1 m long and 0.05 rad left in every other sample, nothing between
        detected=lambda a, k: ((a["distance"][k] + 0.1, a["bearing"][k] + 0.05, "laser")
                               if k % 2 == 0 else None),
        # the followed point 0.2 m short on the second half
        followed=lambda a, k: (a["distance"][k] - (0.2 if a["t"][k] >= 20.0 else 0.0),
                               a["bearing"][k]))
    s = rec.summary()
    assert s["detection_fraction"] == pytest.approx(0.5, abs=0.01)
    assert s["detected_range_error_median_m"] == pytest.approx(0.1, abs=1e-3)
    assert s["detected_range_error_p95_m"] == pytest.approx(0.1, abs=1e-3)
    assert s["detected_bearing_error_median_rad"] == pytest.approx(0.05, abs=1e-3)
    assert s["followed_range_error_median_m"] == pytest.approx(0.2, abs=1e-3)
    assert s["followed_range_error_p95_m"] == pytest.approx(0.2, abs=1e-3)
    assert s["followed_bearing_error_p95_rad"] == pytest.approx(0.0, abs=1e-6)


def test_belief_in_the_csv(tmp_path):
    rec = with_belief(l_route_run(lambda t: 1.2 + R),
                      detected=lambda a, k: (1.0, -0.25, "size") if k == 0 else None)
    rec.write(str(tmp_path), "run")
    rows = (tmp_path / "run.csv").read_text().splitlines()
    first, second = rows[1].split(","), rows[2].split(",")
    assert [float(first[10]), float(first[11]), first[12]] == [1.0, -0.25, "size"]
    assert second[10:13] == ["", "", ""]


def test_no_belief_gives_no_errors():
    s = l_route_run(lambda t: 1.2 + R).summary()
    assert s["detection_fraction"] == 0.0
    assert s["detected_range_error_p95_m"] is None and s["followed_range_error_p95_m"] is None


def test_empty_record_summarises():
    assert FollowRecord().summary()["samples"] == 0
