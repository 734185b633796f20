"""Gesture motion control (thesis 4.3-4.4), without ROS: what the robot does on a
recognized "come close" or "go away".

* ``come_close``: drive straight ahead toward the person until the laser measures
  ``stop_distance_m`` ahead (the nearest laser point in the robot's path, a corridor of
  ``path_half_width_m`` either side of base_link's x axis, from base_link's origin); speed
  ``approach_speed_mps``, slowing with ``approach_gain_per_s`` near the stop. It ends at
  the stop distance, after ``approach_timeout_s``, or at once when no fresh scan is there
  to measure with (the robot must not drive blind).
* ``go_away``: back straight off by ``backoff_distance_m`` measured by odometry, at
  ``backoff_speed_mps``: slowly and briefly, since no sensor sees behind the robot; ends
  there, after ``backoff_timeout_s``, or at once without odometry.

A new command replaces the running one. ``GestureController.step`` gives the velocity of
each control period; when a motion ends it gives one zero and the reason, then the
controller is idle and the node publishes nothing (the velocity mux hands the base back
to the operator).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param

IDLE, COMING, BACKING = "idle", "coming", "backing"


@dataclass
class GestureControlParams:
    rate_hz: float = param(10.0, "control rate while a motion runs [Hz]", gt=0.0, le=100.0)
    stop_distance_m: float = param(0.8, "come_close stops when the laser measures this "
                                   "little ahead of base_link [m]", gt=0.2)
    path_half_width_m: float = param(0.2, "half width of the robot's path in which the "
                                     "laser looks ahead [m]", gt=0.0)
    approach_speed_mps: float = param(0.2, "come_close's top speed [m/s]", gt=0.0, le=0.5)
    approach_gain_per_s: float = param(0.8, "come_close slows to gain x (distance - stop) "
                                       "[1/s]", gt=0.0)
    approach_min_speed_mps: float = param(0.05, "come_close's slowest speed before the stop "
                                          "[m/s]", gt=0.0)
    approach_timeout_s: float = param(15.0, "come_close ends after this long [s]", gt=0.0)
    backoff_distance_m: float = param(0.5, "go_away backs off this far (odometry) [m]",
                                      gt=0.0, le=2.0)
    backoff_speed_mps: float = param(0.1, "go_away's speed backwards [m/s]", gt=0.0,
                                     le=0.3)
    backoff_timeout_s: float = param(8.0, "go_away ends after this long [s]", gt=0.0)
    scan_timeout_s: float = param(0.5, "a scan older than this does not count [s]", gt=0.0)
    odom_timeout_s: float = param(0.5, "odometry older than this does not count [s]", gt=0.0)

    def validate(self) -> None:
        if self.backoff_timeout_s < self.backoff_distance_m / self.backoff_speed_mps:
            raise ValueError("backoff_timeout_s %.2f s is shorter than backoff_distance_m / "
                             "backoff_speed_mps = %.2f s" % (self.backoff_timeout_s,
                                                             self.backoff_distance_m
                                                             / self.backoff_speed_mps))
        if self.approach_min_speed_mps > self.approach_speed_mps:
            raise ValueError("approach_min_speed_mps is above approach_speed_mps")


def distance_ahead(ranges: Sequence[float], angles: np.ndarray, mount_xy: Tuple[float, float],
                   range_min: float, range_max: float, half_width_m: float) -> float:
    """The nearest laser point in the robot's path: min x [m] (base_link) of the beam end
    points ahead (x > 0) within ``half_width_m`` of the x axis; ``range_max`` (from the
    mount) when no beam hits there. ``angles``: the beams' directions in base_link;
    readings outside [range_min, range_max] or not finite are no hits."""
    r = np.asarray(ranges, dtype=float)
    finite = np.isfinite(r)
    r = np.where(finite, r, -1.0)  # no comparison with NaN (numpy 1.17 warns on each)
    ok = finite & (r >= range_min) & (r <= range_max)
    x = mount_xy[0] + r * np.cos(angles)
    y = mount_xy[1] + r * np.sin(angles)
    hit = ok & (x > 0.0) & (np.abs(y) <= half_width_m)
    if not np.any(hit):
        return float(mount_xy[0] + range_max)
    return float(np.min(x[hit]))


class Command(NamedTuple):
    v: float  # [m/s], + forward
    state: str  # IDLE, COMING or BACKING after this step
    ended: Optional[str]  # why the motion ended in this step (send one zero), else None


class GestureController:
    def __init__(self, p: GestureControlParams):
        self.p = p
        self.state = IDLE
        self.t0 = 0.0
        self.start_xy: Optional[Tuple[float, float]] = None

    def on_gesture(self, command: str, t: float) -> None:
        """Start (or restart) the motion of ``command`` at ``t`` [s]."""
        if command not in ("come_close", "go_away"):
            raise ValueError("unknown gesture command %r" % command)
        self.state = COMING if command == "come_close" else BACKING
        self.t0, self.start_xy = t, None

    def cancel(self) -> None:
        self.state = IDLE

    def step(self, t: float, ahead_m: Optional[float], scan_t: Optional[float],
             odom_xy: Optional[Tuple[float, float]], odom_t: Optional[float]) -> Command:
        """The velocity at ``t`` [s] from the distance ahead (``ahead_m`` measured at
        ``scan_t``) and the odometry position (``odom_xy`` at ``odom_t``)."""
        p = self.p
        if self.state == COMING:
            if scan_t is None or ahead_m is None or t - scan_t > p.scan_timeout_s:
                return self._end("no fresh scan to measure the distance with")
            if ahead_m <= p.stop_distance_m:
                return self._end("at %.2f m from the person (laser)" % ahead_m)
            if t - self.t0 > p.approach_timeout_s:
                return self._end("approach timed out after %.1f s" % p.approach_timeout_s)
            v = min(p.approach_speed_mps, p.approach_gain_per_s * (ahead_m - p.stop_distance_m))
            return Command(max(v, p.approach_min_speed_mps), COMING, None)
        if self.state == BACKING:
            if odom_t is None or odom_xy is None or t - odom_t > p.odom_timeout_s:
                return self._end("no fresh odometry to measure the distance with")
            if self.start_xy is None:
                self.start_xy = odom_xy
            backed = math.hypot(odom_xy[0] - self.start_xy[0], odom_xy[1] - self.start_xy[1])
            if backed >= p.backoff_distance_m:
                return self._end("backed off %.2f m" % backed)
            if t - self.t0 > p.backoff_timeout_s:
                return self._end("backing off timed out after %.1f s (%.2f m)"
                                 % (p.backoff_timeout_s, backed))
            return Command(-p.backoff_speed_mps, BACKING, None)
        return Command(0.0, IDLE, None)

    def _end(self, why: str) -> Command:
        self.state = IDLE
        return Command(0.0, IDLE, why)
