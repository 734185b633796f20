"""PacedTimer on a fake clock: a simulated clock with 10 ms steps at a given real-time
factor, driven by the timer's own wall-time sleeps (no threads, no ROS)."""
import math

import pytest

from ascc_common.paced_timer import PacedTimer


class FakeClock:
    """Wall time advances only when the timer sleeps; the simulated clock follows it at
    ``rate`` in steps of ``step`` (0: continuous, as on a robot)."""

    def __init__(self, rate=1.0, step=0.01, start=0.0):
        self.wall = 0.0
        self.rate = rate
        self.step = step
        self.offset = start
        self.jump_at = None       # (wall time, new clock value)

    def now(self):
        if self.jump_at is not None and self.wall >= self.jump_at[0]:
            self.offset = self.jump_at[1] - self.wall * self.rate
            self.jump_at = None
        t = self.offset + self.wall * self.rate
        return math.floor(t / self.step + 1e-9) * self.step if self.step else t

    def sleep(self, s):
        assert s > 0.0
        self.wall += s


def _run(clock, period, until_wall, callback=None, **kw):
    calls = []

    def cb():
        calls.append(clock.now())
        if callback:
            callback()

    timer = PacedTimer(period, cb, clock.now, lambda: clock.wall >= until_wall,
                       sleep=clock.sleep, wall=lambda: clock.wall, start=False, **kw)
    timer.run()
    return timer, calls


@pytest.mark.parametrize("rate", [0.5, 1.0, 4.0, 10.0])
def test_calls_every_period_of_the_simulated_clock_with_few_wakes(rate):
    clock = FakeClock(rate=rate, step=0.01, start=1.0)
    timer, calls = _run(clock, 0.05, until_wall=60.0 / rate)     # 60 s simulated
    gaps = [b - a for a, b in zip(calls, calls[1:])]
    assert 0.99 * 60.0 / 0.05 <= len(calls) <= 60.0 / 0.05 + 1
    # on the schedule start + k * period, each call at most a tenth of a period and one
    # clock step late
    late = 0.1 * 0.05 + 0.01 + 1e-9
    assert all(0.05 - late <= g <= 0.05 + late for g in gaps), (min(gaps), max(gaps))
    # a rospy.Timer would wake on every 10 ms step: 5 times per call
    assert timer.wakes / len(calls) < 1.6, timer.wakes / len(calls)


def test_wall_clock_without_steps_sleeps_once_per_period():
    clock = FakeClock(rate=1.0, step=0.0, start=100.0)
    timer, calls = _run(clock, 0.1, until_wall=30.0)
    assert len(calls) == pytest.approx(300, abs=2)
    assert timer.wakes / len(calls) < 1.1
    assert max(b - a for a, b in zip(calls, calls[1:])) < 0.1 + 0.1 * 0.1 + 1e-6


def test_nothing_before_the_clock_starts_and_a_restart_after_time_goes_back():
    clock = FakeClock(rate=1.0, step=0.01, start=-5.0)   # clock reads 0 (not started) ...
    clock.offset = 0.0
    clock.rate = 0.0
    timer, calls = _run(clock, 0.1, until_wall=2.0)
    assert calls == []
    clock = FakeClock(rate=1.0, step=0.01, start=50.0)
    clock.jump_at = (10.0, 3.0)                          # simulator restarted at 3 s
    timer, calls = _run(clock, 0.1, until_wall=20.0)
    before = [c for c in calls if c >= 50.0]
    after = [c for c in calls if c < 50.0]
    assert len(before) == pytest.approx(100, abs=2) and len(after) == pytest.approx(100, abs=2)
    assert min(after) <= 3.0 + 0.1 + 0.01 + 1e-9         # the schedule restarted at once


def test_a_slow_callback_is_not_repeated_to_catch_up():
    clock = FakeClock(rate=1.0, step=0.01, start=1.0)
    slow = {"n": 0}

    def cb():
        slow["n"] += 1
        if slow["n"] == 5:
            clock.wall += 1.0            # one call takes 10 periods

    timer, calls = _run(clock, 0.1, until_wall=5.0, callback=cb)
    gaps = [b - a for a, b in zip(calls, calls[1:])]
    assert min(gaps) >= 0.1 - 0.02 - 1e-9  # no burst of the missed calls
    assert len(calls) == pytest.approx(40, abs=2)


def test_bad_arguments():
    with pytest.raises(ValueError):
        PacedTimer(0.0, lambda: None, lambda: 1.0, lambda: True, start=False)
    with pytest.raises(ValueError):
        PacedTimer(0.1, lambda: None, lambda: 1.0, lambda: True, min_sleep_s=0.5,
                   max_sleep_s=0.1, start=False)


def test_a_callback_failing_at_shutdown_ends_the_timer_quietly():
    # rospy's waits raise ROSInterruptException once the node shuts down: that is an end,
    # not an error (it printed a traceback at every rostest's shutdown before)
    clock = FakeClock(rate=1.0, step=0.01, start=1.0)
    state = {"down": False, "calls": 0}

    def cb():
        state["calls"] += 1
        if state["calls"] == 3:
            state["down"] = True
            raise RuntimeError("shutting down")

    timer = PacedTimer(0.1, cb, clock.now, lambda: state["down"], sleep=clock.sleep,
                       wall=lambda: clock.wall, start=False)
    timer.run()                                   # returns, does not raise
    assert state["calls"] == 3


def test_a_callback_failing_while_running_is_not_hidden():
    clock = FakeClock(rate=1.0, step=0.01, start=1.0)

    def cb():
        raise RuntimeError("a bug")

    timer = PacedTimer(0.1, cb, clock.now, lambda: clock.wall >= 5.0, sleep=clock.sleep,
                       wall=lambda: clock.wall, start=False)
    with pytest.raises(RuntimeError, match="a bug"):
        timer.run()
