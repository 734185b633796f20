"""The recognizer's sample rows (`alignment.SampleAligner`) and the emulator's sample clock
(`emulator.SampleClock`): every sample once and in order whatever the delivery's delays
and bursts, sleeping sensors held, the same features as the recording's."""
import numpy as np
import pytest

from semantic_mapping.activity import RecognizerConfig, window_features
from semantic_mapping.alignment import SampleAligner
from semantic_mapping.body_signals import Person, render
from semantic_mapping.emulator import SampleClock

RATE = 20.0
PERIOD = 1.0 / RATE


def aligner(**kw):
    args = dict(silent_after_s=0.25, max_backlog_s=2.0)
    args.update(kw)
    return SampleAligner(("waist", "thigh"), RATE, **args)


def deliver(al, waist, thigh, arrivals, ticks):
    """Feed the samples at their arrival times [s] (both sensors' sample k at
    arrivals[k]) and take the rows at each timer tick [s]; the rows as two arrays."""
    events = sorted([(t, 0, k) for k, t in enumerate(arrivals)] +
                    [(t, 1, -1) for t in ticks])
    rows = []
    for t, kind, k in events:
        if kind == 0:
            al.add("waist", waist[k], t)
            al.add("thigh", thigh[k], t)
        else:
            rows += al.rows(t)
    if not rows:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])


def test_late_ticks_and_bursts_lose_and_repeat_nothing():
    rec = render([("walking", 8.0), ("carrying", 8.0)], Person.from_seed(104), RATE)
    waist, thigh = rec["waist_accel"], rec["thigh_accel"]
    n = waist.shape[0]
    r = np.random.default_rng(3)
    # sent on time, delivered 0-40 ms late and in bursts of up to 3 (a busy serial
    # reader); the timer 0-100 ms late: the delays that broke the newest-sample scheme.
    # (A gap in delivery longer than silent_after_s would read as both sensors asleep.)
    arrivals = np.arange(n) * PERIOD + r.uniform(0.0, 0.04, n)
    burst = r.integers(1, 4, n)
    arrivals = np.maximum.accumulate(np.array(
        [arrivals[min(k + burst[k] - 1, n - 1)] for k in range(n)]))
    assert np.diff(arrivals).max() < 0.25
    ticks = np.arange(n + 2) * PERIOD + 0.025 + r.exponential(0.03, n + 2)
    ticks = np.minimum(np.maximum.accumulate(ticks), arrivals[-1] + 0.2)
    w, t = deliver(aligner(), waist, thigh, arrivals, ticks)
    assert w.shape[0] == n
    np.testing.assert_array_equal(w, waist)
    np.testing.assert_array_equal(t, thigh)
    cfg = RecognizerConfig(features="extended")
    np.testing.assert_array_equal(window_features(w, t, cfg)[0],
                                  window_features(waist, thigh, cfg)[0])


def test_no_row_before_both_sensors_were_heard():
    al = aligner()
    al.add("waist", [1.0, 0.0, 9.8], 0.0)
    assert al.missing() == ["thigh"]
    assert al.rows(5.0) == []
    al.add("thigh", [2.0, 0.0, 9.8], 5.0)
    assert al.missing() == []
    rows = al.rows(5.0)
    assert len(rows) == 1  # the waist's sample waited for the thigh's
    np.testing.assert_array_equal(rows[0][1], [2.0, 0.0, 9.8])


def test_a_late_sample_is_waited_for_then_a_silent_sensor_is_held():
    al = aligner(silent_after_s=0.25)
    al.add("waist", [0.0, 0.0, 1.0], 0.0)
    al.add("thigh", [0.0, 0.0, 2.0], 0.0)
    assert len(al.rows(0.01)) == 1
    for k in range(1, 5):  # the thigh falls silent: the waist goes on alone
        al.add("waist", [0.0, 0.0, 1.0 + k], k * PERIOD)
    assert al.rows(0.2) == []  # 0.2 s < silent_after_s: the thigh may still come
    rows = al.rows(0.26)       # now it is asleep: its last sample held
    assert [r[0][2] for r in rows] == [2.0, 3.0, 4.0, 5.0]
    assert all(r[1][2] == 2.0 for r in rows)


def test_with_every_sensor_asleep_rows_go_on_at_the_sample_rate():
    al = aligner(silent_after_s=0.25)
    al.add("waist", [0.0, 0.0, 1.0], 0.0)
    al.add("thigh", [0.0, 0.0, 2.0], 0.0)
    assert len(al.rows(0.0)) == 1
    assert al.rows(0.2) == []
    rows = al.rows(0.26) + al.rows(1.0) + al.rows(1.02)
    assert len(rows) == 20  # 1 s of held rows after the last sample
    assert all(r[0][2] == 1.0 and r[1][2] == 2.0 for r in rows)
    al.add("waist", [0.0, 0.0, 7.0], 1.05)  # the waist wakes
    al.add("thigh", [0.0, 0.0, 8.0], 1.05)
    rows = al.rows(1.06)
    assert [(r[0][2], r[1][2]) for r in rows] == [(7.0, 8.0)]


def test_a_full_queue_drops_its_oldest_sample():
    al = aligner(max_backlog_s=0.2)  # 4 samples
    al.add("thigh", [0.0, 0.0, 0.0], 0.0)
    kept = [al.add("waist", [0.0, 0.0, float(k)], 0.0) for k in range(6)]
    assert kept == [True] * 4 + [False] * 2
    assert al.dropped == 2
    rows = al.rows(0.3)  # 4 queued, then 0.3 s of silence held: 6 more
    assert [r[0][2] for r in rows] == [2.0, 3.0, 4.0, 5.0] + [5.0] * 6


@pytest.mark.parametrize("kw", [dict(silent_after_s=0.0), dict(max_backlog_s=-1.0)])
def test_bad_parameters_are_named(kw):
    with pytest.raises(ValueError, match="silent_after_s and max_backlog_s"):
        aligner(**kw)


def test_the_sample_clock_renders_missed_samples_at_their_own_times():
    c = SampleClock(RATE, max_backlog_s=1.0)
    assert c.due(0.0) == [0.0]
    assert c.due(0.01) == []
    assert c.due(0.17) == pytest.approx([0.05, 0.10, 0.15])  # a tick 120 ms late
    assert c.due(0.20) == pytest.approx([0.20])
    got = c.due(5.0)  # a 4.8 s jump: the last second only
    assert len(got) == 20 and got[-1] == pytest.approx(5.0)
    assert c.skipped == 96 - 20  # samples 5..100 were due
    c.reset()
    assert c.due(0.05) == pytest.approx([0.0, 0.05])
