"""The sensors' samples as the recognizer needs them: one row (one sample of each sensor)
per sample period, every sample used once and in order, whatever the delivery did. Pure
Python; the node (`ros/activity_recognizer_node.py`) adds each received sample and takes
the rows on its timer.

Why not the newest sample of each sensor at each timer tick: the features include the
variance of sample-to-sample differences, and a tick 10-20 ms late (a busy PC, a burst from
the serial port) repeats one sample and skips another. `scripts/bench_delivery_jitter.py`
(activity.test's script, held-out persons, ticks late by 20 ms on average): carrying
reported unknown in 77 % of its windows instead of 100 %, walking recognized in 90 %.
Here a sample waits in its sensor's queue until the other sensor's
sample of the same period is there; a sensor silent for ``silent_after_s`` (asleep under
the power scheme, 5.4.1: it sends nothing) has its last sample held, as in training; with
every sensor silent the rows go on at the sample rate from the last one.
"""

from __future__ import annotations

from collections import deque
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np


class SampleAligner:
    """Rows of one sample per sensor (in ``names``' order) from streams that arrive late,
    in bursts, or (asleep) not at all."""

    def __init__(self, names: Sequence[str], rate_hz: float, silent_after_s: float,
                 max_backlog_s: float):
        if rate_hz <= 0.0 or silent_after_s <= 0.0 or max_backlog_s <= 0.0:
            raise ValueError("rate_hz, silent_after_s and max_backlog_s must be > 0 "
                             "(got %g, %g, %g)" % (rate_hz, silent_after_s, max_backlog_s))
        self.names = tuple(names)
        self.period_s = 1.0 / rate_hz
        self.silent_after_s = silent_after_s
        self.max_queue = max(1, int(round(max_backlog_s * rate_hz)))
        self.queues: Dict[str, deque] = {n: deque() for n in self.names}
        self.held: Dict[str, Optional[np.ndarray]] = {n: None for n in self.names}
        self.last_rx: Dict[str, Optional[float]] = {n: None for n in self.names}
        self.t_row: Optional[float] = None  # [s] time of the last row
        self.dropped = 0  # samples dropped, oldest first, from a queue over max_backlog_s

    def add(self, name: str, value, now_s: float) -> bool:
        """Queue a sample of sensor ``name`` received at ``now_s`` [s]; False if the queue
        was full and its oldest sample was dropped."""
        q = self.queues[name]
        full = len(q) >= self.max_queue
        if full:
            q.popleft()
            self.dropped += 1
        q.append(np.asarray(value, dtype=float))
        self.last_rx[name] = now_s
        return not full

    def missing(self) -> List[str]:
        """The sensors never heard from (no row is made before each has sent once)."""
        return [n for n in self.names if self.held[n] is None and not self.queues[n]]

    def rows(self, now_s: float) -> List[Tuple[np.ndarray, ...]]:
        """The rows complete at ``now_s`` [s], oldest first."""
        out: List[Tuple[np.ndarray, ...]] = []
        if self.missing():
            return out
        if self.t_row is not None and now_s < self.t_row:
            self.t_row = now_s  # the clock went back (a simulator restart)
        while True:
            queued = [bool(self.queues[n]) for n in self.names]
            silent = [not q and now_s - self.last_rx[n] >= self.silent_after_s
                      for n, q in zip(self.names, queued)]
            if not all(q or s for q, s in zip(queued, silent)):
                break  # a sensor's sample of this period is still on its way
            if any(queued):
                for n, q in zip(self.names, queued):
                    if q:
                        self.held[n] = self.queues[n].popleft()
                out.append(tuple(self.held[n] for n in self.names))
                self.t_row = max(self.last_rx[n] for n in self.names)
                continue
            # every sensor asleep: held rows at the sample rate since the last row
            start = self.t_row if self.t_row is not None else now_s
            n_rows = int((now_s - start) / self.period_s + 1e-9)
            out.extend(tuple(self.held[n] for n in self.names) for _ in range(n_rows))
            self.t_row = start + n_rows * self.period_s
            break
        return out
