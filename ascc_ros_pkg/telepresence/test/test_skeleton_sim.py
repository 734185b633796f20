"""The simulated tracker (telepresence.skeleton_sim): joints, gestures, imperfections."""
import math

import numpy as np
import pytest

from ascc_common.params import ParamError, from_params
from telepresence.gestures import JOINTS, elbow_angles
from telepresence.skeleton_sim import (
    GESTURES,
    PersonParams,
    SensorParams,
    SkeletonSimParams,
    SkeletonSource,
    make_script,
    script_of,
)

CLEAN = SensorParams(noise_m=0.0, drop_prob=0.0, missing_joint_prob=0.0, lost_per_min=0.0)


def frames(src, rate_hz=30.0):
    return [f for f in (src.frame(t) for t in np.arange(0.0, src.end_s, 1.0 / rate_hz))
            if f is not None]


def test_a_frame_has_the_15_joints_of_openni_tracker_in_front_of_the_sensor():
    src = SkeletonSource(script_of(["rest"], 0), CLEAN, 0, PersonParams(2.0, 0.1, 0.0, 1.0))
    f = src.frame(0.5)
    assert set(f.joints) == set(JOINTS) and f.user == 1
    assert f.joints["torso"][0] == pytest.approx(2.0)
    assert f.joints["head"][2] > f.joints["neck"][2] > f.joints["torso"][2] > 0.5
    # facing the sensor: the person's right shoulder is on the sensor's left (+y)
    assert f.joints["right_shoulder"][1] > f.joints["left_shoulder"][1]


@pytest.mark.parametrize("kind", GESTURES)
def test_the_gestures_move_the_forearm_as_scripted(kind):
    src = SkeletonSource(script_of(["rest", kind, "rest"], 4), CLEAN, 4)
    g = src.script[1]
    for t in np.linspace(g.t0 + 0.5, g.motion_end, 20):  # the cycles
        posture = src.body.posture(t)
        yaw, pitch = elbow_angles(src.frame(t).joints)
        fore = posture.fore
        assert yaw == pytest.approx(math.atan2(fore[1], fore[0]), abs=1e-6)
        assert pitch == pytest.approx(math.asin(fore[2]), abs=1e-6)


def test_same_seed_same_frames_other_seed_other_frames():
    a = SkeletonSource(make_script(5, 30.0), SensorParams(), 5)
    b = SkeletonSource(make_script(5, 30.0), SensorParams(), 5)
    c = SkeletonSource(make_script(6, 30.0), SensorParams(), 6)
    fa, fb = frames(a), frames(b)
    assert len(fa) == len(fb)
    assert all(np.array_equal(x.joints["right_hand"], y.joints["right_hand"])
               for x, y in zip(fa[:50], fb[:50]) if "right_hand" in x.joints)
    assert [e.kind for e in c.script] != [e.kind for e in a.script]


def test_dropped_frames_missing_joints_and_noise():
    sensor = SensorParams(noise_m=0.01, drop_prob=0.2, missing_joint_prob=0.1,
                          lost_per_min=0.0)
    src = SkeletonSource(script_of(["rest"] * 20, 1), sensor, 1, PersonParams())
    times = np.arange(0.0, src.end_s, 1.0 / 30.0)
    got = frames(src)
    assert 0.7 < len(got) / len(times) < 0.9
    lacking = sum(len(f.joints) < len(JOINTS) for f in got)
    assert 0.05 < lacking / len(got) < 0.15
    heads = np.array([f.joints["head"] for f in got if "head" in f.joints])
    assert 0.005 < float(np.std(heads[:, 0])) < 0.02  # the 1 cm noise at 2 m


def test_user_id_changes_after_a_lost_track_and_for_a_passer_by():
    sensor = SensorParams(noise_m=0.0, drop_prob=0.0, missing_joint_prob=0.0,
                          lost_per_min=6.0)
    src = SkeletonSource(script_of(["rest"] * 30, 2), sensor, 2)
    got = frames(src)
    users = [f.user for f in got]
    assert users == sorted(users) and users[-1] >= 3  # ~6 losses in a minute
    gaps = [b.t - a.t for a, b in zip(got, got[1:]) if b.user != a.user]
    assert min(gaps) > 0.25  # a new id only after the tracker lost the person
    walk = SkeletonSource(script_of(["rest", "walk_past", "rest"], 3), CLEAN, 3)
    assert sorted({f.user for f in frames(walk)}) == [1, 2, 3]


def test_nan_positions_when_asked():
    sensor = SensorParams(noise_m=0.0, drop_prob=0.0, missing_joint_prob=0.0, nan_prob=1.0,
                          lost_per_min=0.0)
    f = SkeletonSource(script_of(["rest"], 0), sensor, 0).frame(0.1)
    assert sum(not np.all(np.isfinite(v)) for v in f.joints.values()) == 1


def test_node_params_reject_an_unknown_episode_kind():
    p = from_params(SkeletonSimParams, {"episodes": "rest, come_close"}.get)
    assert [e.kind for e in p.script(0)] == ["rest", "come_close"]
    with pytest.raises(ParamError, match="unknown kind.*dance"):
        from_params(SkeletonSimParams, {"episodes": "rest,dance"}.get)
