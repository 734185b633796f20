"""The power-aware sleep/wake scheme of the wearable sensor node (thesis 5.4.1, fig. 5.12)
and its duty cycle. Pure numpy.

The node's tiny low-power accelerometer runs all the time; the VN-100 and the XBee are on
only while the node is active. A sample shows "significant motion" when the acceleration
departs from its mean over the last ``window_s`` by more than ``motion_threshold_mps2``
(the norm of the difference: a posture change, a step, a fidget; sensor noise stays far
below it). The node wakes at the first such sample and goes to sleep after
``sleep_after_s`` without one. The thesis gives the flowchart's idea, not its numbers: the
three parameters are ours (`PowerParams`).

`awake_mask` applies the rule to a whole recording at once (cumulative sums); `PowerManager`
applies the same rule sample by sample (the emulator node); tests check they agree. The
duty cycle is the fraction of samples awake.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ascc_common.params import param


@dataclass
class PowerParams:
    window_s: float = param(1.0, "[s] the reference acceleration is the mean over this",
                            gt=0.0)
    motion_threshold_mps2: float = param(0.5, "[m/s^2] departure from the reference that "
                                         "counts as significant motion", gt=0.0)
    sleep_after_s: float = param(10.0, "[s] asleep after this long without motion", gt=0.0)


def _samples(seconds: float, rate_hz: float) -> int:
    return max(1, int(round(seconds * rate_hz)))


def motion(accel: np.ndarray, rate_hz: float, params: PowerParams) -> np.ndarray:
    """(n,) bool: significant motion at each sample of ``accel`` (n, 3) [m/s^2]. The
    reference at sample i is the mean of the (up to) ``window_s`` samples before it; the
    first sample has none and shows no motion."""
    a = np.asarray(accel, dtype=float)
    n = a.shape[0]
    w = _samples(params.window_s, rate_hz)
    c = np.vstack([np.zeros((1, 3)), np.cumsum(a, axis=0)])
    i = np.arange(n)
    lo = np.maximum(i - w, 0)
    count = (i - lo).astype(float)
    ref = (c[i] - c[lo]) / np.maximum(count, 1.0)[:, None]
    dev = np.linalg.norm(a - ref, axis=1)
    return (dev > params.motion_threshold_mps2) & (count > 0)


def awake_mask(accel: np.ndarray, rate_hz: float, params: PowerParams) -> np.ndarray:
    """(n,) bool: the node is active at each sample. It starts active (switched on) and
    stays active ``sleep_after_s`` after switching on or after the last motion."""
    m = motion(accel, rate_hz, params)
    m[0] = True  # switching on counts as motion: the node starts awake
    hold = _samples(params.sleep_after_s, rate_hz)
    c = np.concatenate([[0], np.cumsum(m)])
    i = np.arange(m.size)
    return (c[i + 1] - c[np.maximum(i + 1 - hold, 0)]) > 0


def hold_asleep(accel: np.ndarray, rate_hz: float, params: PowerParams) -> np.ndarray:
    """What a receiver that holds each sensor's last sample sees: ``accel`` (n, 3) with
    every sample of a sleeping node replaced by the last one it sent."""
    a = np.asarray(accel, dtype=float)
    awake = awake_mask(a, rate_hz, params)
    last = np.maximum.accumulate(np.where(awake, np.arange(a.shape[0]), 0))
    return a[last]


def duty_cycle(awake: np.ndarray) -> float:
    return float(np.mean(awake)) if len(awake) else 0.0


def wake_ups(awake: np.ndarray) -> int:
    """Sleep -> active switches."""
    a = np.asarray(awake, dtype=bool)
    return int(np.sum(a[1:] & ~a[:-1]))


class PowerManager:
    """The same rule sample by sample: ``step(accel)`` -> (awake, event) with event
    "wake", "sleep" or ""."""

    def __init__(self, rate_hz: float, params: PowerParams):
        self.params = params
        self._window = deque(maxlen=_samples(params.window_s, rate_hz))
        self._hold = _samples(params.sleep_after_s, rate_hz)
        self._since_motion = 0  # samples since the last motion (0: this one)
        self.awake = True
        self._first = True

    def step(self, accel) -> tuple:
        a = np.asarray(accel, dtype=float)
        moved = self._first
        if self._window:
            ref = np.mean(np.asarray(self._window), axis=0)
            moved = moved or bool(np.linalg.norm(a - ref) > self.params.motion_threshold_mps2)
        self._first = False
        self._window.append(a)
        self._since_motion = 0 if moved else self._since_motion + 1
        now_awake = self._since_motion < self._hold
        event = "" if now_awake == self.awake else ("wake" if now_awake else "sleep")
        self.awake = now_awake
        return now_awake, event
