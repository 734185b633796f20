"""Target identity: which of a frame's detections is the target being followed (no rospy).

With several plausible blobs in view (two cones, a cone and a shirt) the follower must
keep following the one it was following, not whichever is largest (issue 21). One track,
kept in the odom frame so that the robot's own motion does not move it:

* predict: constant velocity, p^ = p + v * (t - t_k), from the last update t_k;
* gate: a detection of the track's kind is a candidate when its position (base_link ->
  odom through the robot's odometry pose at the frame's stamp) lies within
  g = ``gate_m`` + ``gate_growth_mps`` * (t - t_k) of p^; a detection without a range
  (bearing only) when its direction is within ``gate_bearing_rad`` of p^'s direction;
* associate: the nearest candidate wins (positions before bearings);
* update (alpha-beta filter): r = z - p^, p = p^ + alpha r, v = v + (beta / dt) r, |v|
  clipped to ``max_target_speed_mps``; a bearing-only detection is placed at p^'s range;
* lose the track when no detection was associated for ``track_timeout_s``;
* acquire, when there is no track: the best detection (highest confidence, then largest
  area) of a configured kind (``kinds``) with at least ``min_confidence``.

Poses are (x, y, yaw) of base_link in odom (ascc_common.pose2d); times in seconds, passed
in (no clock inside).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param
from ascc_common.pose2d import transform_points, wrap_angle

from .follower import Aim

KINDS = ("cone", "shirt", "logo")


@dataclass
class TrackerParams:
    """Which targets to follow and how one is told from another (module doc)."""

    kinds: str = param("shirt", "comma-separated kinds to acquire: cone, shirt, logo")
    min_confidence: float = param(0.05, "a detection's confidence needed to acquire it "
                                        "(the colour detector's score grows with the "
                                        "blob's area: 0.05 is a shirt at ~5 m, 0.3 at ~2 m)",
                                  ge=0.0, le=1.0)
    gate_m: float = param(0.5, "[m] association gate around the predicted position",
                          gt=0.0)
    gate_growth_mps: float = param(0.5, "[m/s] the gate grows this much per second "
                                        "without an associated detection", ge=0.0)
    gate_bearing_rad: float = param(0.2, "[rad] gate for detections without a range",
                                    gt=0.0)
    track_timeout_s: float = param(1.5, "[s] lose the track after this long without an "
                                        "associated detection", gt=0.0)
    position_gain: float = param(0.7, "alpha of the alpha-beta filter", gt=0.0, le=1.0)
    velocity_gain: float = param(0.3, "beta of the alpha-beta filter", ge=0.0, le=1.0)
    max_target_speed_mps: float = param(1.5, "[m/s] limit of the estimated target speed",
                                        gt=0.0)

    def kind_set(self) -> Tuple[str, ...]:
        return tuple(k.strip() for k in self.kinds.split(",") if k.strip())

    def validate(self) -> None:
        kinds = self.kind_set()
        unknown = [k for k in kinds if k not in KINDS]
        if not kinds or unknown:
            raise ValueError("kinds must list some of %s, got %r" % (", ".join(KINDS),
                                                                    self.kinds))


@dataclass
class Observation:
    """One detection in base_link: bearing [rad], position [m] (NaN: bearing only)."""

    kind: str
    bearing_rad: float
    x_m: float = math.nan
    y_m: float = math.nan
    area_px: float = math.nan
    confidence: float = 1.0

    @property
    def has_position(self) -> bool:
        return math.isfinite(self.x_m) and math.isfinite(self.y_m)

    @classmethod
    def at(cls, kind: str, bearing_rad: float, range_m: float = math.nan,
           area_px: float = math.nan, confidence: float = 1.0) -> Observation:
        """From a bearing and a range (NaN: none)."""
        return cls(kind, bearing_rad, range_m * math.cos(bearing_rad),
                   range_m * math.sin(bearing_rad), area_px, confidence)


@dataclass
class Track:
    """The followed target in odom: position (NaN while bearing only) and velocity."""

    id: int
    kind: str
    t_s: float  # last update
    pos: np.ndarray  # (2,) [m]
    direction_rad: float  # odom direction from the robot at the last update
    area_px: float
    vel: np.ndarray = field(default_factory=lambda: np.zeros(2))  # [m/s]
    seen: np.ndarray = field(default_factory=lambda: np.full(2, np.nan))  # last measured
    # position [m, odom] (unfiltered: what the trail records)
    seen_base: Tuple[float, float] = (math.nan, math.nan)  # the same in base_link [m]
    innovation_m: float = math.nan  # |seen - predicted| at the last update [m] (NaN: none)
    updates: int = 1

    @property
    def has_position(self) -> bool:
        return bool(np.all(np.isfinite(self.pos)))

    def predicted(self, t_s: float) -> np.ndarray:
        return self.pos + self.vel * max(t_s - self.t_s, 0.0)


class Tracker:
    """One followed target (module doc). Not thread-safe: call from one thread."""

    def __init__(self, p: TrackerParams):
        self.p = p
        self.kinds = p.kind_set()
        self.track: Optional[Track] = None
        self.next_id = 1

    def reset(self) -> None:
        self.track = None

    def update(self, stamp_s: float, pose, observations: Sequence[Observation]) \
            -> Optional[Track]:
        """One frame's detections, stamped ``stamp_s``, seen from odometry ``pose``; the
        track after it (None: none). A frame older than the track's last update is
        ignored."""
        t = self.track
        if t is not None and stamp_s < t.t_s:
            return t
        if t is not None and stamp_s - t.t_s > self.p.track_timeout_s:
            self.track = t = None
        obs = [o for o in observations if math.isfinite(o.bearing_rad)]
        if t is None:
            self._acquire(stamp_s, pose, obs)
        else:
            best = self._associate(t, stamp_s, pose, obs)
            if best is not None:
                self._correct(t, stamp_s, pose, best)
        return self.track

    def aim(self, now_s: float, pose) -> Optional[Aim]:
        """The track predicted to ``now_s`` and seen from ``pose`` (None: no track, or it
        timed out)."""
        t = self.track
        if t is None:
            return None
        if now_s - t.t_s > self.p.track_timeout_s:
            self.track = None
            return None
        if not t.has_position:
            return Aim(wrap_angle(t.direction_rad - pose[2]), math.nan, t.area_px)
        x, y = self.in_base(pose, t.predicted(now_s))
        r = math.hypot(x, y)
        rate = 0.0  # the target's velocity along the line of sight (positive: away)
        if r > 1e-6:
            vx, vy = self.in_base((0.0, 0.0, pose[2]), t.vel)
            rate = (vx * x + vy * y) / r
        return Aim(math.atan2(y, x), r, t.area_px, rate)

    # -- internals -----------------------------------------------------------------------
    @staticmethod
    def in_base(pose, point) -> Tuple[float, float]:
        """An odom point seen from base_link at ``pose``."""
        dx, dy = point[0] - pose[0], point[1] - pose[1]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        return c * dx + s * dy, -s * dx + c * dy

    @staticmethod
    def _in_odom(pose, o: Observation) -> np.ndarray:
        if not o.has_position:
            return np.array([math.nan, math.nan])
        return transform_points(pose, [[o.x_m, o.y_m]])[0]

    def _acquire(self, stamp_s: float, pose, obs: List[Observation]) -> None:
        ok = [o for o in obs if o.kind in self.kinds and o.confidence >= self.p.min_confidence]
        if not ok:
            return
        best = max(ok, key=lambda o: (o.confidence, np.nan_to_num(o.area_px, nan=0.0)))
        pos = self._in_odom(pose, best)
        self.track = Track(self.next_id, best.kind, stamp_s, pos,
                           wrap_angle(pose[2] + best.bearing_rad), best.area_px,
                           seen=pos.copy(), seen_base=(best.x_m, best.y_m))
        self.next_id += 1

    def _associate(self, t: Track, stamp_s: float, pose,
                   obs: List[Observation]) -> Optional[Observation]:
        same = [o for o in obs if o.kind == t.kind]
        pred = t.predicted(stamp_s)
        if t.has_position:
            gate = self.p.gate_m + self.p.gate_growth_mps * (stamp_s - t.t_s)
            near = [(float(np.hypot(*(self._in_odom(pose, o) - pred))), o)
                    for o in same if o.has_position]
            near = [(d, o) for d, o in near if d <= gate]
            if near:
                return min(near, key=lambda c: c[0])[1]
            pred_dir = math.atan2(pred[1] - pose[1], pred[0] - pose[0])
        else:
            pred_dir = t.direction_rad
        turned = [(abs(wrap_angle(pose[2] + o.bearing_rad - pred_dir)), o) for o in same
                  if not (t.has_position and o.has_position)]
        turned = [(d, o) for d, o in turned if d <= self.p.gate_bearing_rad]
        return min(turned, key=lambda c: c[0])[1] if turned else None

    def _correct(self, t: Track, stamp_s: float, pose, o: Observation) -> None:
        direction = wrap_angle(pose[2] + o.bearing_rad)
        pred = t.predicted(stamp_s)
        z = self._in_odom(pose, o)
        if not o.has_position and t.has_position:  # bearing only: at the predicted range
            rng = math.hypot(pred[0] - pose[0], pred[1] - pose[1])
            z = np.array([pose[0] + rng * math.cos(direction),
                          pose[1] + rng * math.sin(direction)])
        dt = stamp_s - t.t_s
        if not t.has_position:
            t.pos, t.vel = z, np.zeros(2)
        elif np.all(np.isfinite(z)):
            r = z - pred
            t.pos = pred + self.p.position_gain * r
            if dt > 0.0:
                t.vel = t.vel + (self.p.velocity_gain / dt) * r
                speed = float(np.hypot(*t.vel))
                if speed > self.p.max_target_speed_mps:
                    t.vel = t.vel * (self.p.max_target_speed_mps / speed)
        t.innovation_m = float(np.hypot(*(z - pred))) if t.has_position and \
            np.all(np.isfinite(z)) and np.all(np.isfinite(pred)) else math.nan
        t.seen = np.array(z, dtype=float)
        t.seen_base = (o.x_m, o.y_m)
        t.t_s = stamp_s
        t.direction_rad = direction
        t.area_px = o.area_px
        t.updates += 1
