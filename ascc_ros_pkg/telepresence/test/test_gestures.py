"""Gesture recognition (telepresence.gestures): the elbow angles, template files, the
sliding-window template matching, frames from TF and the bad-data rules."""
import math
import os

import numpy as np
import pytest

from telepresence.gestures import (
    JOINTS,
    BadSkeleton,
    GestureMatcher,
    GestureParams,
    GestureRecognizer,
    SkeletonFrames,
    Template,
    TemplateError,
    elbow_angles,
    load_template,
    save_template,
    template_from_dict,
    wrap,
)

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def skeleton(forearm, facing=math.pi, at=(2.0, 0.0, 1.1), lean=0.0):
    """Joints of a person at ``at`` facing ``facing`` (depth frame), leaning forward by
    ``lean`` [rad], with the right forearm ``forearm`` given in body coordinates
    (forward, left, up)."""
    f = np.array([math.cos(facing), math.sin(facing), 0.0])
    left = np.array([-math.sin(facing), math.cos(facing), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    up, f = math.cos(lean) * up + math.sin(lean) * f, math.cos(lean) * f - math.sin(lean) * up
    c = np.asarray(at, float)

    def body(x, y, z):
        return c + x * f + y * left + z * up
    elbow = body(0.1, -0.2, 0.1)
    return {"torso": body(0, 0, 0), "neck": body(0, 0, 0.35),
            "left_shoulder": body(0, 0.18, 0.3), "right_shoulder": body(0, -0.18, 0.3),
            "right_elbow": elbow,
            "right_hand": elbow + 0.27 * (forearm[0] * f + forearm[1] * left
                                          + forearm[2] * up)}


def unit(psi, theta):
    return (math.cos(theta) * math.cos(psi), math.cos(theta) * math.sin(psi),
            math.sin(theta))


# -- angles ------------------------------------------------------------------------------
@pytest.mark.parametrize("psi, theta", [(0.0, 0.0), (0.5, 0.3), (-1.2, -0.4), (2.5, 1.0),
                                        (-3.0, -1.2), (1.0, 1.5)])
@pytest.mark.parametrize("facing, at, lean", [(math.pi, (2.0, 0.0, 1.1), 0.0),
                                              (math.pi - 0.6, (1.5, 0.7, 1.0), 0.0),
                                              (2.0, (3.0, -0.5, 1.2), 0.3)])
def test_angles_are_the_forearms_yaw_and_pitch_in_the_body_frame(psi, theta, facing, at,
                                                                 lean):
    yaw, pitch = elbow_angles(skeleton(unit(psi, theta), facing, at, lean))
    assert pitch == pytest.approx(theta, abs=1e-9)
    assert float(wrap(yaw - psi)) == pytest.approx(0.0, abs=1e-9)


def test_named_directions():
    forward, left, up, down = (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, -1)
    assert elbow_angles(skeleton(forward)) == pytest.approx((0.0, 0.0))
    assert elbow_angles(skeleton(left)) == pytest.approx((math.pi / 2, 0.0))
    assert elbow_angles(skeleton(up))[1] == pytest.approx(math.pi / 2)
    assert elbow_angles(skeleton(down))[1] == pytest.approx(-math.pi / 2)
    # the person's right (-left) is the sensor's left (+y) when they face the sensor
    j = skeleton((0, -1, 0))
    assert j["right_hand"][1] > j["right_elbow"][1]


def test_bad_skeletons_are_named():
    j = skeleton((1, 0, 0))
    with pytest.raises(BadSkeleton, match="missing joints: right_hand"):
        elbow_angles({k: v for k, v in j.items() if k != "right_hand"})
    with pytest.raises(BadSkeleton, match="non-finite.*neck"):
        elbow_angles(dict(j, neck=(np.nan, 0.0, 1.0)))
    with pytest.raises(BadSkeleton, match="shoulders"):
        elbow_angles(dict(j, left_shoulder=j["right_shoulder"]))
    with pytest.raises(BadSkeleton, match="forearm"):
        elbow_angles(dict(j, right_hand=j["right_elbow"]))


# -- templates ---------------------------------------------------------------------------
RAW = {"smooth_s": 0.0}  # no moving average: the errors below are exact


def sine_template(command="come_close", rate=15.0, n=30, f=1.0, psi0=0.1, amp=0.5,
                  centre=0.7):
    t = np.arange(n) / rate
    return Template(command, rate, np.full(n, psi0) + 0.05 * np.sin(2 * np.pi * f * t),
                    centre - amp * np.cos(2 * np.pi * f * t))


def test_template_file_round_trip(tmp_path):
    tp = sine_template()
    path = str(tmp_path / "t.yaml")
    save_template(path, tp)
    back = load_template(path)
    assert back.command == "come_close" and back.rate_hz == 15.0
    np.testing.assert_allclose(back.pitch, tp.pitch, atol=1e-5)


def test_the_packages_templates_load():
    for c in ("come_close", "go_away"):
        tp = load_template(os.path.join(PKG, "templates", c + ".yaml"))
        assert tp.command == c and 1.0 < tp.duration_s < 3.0


@pytest.mark.parametrize("content, words", [
    ("command: come_close\nrate_hz: 15\nyaw_rad: [0.1, oops]\npitch_rad: [0.1]\n",
     "yaw_rad"),
    ("command: dance\nrate_hz: 15\nyaw_rad: [0, 0, 0, 0, 0]\npitch_rad: [0, 0, 0, 0, 0]\n",
     "dance"),
    ("command: go_away\nyaw_rad: [0, 0, 0, 0, 0]\npitch_rad: [0, 0, 0, 0, 0]\n",
     "lacks rate_hz"),
    ("command: go_away\nrate_hz: 15\nyaw_rad: [0, 0, 0, 0, 0, 0]\npitch_rad: [0, 0, 0, 0, 0]"
     "\n", "6 samples, pitch_rad 5"),
    ("command: go_away\nrate_hz: 15\nyaw_rad: [0, 0, 0, 0, 0]\npitch_rad: [0, 90, 0, 0, 0]"
     "\n", "not radians"),
    ("command: go_away\nrate_hz: 15\nyaw_rad: [0, 0, 0, 0, .nan]\npitch_rad: [0, 0, 0, 0, 0]"
     "\n", "finite"),
    ("[unclosed\n", "not YAML"),
    ("just text\n", "not a mapping"),
])
def test_malformed_templates_are_named(tmp_path, content, words):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(TemplateError, match=words):
        load_template(str(path))


def test_missing_template_is_named():
    with pytest.raises(TemplateError, match="cannot read template /nonexistent.yaml"):
        load_template("/nonexistent.yaml")
    with pytest.raises(TemplateError):
        template_from_dict(None)


# -- matching ----------------------------------------------------------------------------
def feed(matcher, psi, theta, rate=30.0, t0=0.0, skip=()):
    """Samples of the functions psi(t), theta(t) at ``rate`` from t0 until psi's data
    ends; returns the matches."""
    out = []
    for i in range(len(psi)):
        if i in skip:
            continue
        m = matcher.add(t0 + i / rate, float(psi[i]), float(theta[i]))
        if m is not None:
            out.append(m)
    return out


def motion(template, seconds, rate=30.0, speed=1.0, offset=(0.0, 0.0), lead_s=1.0):
    """The template's motion repeated for ``seconds`` at ``speed`` after ``lead_s`` of the
    arm at rest, sampled at ``rate``; (psi, theta, t of the last cycle's end)."""
    t = np.arange(0.0, lead_s + seconds, 1.0 / rate)
    k = np.arange(len(template.yaw)) / template.rate_hz
    period = template.duration_s + 1.0 / template.rate_hz
    phase = ((t - lead_s) * speed) % period
    psi = np.interp(phase, k, template.yaw) + offset[0]
    theta = np.interp(phase, k, template.pitch) + offset[1]
    rest = t < lead_s
    psi[rest], theta[rest] = 0.0, -1.3
    return psi, theta


def test_the_template_itself_matches_with_zero_error_at_its_end():
    tp = sine_template()
    m = GestureMatcher([tp], GestureParams(time_scales=[1.0], **RAW))
    psi, theta = motion(tp, tp.duration_s, rate=tp.rate_hz)
    matches = feed(m, psi, theta, rate=tp.rate_hz)
    assert len(matches) == 1
    assert matches[0].error_rad2 == pytest.approx(0.0, abs=1e-12)
    assert matches[0].t == pytest.approx(1.0 + tp.duration_s, abs=1e-9)


def test_error_is_the_mean_squared_angle_difference():
    tp = sine_template()
    m = GestureMatcher([tp], GestureParams(time_scales=[1.0], threshold_rad2=10.0, **RAW))
    psi, theta = motion(tp, tp.duration_s, rate=tp.rate_hz, offset=(0.0, 0.1))
    feed(m, psi, theta, rate=tp.rate_hz)
    assert m.best(1.0 + tp.duration_s).error_rad2 == pytest.approx(0.01, rel=1e-6)
    m.reset()
    psi, theta = motion(tp, tp.duration_s, rate=tp.rate_hz, offset=(0.2, 0.0))
    feed(m, psi, theta, rate=tp.rate_hz)
    expected = float(np.mean((np.cos(tp.pitch) * 0.2) ** 2))  # yaw weighed by cos(pitch)
    assert m.best(1.0 + tp.duration_s).error_rad2 == pytest.approx(expected, rel=1e-6)


def test_yaw_wraps_at_pi():
    tp = Template("go_away", 15.0, wrap(np.pi - 0.1 + 0.3 * np.sin(np.arange(30) / 3.0)),
                  np.zeros(30))
    m = GestureMatcher([tp], GestureParams(time_scales=[1.0], **RAW))
    psi, theta = motion(tp, tp.duration_s, rate=tp.rate_hz)
    matches = feed(m, wrap(psi), theta, rate=tp.rate_hz)
    assert matches and matches[0].error_rad2 < 1e-9


def test_moving_average_of_the_last_smooth_s():
    m = GestureMatcher([sine_template()], GestureParams(smooth_s=0.08))
    for i, (yaw, pitch) in enumerate([(0.0, 0.0), (0.3, 0.6), (0.6, 0.3), (0.9, 0.9)]):
        m.add(i / 30.0, yaw, pitch)
    t, yaw, pitch = m.samples[-1]
    assert (yaw, pitch) == pytest.approx((0.6, 0.6))  # the last 3 frames at 30 Hz
    assert m.samples[0][1:] == (0.0, 0.0)
    m.reset()
    m.add(0.0, math.pi - 0.05, 0.0)
    m.add(1 / 30.0, -math.pi + 0.05, 0.0)  # across the wrap: the mean is pi, not 0
    assert float(wrap(m.samples[-1][1])) == pytest.approx(-math.pi, abs=1e-9)


def test_threshold_decides():
    tp = sine_template()
    psi, theta = motion(tp, tp.duration_s, rate=30.0, offset=(0.0, 0.2))  # error 0.04
    assert feed(GestureMatcher([tp], GestureParams(threshold_rad2=0.05, **RAW)), psi, theta)
    assert not feed(GestureMatcher([tp], GestureParams(threshold_rad2=0.03, **RAW)), psi, theta)


def test_time_scales_find_a_slower_gesture():
    tp = sine_template()
    psi, theta = motion(tp, 1.25 * tp.duration_s + 0.1, speed=0.8)
    one_scale = GestureParams(time_scales=[1.0], threshold_rad2=2e-3, **RAW)
    assert not feed(GestureMatcher([tp], one_scale), psi, theta)
    matches = feed(GestureMatcher([tp], GestureParams(threshold_rad2=2e-3, **RAW)), psi, theta)
    assert matches and matches[0].time_scale == pytest.approx(1.25)
    assert matches[0].t == pytest.approx(1.0 + 1.25 * tp.duration_s, abs=0.04)


def test_the_best_template_under_the_threshold_is_the_command():
    a = sine_template("come_close")
    b = sine_template("go_away", psi0=-0.6, centre=0.2, amp=0.1)
    m = GestureMatcher([a, b], GestureParams(threshold_rad2=0.5))
    psi, theta = motion(b, b.duration_s)
    matches = feed(m, psi, theta)
    assert [x.command for x in matches] == ["go_away"]


def test_refractory_one_command_per_gesture_then_again():
    tp = sine_template()
    p = GestureParams(refractory_s=1.5)
    psi, theta = motion(tp, 4 * tp.duration_s)  # four cycles in a row
    matches = feed(GestureMatcher([tp], p), psi, theta)
    gaps = np.diff([x.t for x in matches])
    assert len(matches) >= 2 and np.all(gaps >= 1.5)


def test_no_window_across_a_gap():
    tp = sine_template()
    psi, theta = motion(tp, tp.duration_s)
    n = len(psi)
    gap = set(range(n - 25, n - 12))  # 0.43 s of lost frames inside the last window
    assert not feed(GestureMatcher([tp], GestureParams()), psi, theta, skip=gap)
    small = set(range(n - 20, n - 16))  # 0.13 s: within max_gap_s
    assert feed(GestureMatcher([tp], GestureParams()), psi, theta, skip=small)


def test_not_enough_history_no_comparison():
    m = GestureMatcher([sine_template()], GestureParams())
    assert m.add(0.0, 0.0, 0.0) is None and m.errors(0.0) == []
    assert m.add(0.0, 0.0, 0.0) is None  # not newer: ignored
    assert len(m.samples) == 1


# -- frames from TF and the recognizer's bad-data rules ---------------------------------
def test_frames_assembled_from_per_joint_stamps():
    frames = SkeletonFrames("openni_depth_frame", max_skew_s=0.05)
    j = dict(skeleton((1, 0, 0)), head=(2.0, 0.0, 1.6))  # 7 joints
    for i, (name, xyz) in enumerate(j.items()):
        assert frames.take(1.0 + i * 0.001) == []  # not complete yet
        assert frames.add("/openni_depth_frame", "%s_3" % name, 1.0 + i * 0.001, xyz) is None
    assert frames.take(1.02) == []  # 7 of 15 joints, within the skew: more may come
    # the next frame begins (a joint again): the first one is complete
    frames.add("openni_depth_frame", "torso_3", 1.033, j["torso"])
    (t, user, joints), = frames.take(1.034)
    assert user == 3 and set(joints) == set(j) and t == pytest.approx(1.006)
    assert "parent camera_link" in frames.add("camera_link", "head_3", 1.1, (0, 0, 0))
    assert frames.add("openni_depth_frame", "base_link", 1.1, (0, 0, 0)) is None


def test_a_frame_of_15_joints_is_complete_at_once_and_users_do_not_mix():
    frames = SkeletonFrames(max_skew_s=0.05)
    for i, name in enumerate(JOINTS):
        frames.add("openni_depth_frame", name + "_1", 5.0 + 0.001 * i, (2.0, 0.0, 1.0))
    assert [(f[1], len(f[2])) for f in frames.take(5.015)] == [(1, 15)]
    frames.add("openni_depth_frame", "torso_1", 5.03, (2.0, 0.0, 1.0))
    frames.add("openni_depth_frame", "torso_2", 5.031, (2.0, 0.0, 1.0))
    assert [(f[1], len(f[2])) for f in frames.take(5.2)] == [(1, 1), (2, 1)]


def test_an_incomplete_frame_is_given_after_the_skew_then_named():
    frames = SkeletonFrames(max_skew_s=0.05)
    j = skeleton((1, 0, 0))
    for name, xyz in j.items():
        if name != "right_elbow":
            frames.add("openni_depth_frame", name + "_1", 2.0, xyz)
    assert frames.take(2.02) == []
    (t, user, joints), = frames.take(2.06)
    with pytest.raises(BadSkeleton, match="missing joints: right_elbow"):
        elbow_angles(joints)


def test_recognizer_drops_the_window_when_the_user_changes():
    tp = sine_template()
    psi, theta = motion(tp, tp.duration_s, lead_s=0.0)
    rec = GestureRecognizer([tp], GestureParams())
    problems, matches = [], []
    for i in range(len(psi)):
        user = 1 if i < len(psi) // 2 else 2
        step = rec.on_frame(i / 30.0, user, skeleton(unit(psi[i], theta[i])))
        problems += step.problems
        matches += [step.match] if step.match else []
    assert matches == []
    assert [k for k, _ in problems] == ["user"]
    assert "changed from 1 to 2" in problems[0][1]


def test_recognizer_skips_bad_frames_and_names_them():
    tp = sine_template()
    rec = GestureRecognizer([tp], GestureParams())
    j = skeleton((1, 0, 0))
    step = rec.on_frame(0.0, 1, dict(j, right_hand=(np.nan, 0, 0)))
    assert step.match is None and step.angles is None and step.problems[0][0] == "bad"
    step = rec.on_frame(0.1, 1, {k: v for k, v in j.items() if k != "torso"})
    assert step.problems[0][0] == "missing" and "torso" in step.problems[0][1]
    assert len(rec.matcher.samples) == 0
