"""The target_follower node's pure parts (no rospy): its parameters, the odometry history
that places each camera frame at the robot's pose when it was taken, and the check of one
target_follower/Detection before it becomes a tracker ``Observation``."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from ascc_common.params import nested, param
from ascc_common.pose2d import wrap_angle

from .follower import FollowerParams
from .latency import LatencyParams
from .tracker import KINDS, Observation, TrackerParams
from .trail import TrailParams

RANGE_NONE = 0  # target_follower/Detection's range_source values
RANGE_LASER = 1
RANGE_SIZE = 2


@dataclass
class TargetFollowerParams:
    """Every ``~`` parameter of the target_follower node."""

    rate_hz: float = param(10.0, "[Hz] control rate (a timer; callbacks only store)", gt=0.0)
    start_enabled: bool = param(True, "follow from the start (else wait for ~enable)")
    base_frame: str = param("base_link", "the robot's frame (Target messages' frame_id)")
    odom_history_s: float = param(2.0, "[s] odometry kept to look up the robot's pose at "
                                       "a camera frame's stamp", gt=0.0)
    follower: FollowerParams = nested(FollowerParams)
    tracker: TrackerParams = nested(TrackerParams)
    trail: TrailParams = nested(TrailParams)
    latency: LatencyParams = nested(LatencyParams)

    def odom_keep_s(self) -> float:
        """[s] odometry to keep: ``odom_history_s``, or more when the latency estimate
        needs it (its window and largest latency)."""
        lat = self.latency
        need = lat.latency_window_s + lat.max_latency_s + 1.0 if lat.estimate_latency \
            else lat.latency_s + 1.0
        return max(self.odom_history_s, need)


class OdomHistory:
    """Recent odometry poses (x, y, yaw) by stamp [s] in numpy arrays (a buffer that drops
    what is older than ``keep_s`` in place); ``pose_at`` interpolates, ``stamps`` and
    ``poses`` are views (no copy per frame: the latency estimate reads them on each)."""

    def __init__(self, keep_s: float, capacity: int = 256):
        self.keep_s = keep_s
        self._t = np.empty(capacity)
        self._p = np.empty((capacity, 3))
        self._i0 = self._n = 0  # the history is [_i0, _n)

    @property
    def stamps(self) -> np.ndarray:
        return self._t[self._i0:self._n]

    @property
    def poses(self) -> np.ndarray:
        return self._p[self._i0:self._n]

    def __len__(self) -> int:
        return self._n - self._i0

    def clear(self) -> None:
        self._i0 = self._n = 0

    def add(self, stamp_s: float, pose: Tuple[float, float, float]) -> None:
        """Append a pose; one older than the newest is dropped (out of order)."""
        if self._n > self._i0 and stamp_s < self._t[self._n - 1]:
            return
        if self._n == len(self._t):  # full: move the kept part to the front, or grow
            k = self._n - self._i0
            if k > len(self._t) // 2:
                self._t = np.concatenate([self._t, np.empty(len(self._t))])
                self._p = np.concatenate([self._p, np.empty((len(self._p), 3))])
            self._t[:k] = self._t[self._i0:self._n]
            self._p[:k] = self._p[self._i0:self._n]
            self._i0, self._n = 0, k
        self._t[self._n] = stamp_s
        self._p[self._n] = pose
        self._n += 1
        self._i0 += int(np.searchsorted(self.stamps, stamp_s - self.keep_s))

    def newest(self) -> Optional[Tuple[float, float, float]]:
        return tuple(float(v) for v in self._p[self._n - 1]) if len(self) else None

    def pose_at(self, stamp_s: float) -> Optional[Tuple[float, float, float]]:
        """The pose at ``stamp_s``, interpolated; the oldest/newest outside the history."""
        if not len(self):
            return None
        stamps, poses = self.stamps, self.poses
        i = int(np.searchsorted(stamps, stamp_s))
        if i == 0:
            return tuple(float(v) for v in poses[0])
        if i == len(stamps):
            return tuple(float(v) for v in poses[-1])
        t0, t1 = stamps[i - 1], stamps[i]
        a, b = poses[i - 1], poses[i]
        f = (stamp_s - t0) / (t1 - t0) if t1 > t0 else 1.0
        return (float(a[0] + f * (b[0] - a[0])), float(a[1] + f * (b[1] - a[1])),
                wrap_angle(float(a[2] + f * wrap_angle(float(b[2] - a[2])))))


def observation_from_detection(d) -> Tuple[Optional[Observation], str]:
    """A target_follower/Detection (any object with its fields) as an ``Observation``, or
    (None, what is wrong with it). The position is the message's, else it is made from
    the range and bearing; neither: bearing only."""
    if d.kind not in KINDS:
        return None, "unknown kind %r" % d.kind
    if not math.isfinite(d.bearing_rad):
        return None, "%s detection with a non-finite bearing (%r)" % (d.kind, d.bearing_rad)
    x, y = d.position.x, d.position.y
    if d.range_source != RANGE_NONE and not (math.isfinite(d.range_m) and d.range_m > 0.0):
        return None, "%s detection with range_source %d but range_m %r" % (
            d.kind, d.range_source, d.range_m)
    if not (math.isfinite(x) and math.isfinite(y)):
        if d.range_source == RANGE_NONE:
            x = y = math.nan
        else:
            x, y = d.range_m * math.cos(d.bearing_rad), d.range_m * math.sin(d.bearing_rad)
    elif d.range_source == RANGE_NONE:
        x = y = math.nan  # no range: a position would be a guess
    area = d.area_px if math.isfinite(d.area_px) and d.area_px > 0.0 else math.nan
    confidence = d.confidence if math.isfinite(d.confidence) else 0.0
    return Observation(d.kind, float(d.bearing_rad), float(x), float(y), float(area),
                       float(confidence)), ""
