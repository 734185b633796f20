"""The emulated sensors: postures, gait, persons; the sleep/wake rule and the duty cycle
tool; the emulator's frames through the receiver's core."""
import re

import numpy as np
import pytest

from semantic_mapping import duty_cycle
from semantic_mapping.body_signals import RATE_HZ, G, Person, render, sensor_signals
from semantic_mapping.emulator import Emulator
from semantic_mapping.power import PowerManager, PowerParams, awake_mask, hold_asleep, wake_ups
from semantic_mapping.wearable import ReceiverCore, ReceiverWarning, SampleOut

T = np.arange(0.0, 20.0, 1.0 / RATE_HZ)


def mean_accel(activity, position, seed=0):
    a, _, _ = sensor_signals(activity, position, Person.from_seed(seed), T)
    return a.mean(axis=0)


@pytest.mark.parametrize("activity, position, axis", [
    ("standing", "waist", 0), ("standing", "thigh", 0),   # x along the segment, up
    ("sitting", "waist", 0), ("sitting", "thigh", 2),     # thigh front up
    ("lying", "waist", 2), ("lying", "thigh", 2),
])
def test_gravity_follows_the_posture(activity, position, axis):
    m = mean_accel(activity, position)
    assert abs(np.linalg.norm(m) - G) < 0.3
    assert abs(m[axis]) > 0.95 * G   # within ~18 deg (person's offsets and mounting tilt)


def test_the_waist_leans_forward_when_typing_and_eating():
    pitch = {a: np.degrees(np.arctan2(-mean_accel(a, "waist")[2], mean_accel(a, "waist")[0]))
             for a in ("sitting", "typing", "eating")}
    assert pitch["sitting"] < pitch["typing"] < pitch["eating"]


def test_walking_bounces_at_the_step_frequency():
    p = Person.from_seed(2)
    a, g, _ = sensor_signals("walking", "waist", p, T)
    spectrum = np.abs(np.fft.rfft(np.linalg.norm(a, axis=1) - G))
    freqs = np.fft.rfftfreq(T.size, 1.0 / RATE_HZ)
    assert freqs[np.argmax(spectrum[1:]) + 1] == pytest.approx(2 * p.stride_hz, abs=0.1)
    _, g_thigh, _ = sensor_signals("walking", "thigh", p, T)
    assert np.abs(g_thigh).max() > 1.0 and np.abs(g).max() < np.abs(g_thigh).max()


@pytest.mark.parametrize("activity", ["walking", "opening_door", "carrying"])
def test_the_body_frame_signals_do_not_depend_on_the_heading(activity):
    """A person walking north measures what one walking east does (the gait's fore-aft
    acceleration turns with them; in the apartment a walk along the map's y was rendered
    sideways and recognized "unknown"); only the orientation turns."""
    p = Person.from_seed(5)
    t = np.arange(0.0, 6.0, 1.0 / RATE_HZ)
    for position in ("waist", "thigh"):
        east = sensor_signals(activity, position, p, t, 0.0, 0.0)
        for heading in (0.8, np.pi / 2, -2.5):
            other = sensor_signals(activity, position, p, t, 0.0, heading)
            np.testing.assert_allclose(other[0], east[0], atol=1e-9)   # accel
            np.testing.assert_allclose(other[1], east[1], atol=1e-6)   # gyro
            assert np.abs(np.abs(np.sum(other[2] * east[2], axis=1)) - 1.0).max() > 0.05


def test_gyro_matches_the_orientation_change():
    p = Person.from_seed(3)
    _, g, q = sensor_signals("walking", "thigh", p, T)
    dots = np.abs(np.sum(q[1:] * q[:-1], axis=1)).clip(max=1.0)
    angle_rate = 2 * np.arccos(dots) * RATE_HZ
    gyro_rate = np.linalg.norm(0.5 * (g[1:] + g[:-1]), axis=1)
    moving = angle_rate > 0.5
    assert np.median(np.abs(angle_rate[moving] - gyro_rate[moving])) < 0.1


def test_persons_differ_and_a_person_is_reproducible():
    a0, _, _ = sensor_signals("sitting", "waist", Person.from_seed(0), T)
    a0b, _, _ = sensor_signals("sitting", "waist", Person.from_seed(0), T)
    a1, _, _ = sensor_signals("sitting", "waist", Person.from_seed(1), T)
    assert np.array_equal(a0, a0b)
    assert np.abs(a0.mean(0) - a1.mean(0)).max() > 0.1


def test_render_inserts_the_transitions():
    p = Person.from_seed(0)
    d = render([("sitting", 5.0), ("walking", 5.0), ("sitting", 5.0)], p)
    labels = [lab for i, lab in enumerate(d["label"]) if i == 0 or lab != d["label"][i - 1]]
    assert labels == ["sitting", "sit_to_stand", "walking", "stand_to_sit", "sitting"]
    assert d["t"][-1] == pytest.approx(15.0 + 2 * p.transition_s, abs=0.06)


def test_power_rule_batch_equals_sample_by_sample_and_sleeps_when_still():
    p = Person.from_seed(4)
    d = render([("walking", 20.0), ("sitting", 60.0), ("walking", 10.0)], p)
    params = PowerParams()
    batch = awake_mask(d["waist_accel"], RATE_HZ, params)
    pm = PowerManager(RATE_HZ, params)
    online = np.array([pm.step(a)[0] for a in d["waist_accel"]])
    assert np.array_equal(batch, online)
    walking = d["label"] == "walking"
    assert batch[walking].all()
    assert not batch.all() and wake_ups(batch) >= 1
    # asleep at most sleep_after_s after the last motion: a still stretch sleeps
    still = PowerManager(RATE_HZ, params)
    states = [still.step([9.8, 0.0, 0.0])[0] for _ in range(int(12 * RATE_HZ))]
    assert states[int(9.9 * RATE_HZ)] and not states[int(10.1 * RATE_HZ)]


def test_hold_asleep_repeats_the_last_sample_sent():
    a = np.tile([9.8, 0.0, 0.0], (400, 1))
    a[:5, 0] += np.arange(5)  # a little motion, then still: asleep after 10 s
    a[300:, 1] = 3.0          # a jump at 15 s wakes it
    awake = awake_mask(a, RATE_HZ, PowerParams())
    held = hold_asleep(a, RATE_HZ, PowerParams())
    assert np.array_equal(held[awake], a[awake])
    asleep = np.flatnonzero(~awake)
    assert asleep.size > 0 and np.all(held[asleep] == a[asleep[0] - 1])
    assert awake[300]


def test_duty_cycle_tool(capsys):
    assert duty_cycle.main(["--seeds", "0", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert re.match(r"^duty_cycle: waist 0\.\d{4} thigh 0\.\d{4}$", lines[-1])
    rows = [ln.split() for ln in lines if re.match(r"^[01] ", ln)]
    assert len(rows) == 4 and all(0.0 < float(r[2]) < 1.0 for r in rows)


def test_duty_cycle_tool_bad_day(tmp_path, capsys):
    day = tmp_path / "day.yaml"
    day.write_text("day:\n  - [dancing, 10]\n")
    assert duty_cycle.main(["--day", str(day)]) == 2
    assert "day[0]: expected [activity, seconds > 0]" in capsys.readouterr().err


def test_emulator_frames_through_the_receiver():
    emu = Emulator(Person.from_seed(5), {"waist": 1, "thigh": 2}, RATE_HZ)
    rx = ReceiverCore({1: "waist", 2: "thigh"})
    got = {"waist": [], "thigh": []}
    warnings = []
    script = [("walk", 10.0), ("sit", 40.0), ("stand", 5.0)]
    t, segments = 0.0, []
    for activity, duration in script:
        for _ in range(int(duration * RATE_HZ)):
            out = rx.feed(emu.step(t, activity), t) + rx.check(t)
            for o in out:
                if isinstance(o, SampleOut):
                    got[o.sensor].append((t, o.sample))
                else:
                    assert isinstance(o, ReceiverWarning)
                    warnings.append(o.kind)
            if not segments or segments[-1] != emu.segment:
                segments.append(emu.segment)
            t += 1.0 / RATE_HZ
    assert segments[:4] == ["walking", "stand_to_sit", "sitting", "sit_to_stand"]
    assert warnings == []  # sleeping sensors announce it: no silent warnings
    for name in ("waist", "thigh"):
        times = np.array([s[0] for s in got[name]])
        assert np.sum(times < 10.0) == 200            # 20 Hz while walking
        assert len(times) < t * RATE_HZ               # and asleep for a while when sitting
        seqs = [s[1].seq for s in got[name]]
        assert seqs == sorted(seqs)
    thigh_sit = np.array([s[1].accel for s in got["thigh"] if 15 < s[0] < 20])
    assert thigh_sit[:, 2].mean() > 9.0               # the thigh lies flat
