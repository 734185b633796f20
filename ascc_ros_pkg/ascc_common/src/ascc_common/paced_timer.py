"""A periodic callback on ROS time that does not wake on every /clock message (no rospy).

Under simulated time, ``rospy.Timer``, ``rospy.Rate`` and ``rospy.sleep`` wait on rospy's
clock condition, which every /clock message notifies: each such timer wakes 100 times per
simulated second with ascc_sim (its physics step), whatever its own period. Measured on the
2-core VM: a node with one 20 Hz rospy.Timer uses ~0.5 % of a core more than the same node
without it, three such timers ~1 % more (a 100 Hz /clock, nothing else running in them).

``PacedTimer`` sleeps in wall time instead: the ROS time still to wait divided by the
clock's observed rate (simulated seconds per wall second; 1 on a robot), so it wakes about
about once per period: it aims a tenth of a period past the due time, so that a clock
moving in steps (10 ms with ascc_sim) or at a jittery rate has usually reached it (woken
early, it sleeps that tenth again, not a spin). A call is thus about a tenth of a period
late (a rospy.Timer: up to one /clock step). The caller passes the clock and the shutdown
test (``rospy.get_time``, ``rospy.core.is_shutdown_requested``: true from the start of
rospy's shutdown, whose pre-shutdown hooks close the node's publishers while
``rospy.is_shutdown()`` is still false).

Schedule, as ``rospy.Timer(..., reset=True)``: due times ``start + k * period``; a call
late by more than a period (a starved process) is not repeated: the schedule restarts
from now. Time going back (a restarted simulator, a bag loop) restarts it too. Before the
clock has started (0 under simulated time) nothing is called. A callback that raises while
the node shuts down (rospy's ``ROSInterruptException`` from a wait) ends the timer quietly;
at any other time its exception ends the thread with a traceback, as a ``rospy.Timer``'s.
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Optional


class PacedTimer:
    """Calls ``callback()`` every ``period_s`` seconds of the clock ``now()``, from one
    daemon thread (``start=False``: call ``run()`` yourself, as the tests do)."""

    RATE_WINDOW_S = 0.2   # [s wall] the clock's rate is measured over at least this long
    RECHECK_SHARE = 0.1   # [periods] shortest wait of clock time before looking again

    def __init__(self, period_s: float, callback: Callable[[], None],
                 now: Callable[[], float], is_shutdown: Callable[[], bool],
                 name: str = "paced_timer", max_sleep_s: float = 0.1,
                 min_sleep_s: float = 0.001, sleep: Callable[[float], None] = time.sleep,
                 wall: Callable[[], float] = time.monotonic, start: bool = True):
        if not period_s > 0.0:
            raise ValueError("PacedTimer period_s must be > 0, got %r" % (period_s,))
        if not 0.0 < min_sleep_s <= max_sleep_s:
            raise ValueError("PacedTimer needs 0 < min_sleep_s <= max_sleep_s")
        self.period_s = float(period_s)
        self.callback = callback
        self._now = now
        self._is_shutdown = is_shutdown
        self._sleep = sleep
        self._wall = wall
        self.max_sleep_s = max_sleep_s
        self.min_sleep_s = min_sleep_s
        self.calls = 0
        self.wakes = 0
        self._stopped = False
        self._rate = 1.0                 # clock seconds per wall second (last measured)
        self._measured = False
        self._anchor = None              # (clock, wall) where the rate window started
        self.thread: Optional[threading.Thread] = None
        if start:
            self.thread = threading.Thread(target=self.run, name=name, daemon=True)
            self.thread.start()

    def shutdown(self) -> None:
        self._stopped = True

    def _observe(self, clock: float, wall: float) -> None:
        """Learn the clock's rate from one more reading."""
        if self._anchor is None or clock < self._anchor[0]:
            self._anchor = (clock, wall)
            return
        d_clock, d_wall = clock - self._anchor[0], wall - self._anchor[1]
        # the first measurement over a short window (the rate is unknown until then)
        if d_wall >= (self.RATE_WINDOW_S if self._measured else 0.1 * self.RATE_WINDOW_S):
            if d_clock > 0.0:
                self._rate = d_clock / d_wall
                self._measured = True
            self._anchor = (clock, wall)

    def sleep_for(self, remaining: float) -> float:
        """Wall time to sleep while ``remaining`` [s of clock] are left before the due time."""
        # aim a little past the due time: woken before it (the clock's step, the rate's
        # jitter), the timer would sleep again, and each wake-up costs as much as a call
        wait = max(remaining, 0.0) + self.RECHECK_SHARE * self.period_s
        return min(self.max_sleep_s, max(self.min_sleep_s, wait / max(self._rate, 1e-3)))

    def _read_clock(self) -> Optional[float]:
        """The clock, or None when it fails (rospy's at shutdown): the timer then ends."""
        try:
            return self._now()
        except Exception:  # noqa: BLE001
            return None

    def run(self) -> None:
        due = None
        last_clock = None
        while not self._stopped and not self._is_shutdown():
            clock = self._read_clock()
            if clock is None:
                return
            self._observe(clock, self._wall())
            if last_clock is not None and clock < last_clock:
                due = None                       # time went back: restart the schedule
            last_clock = clock
            if clock <= 0.0:                     # simulated time not started yet
                self._sleep(self.max_sleep_s)
                continue
            if due is None:
                due = clock + self.period_s
            elif clock >= due:
                due = due + self.period_s if clock < due + self.period_s else clock + self.period_s
                self.calls += 1
                try:
                    self.callback()
                except Exception:
                    # rospy's waits (a TF lookup with a timeout) raise when the node shuts
                    # down: the timer ends quietly then; any other failure is the caller's
                    if self._stopped or self._is_shutdown():
                        return
                    raise
                if self._stopped or self._is_shutdown():
                    return
                clock = self._read_clock()
                if clock is None:
                    return
                if clock < last_clock:           # went back during the call
                    continue
            self.wakes += 1
            self._sleep(self.sleep_for(due - clock))
