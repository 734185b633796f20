"""The target follower's control law, laser safety stop and search (thesis 2.4, 5.3; no rospy).

Thesis 5.3: "the target follower node is basically trying to keep the target in the middle
of the view of the robot [...] an angular rate and a linear rate [...] computed based on
the size and the centroid position of the orange region", and it stops "when it is close
enough"; 2.4 adds the range from the laser beam at the target's bearing. With the target
at bearing b [rad] and range r [m] in base_link (``Aim``), set point d = ``distance_m``,
band e0 = ``distance_tolerance_m``:

    w = clip(k_w * b, +-w_max)
    e = r - d;  v = v_ff + (0 if |e| <= e0 else k_v * e)
    v = clip(v, -v_back, v_max) * max(0, 1 - |b| / b_drive)

with the feed-forward v_ff = k_ff * r_dot when the target moves away faster than
``feedforward_min_mps`` (r_dot = ``Aim.range_rate_mps``, the rate at which the target's
own motion lengthens the range, from the tracker's velocity estimate; else v_ff = 0): a
proportional law alone follows a walking person only with a standing error of
r_dot / k_v (0.37 m at 0.3 m/s and k_v = 0.8), larger than the band; the feed-forward
matches the person's pace and leaves k_v to correct the error.

where v_back is ``max_linear_mps`` with ``allow_reverse`` and ``backoff_mps`` without (a
small back-off only: the laser does not see behind the robot), and b_drive =
``max_drive_bearing_rad`` (no forward speed when the target is that far off-centre: turn
first). Outside the band the speed is proportional to the whole error, so that the robot
stops inside the band (approaching only its edge, it would creep toward it forever); the
step of k_v * e0 at the band's edge is smoothed by the acceleration limit. Without a
range (RANGE_NONE) r is estimated from the size, r = d * sqrt(A_d / A) with A the blob's
area and A_d = ``area_at_distance_px`` (unset: turn only, v = 0). Both rates then change
by at most ``max_*_accel`` * dt per step.

``Follower.step`` is a small state machine over time passed in (no clock inside):

* ``stale``: no target message newer than ``target_timeout_s`` or no usable scan newer
  than ``scan_timeout_s``: zero, at once;
* ``following``: the tracker has the target (``Aim``): the law above;
* ``blocked``: following, but the laser safety stop (``SafetySector``) sees an obstacle in
  the path: no forward speed (at once), turning and backing off allowed;
* ``searching``: the target was lost less than ``search_timeout_s`` ago: drive along its
  trail to where it was last seen (an ``Aim`` with ``searching`` set, trail.py), then turn
  in place toward its last bearing at ``search_angular_radps``;
* ``lost``: nothing to follow (never acquired, or the search timed out): zero.
(``disabled`` is the node's: the ``~enable`` service.)

``SafetySector``: the region A the footprint (a disc of ``robot_radius_m``) sweeps when the
robot drives ``stop_distance_m`` forward, ahead of its centre (x >= 0): the rectangle
[0, s] x [-R, R] and the half disc of radius R at (s, 0). The sector is the set of beams
whose rays, from the laser's mount, pass through A outside the current footprint -- its
width follows from the footprint, the stop distance and the mount, not a fixed angle.
A robot turning through a door drives an arc, not the straight line ahead, and the wall
beside the door is in front of it all the way in: ``check`` takes the path's curvature
k = w / v [1/m] (positive: to the left) and a length, and A is then the footprint swept
along that arc (discs of radius R centred on the arc every ``ARC_STEP_M``, x >= 0). The
follower checks two arcs (``Follower.step``): the one its new command asks for, over
``stop_distance_m``, and the one the robot is on now, over the distance it needs to stop
from its present speed (one control period plus the braking distance v^2 / 2a): a command
to turn away from a wall does not release the stop while the robot still rolls toward it.
The beams of the straight sector decide blindness and -inf (below).
Ranges per REP 117: a finite return in [range_min, range_max] whose end point lies in A
blocks; -inf (an object closer than range_min) on a sector beam blocks; +inf and returns
beyond range_max are "no object"; NaN and finite values below range_min are invalid, and
a sector with fewer than ``min_valid_sector_fraction`` valid beams is blind: blocked.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Tuple, Union

import numpy as np

from ascc_common.params import param

FOLLOWING = "following"
SEARCHING = "searching"
LOST = "lost"
BLOCKED = "blocked"
STALE = "stale"
DISABLED = "disabled"
# the safety stop's verdict on the newest scan: for any path, or a function of the path's
# curvature [1/m] and length [m] returning (blocked, why) (SafetySector.check on that scan)
PathCheck = Callable[[float, float], Tuple[bool, str]]
# states in which the node sends a command every cycle (LOST and DISABLED: one zero)
ACTIVE_STATES = (FOLLOWING, SEARCHING, BLOCKED, STALE)

EPS_M = 1e-6  # [m] ray intervals shorter than this are empty
ARC_STEP_M = 0.01  # [m] spacing of the footprint discs along a curved path
MIN_CURVATURE_PER_M = 1e-3  # [1/m] flatter paths are straight (radius > 1 km)


@dataclass
class FollowerParams:
    """The control law, limits, timeouts, safety stop and search (module doc)."""

    distance_m: float = param(1.2, "[m] set point: range to keep to the target", gt=0.0)
    distance_tolerance_m: float = param(0.1, "[m] half-width of the band around "
                                             "distance_m with no linear speed", ge=0.0)
    k_linear_per_s: float = param(0.8, "[1/s] linear rate per metre of range error",
                                  ge=0.0)
    k_angular_per_s: float = param(1.5, "[1/s] angular rate per radian of bearing", ge=0.0)
    k_feedforward: float = param(1.0, "[1] share of the target's speed away from the robot "
                                      "added to the linear rate (0: none)", ge=0.0)
    feedforward_min_mps: float = param(0.05, "[m/s] target speeds away from the robot "
                                             "below this are taken as standing", ge=0.0)
    max_linear_mps: float = param(0.45, "[m/s] forward speed limit (above a walking "
                                        "person's, to close a gap; the Create: 0.5)",
                                  gt=0.0)
    max_angular_radps: float = param(0.8, "[rad/s] turn rate limit (thesis Table 2.1: "
                                          "detection degrades when turning fast)", gt=0.0)
    max_linear_accel_mps2: float = param(0.5, "[m/s^2] linear acceleration limit", gt=0.0)
    max_angular_accel_radps2: float = param(2.0, "[rad/s^2] angular acceleration limit",
                                            gt=0.0)
    allow_reverse: bool = param(False, "back away at up to max_linear_mps when the target "
                                       "is too close (the laser does not see behind)")
    backoff_mps: float = param(0.05, "[m/s] reverse speed limit without allow_reverse "
                                     "(0: never reverse)", ge=0.0)
    max_drive_bearing_rad: float = param(0.7, "[rad] no forward speed with the target "
                                              "this far off-centre (linear in between)",
                                         gt=0.0)
    area_at_distance_px: Optional[float] = param(None, "[px] the target's blob area at "
                                                       "distance_m, for detections without "
                                                       "a range (unset: turn only)")
    target_timeout_s: float = param(1.0, "[s] stop when no target message is newer",
                                    gt=0.0)
    scan_timeout_s: float = param(0.5, "[s] stop when no usable scan is newer", gt=0.0)
    robot_radius_m: float = param(0.165, "[m] footprint radius (iRobot Create)", gt=0.0)
    stop_distance_m: float = param(0.3, "[m] safety stop: obstacles in the footprint "
                                        "swept this far forward block", gt=0.0)
    min_valid_sector_fraction: float = param(0.5, "fewer valid beams in the safety sector "
                                                  "than this fraction: blind, blocked",
                                             ge=0.0, le=1.0)
    search_angular_radps: float = param(0.4, "[rad/s] turn rate while searching", gt=0.0)
    search_timeout_s: float = param(8.0, "[s] search at most this long, then stop",
                                    ge=0.0)

    def validate(self) -> None:
        braking_m = self.max_linear_mps ** 2 / (2.0 * self.max_linear_accel_mps2)
        if self.stop_distance_m < braking_m:
            raise ValueError("stop_distance_m %.3f is shorter than the braking distance at "
                             "max_linear_mps (%.3f m)" % (self.stop_distance_m, braking_m))
        if self.area_at_distance_px is not None and not self.area_at_distance_px > 0.0:
            raise ValueError("area_at_distance_px must be > 0 (got %r)"
                             % self.area_at_distance_px)


@dataclass
class Aim:
    """Where the followed target is now, seen from base_link."""

    bearing_rad: float
    range_m: float = math.nan  # NaN: unknown
    area_px: float = math.nan  # NaN: unknown
    range_rate_mps: float = 0.0  # how fast the target's own motion lengthens the range
    searching: bool = False  # not the target: where it was last seen (the trail's end)


@dataclass
class Command:
    """One step's output: rates [m/s, rad/s], the state and why."""

    v: float
    w: float
    state: str
    reason: str = ""
    blocked: bool = False  # the safety stop cut the forward speed


def clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def step_toward(current: float, desired: float, max_step: float) -> float:
    """``desired``, moved from ``current`` by at most ``max_step`` (acceleration limit)."""
    return current + clip(desired - current, -max_step, max_step)


def control_law(p: FollowerParams, aim: Aim) -> Tuple[float, float]:
    """Unlimited-in-time (v [m/s], w [rad/s]) toward ``aim`` (module doc's equations)."""
    b = aim.bearing_rad
    w = clip(p.k_angular_per_s * b, -p.max_angular_radps, p.max_angular_radps)
    r = aim.range_m
    if not math.isfinite(r) and p.area_at_distance_px is not None \
            and math.isfinite(aim.area_px) and aim.area_px > 0.0:
        r = p.distance_m * math.sqrt(p.area_at_distance_px / aim.area_px)
    if not math.isfinite(r):
        return 0.0, w
    e = r - p.distance_m
    v = 0.0
    if math.isfinite(aim.range_rate_mps) and aim.range_rate_mps > p.feedforward_min_mps:
        v = p.k_feedforward * aim.range_rate_mps
    if abs(e) > p.distance_tolerance_m:
        v += p.k_linear_per_s * e
    v_back = p.max_linear_mps if p.allow_reverse else p.backoff_mps
    v = clip(v, -v_back, p.max_linear_mps)
    return v * max(0.0, 1.0 - abs(b) / p.max_drive_bearing_rad), w


def _ray_in_disc(m, ux, uy, centre, radius):
    """(t0, t1) [m] of the rays m + t u (t >= 0) inside a disc; t0 > t1 when they miss."""
    bx, by = m[0] - centre[0], m[1] - centre[1]
    b = bx * ux + by * uy
    disc = b * b - (bx * bx + by * by - radius * radius)
    root = np.sqrt(np.maximum(disc, 0.0))
    t0, t1 = np.maximum(-b - root, 0.0), -b + root
    return np.where(disc >= 0.0, t0, np.inf), np.where(disc >= 0.0, t1, -np.inf)


def _ray_in_slab(m, u, lo, hi):
    """(t0, t1) of the rays m + t u (t >= 0, one coordinate) within [lo, hi]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (lo - m) / u, (hi - m) / u
    inside = (m >= lo) & (m <= hi)
    t0 = np.where(u == 0.0, np.where(inside, 0.0, np.inf), np.minimum(a, b))
    t1 = np.where(u == 0.0, np.where(inside, np.inf, -np.inf), np.maximum(a, b))
    return np.maximum(t0, 0.0), t1


def _ray_in_swept(m, ux, uy, radius, stop):
    """(t0, t1) of the rays from ``m`` inside the swept region A (module doc): A is convex,
    so its interval is the hull of the intervals in its convex parts (the discs at the
    start and the end, the rectangle between), cut by the half plane x >= 0."""
    parts = [_ray_in_disc(m, ux, uy, (0.0, 0.0), radius),
             _ray_in_disc(m, ux, uy, (stop, 0.0), radius)]
    rx, ry = _ray_in_slab(m[0], ux, 0.0, stop), _ray_in_slab(m[1], uy, -radius, radius)
    parts.append((np.maximum(rx[0], ry[0]), np.minimum(rx[1], ry[1])))
    t0 = np.full(ux.shape, np.inf)
    t1 = np.full(ux.shape, -np.inf)
    for a, b in parts:
        hit = b >= a
        t0 = np.where(hit, np.minimum(t0, a), t0)
        t1 = np.where(hit, np.maximum(t1, b), t1)
    hx = _ray_in_slab(m[0], ux, 0.0, np.inf)
    return np.maximum(t0, hx[0]), np.minimum(t1, hx[1])


class SafetySector:
    """The laser safety stop for one scan layout (module doc): beams' directions
    ``angles_rad`` (n,) in base_link from the laser at ``mount_xy_m``."""

    def __init__(self, p: FollowerParams, angles_rad: np.ndarray,
                 mount_xy_m: Tuple[float, float]):
        self.radius = p.robot_radius_m
        self.stop = p.stop_distance_m
        self.min_valid = p.min_valid_sector_fraction
        self.angles = np.asarray(angles_rad, dtype=float)
        self.mount = (float(mount_xy_m[0]), float(mount_xy_m[1]))
        ux, uy = np.cos(self.angles), np.sin(self.angles)
        swept = _ray_in_swept(self.mount, ux, uy, self.radius, self.stop)
        body = _ray_in_disc(self.mount, ux, uy, (0.0, 0.0), self.radius)
        # the ray passes through the swept region outside the current footprint
        nonempty = swept[1] > swept[0] + EPS_M
        covered = (body[0] <= swept[0] + EPS_M) & (body[1] >= swept[1] - EPS_M)
        self.in_sector = nonempty & ~covered

    def in_swept(self, x: np.ndarray, y: np.ndarray, curvature_per_m: float = 0.0,
                 distance_m: Optional[float] = None) -> np.ndarray:
        """Whether base_link points lie in the region the footprint sweeps (ahead of the
        centre) along the arc of ``curvature_per_m`` for ``distance_m`` (default
        ``stop_distance_m``; module doc)."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        s = self.stop if distance_m is None else max(float(distance_m), 0.0)
        k = float(curvature_per_m)
        if abs(k) < MIN_CURVATURE_PER_M:
            cx = np.clip(x, 0.0, s)
            return (x >= 0.0) & (np.hypot(x - cx, y) <= self.radius)
        arc = np.linspace(0.0, s, int(math.ceil(s / ARC_STEP_M)) + 1)
        ax, ay = np.sin(k * arc) / k, (1.0 - np.cos(k * arc)) / k
        d2 = (x[..., None] - ax) ** 2 + (y[..., None] - ay) ** 2
        return (x >= 0.0) & (d2.min(axis=-1) <= self.radius ** 2)

    def check(self, ranges, range_min: float, range_max: float,
              curvature_per_m: float = 0.0, distance_m: Optional[float] = None
              ) -> Tuple[bool, str]:
        """(blocked, why) for one scan's ranges [m] of this layout, for the path of
        ``curvature_per_m`` [1/m] over ``distance_m`` [m] (default: straight ahead over
        ``stop_distance_m``)."""
        r = np.asarray(ranges, dtype=float)
        if r.shape != self.angles.shape:
            return True, "scan has %d beams, the sector was made for %d" % (r.size,
                                                                          self.angles.size)
        with np.errstate(invalid="ignore"):
            hit = np.isfinite(r) & (r >= range_min) & (r <= range_max)
        too_close = np.isneginf(r) & self.in_sector
        if too_close.any():
            return True, "%d beam(s) ahead report an object closer than range_min (-inf)" \
                % int(too_close.sum())
        with np.errstate(invalid="ignore"):
            valid = hit | np.isposinf(r) | (np.isfinite(r) & (r > range_max))
        n_sector = int(self.in_sector.sum())
        if n_sector == 0 or valid[self.in_sector].mean() < self.min_valid:
            return True, "safety sector blind: %d of %d beams valid" % (
                int(valid[self.in_sector].sum()), n_sector)
        rh = np.where(hit, r, 0.0)
        x = self.mount[0] + rh * np.cos(self.angles)
        y = self.mount[1] + rh * np.sin(self.angles)
        k = np.flatnonzero(hit)
        inside = k[self.in_swept(x[k], y[k], curvature_per_m, distance_m)]
        if inside.size:
            nearest = inside[np.argmin(np.hypot(x[inside], y[inside]))]
            return True, "obstacle at (%.2f, %.2f) m in the path" % (x[nearest], y[nearest])
        return False, ""


class Follower:
    """The state machine of the module doc. Not thread-safe: call from one thread."""

    def __init__(self, p: FollowerParams):
        self.p = p
        self.reset()

    def reset(self) -> None:
        """Forget the target and the last command (after disable or a time jump)."""
        self.v = 0.0
        self.w = 0.0
        self.last_bearing: Optional[float] = None
        self.lost_since: Optional[float] = None

    def step(self, now_s: float, dt_s: float, target_stamp_s: Optional[float],
             aim: Optional[Aim], scan_stamp_s: Optional[float],
             blocked: Union[bool, PathCheck], blocked_reason: str = "") -> Command:
        """One control cycle at ``now_s`` [s], ``dt_s`` [s] after the previous one.
        ``target_stamp_s``/``scan_stamp_s``: stamps of the newest target message and
        usable scan (None: none yet); ``aim``: the tracked target (None: not tracked);
        ``blocked``: the safety sector's verdict on that scan, for any path (a bool, with
        ``blocked_reason``) or per path (``PathCheck``: the commanded arc and the arc the
        robot is braking along are checked, module doc)."""
        p = self.p
        stale = self._stale(now_s, target_stamp_s, p.target_timeout_s, "target message")
        stale = stale or self._stale(now_s, scan_stamp_s, p.scan_timeout_s, "usable scan")
        if stale:
            self.v = self.w = 0.0
            return Command(0.0, 0.0, STALE, stale)
        if aim is not None and aim.searching:  # to where the target was last seen
            timed_out = self._search_timed_out(now_s)
            if timed_out is not None:
                return timed_out
            self.last_bearing = aim.bearing_rad
            v, w = control_law(p, aim)
            reason = "to where the target was last seen"
            is_blocked, why = self._blocked(blocked, blocked_reason, v, w, dt_s)
            if is_blocked:
                self.v = min(self.v, 0.0)
                v, reason = min(v, 0.0), why
            cmd = self._limited(v, w, dt_s, SEARCHING, reason)
            cmd.blocked = is_blocked
            return cmd
        if aim is not None:
            self.last_bearing = aim.bearing_rad
            self.lost_since = None
            v, w = control_law(p, aim)
            state, reason = FOLLOWING, ""
            is_blocked, blocked_reason = self._blocked(blocked, blocked_reason, v, w, dt_s)
            if is_blocked:
                self.v = min(self.v, 0.0)  # the safety stop acts at once
                if v > 0.0:
                    v, state, reason = 0.0, BLOCKED, blocked_reason
            cmd = self._limited(v, w, dt_s, state, reason)
            cmd.blocked = is_blocked
            return cmd
        if self.last_bearing is None:
            self.v = self.w = 0.0
            return Command(0.0, 0.0, LOST, "no target acquired")
        timed_out = self._search_timed_out(now_s)
        if timed_out is not None:
            return timed_out
        rate = min(p.search_angular_radps, p.max_angular_radps)
        w = rate if self.last_bearing >= 0.0 else -rate
        self.v = 0.0
        return self._limited(0.0, w, dt_s, SEARCHING, "last bearing %.2f rad"
                             % self.last_bearing)

    def _blocked(self, blocked: Union[bool, PathCheck], reason: str, v: float, w: float,
                 dt_s: float) -> Tuple[bool, str]:
        """The safety stop's verdict for the command (v, w) from the present motion."""
        if not callable(blocked):
            return bool(blocked), reason
        if v > EPS_M:  # the arc the command asks for
            hit, why = blocked(w / v, self.p.stop_distance_m)
            if hit:
                return True, why
        if self.v > EPS_M:  # the arc the robot is on, as far as it rolls before it stops
            rolls = self.v * max(dt_s, 0.0) + self.v ** 2 / (2.0 * self.p.max_linear_accel_mps2)
            return blocked(self.w / self.v, rolls)
        return False, ""

    def _search_timed_out(self, now_s: float) -> Optional[Command]:
        """The LOST command once the search started ``search_timeout_s`` ago, else None
        (the search's start is remembered)."""
        if self.lost_since is None:
            self.lost_since = now_s
        if now_s - self.lost_since < self.p.search_timeout_s:
            return None
        self.v = self.w = 0.0
        return Command(0.0, 0.0, LOST, "searched %.1f s without finding the target"
                       % self.p.search_timeout_s)

    @staticmethod
    def _stale(now_s: float, stamp_s: Optional[float], timeout_s: float, what: str) -> str:
        if stamp_s is None:
            return "no %s yet" % what
        age = now_s - stamp_s
        if age > timeout_s:
            return "no %s newer than %.2f s (newest %.2f s old)" % (what, timeout_s, age)
        return ""

    def _limited(self, v: float, w: float, dt_s: float, state: str, reason: str) -> Command:
        dt = max(dt_s, 0.0)
        self.v = step_toward(self.v, v, self.p.max_linear_accel_mps2 * dt)
        self.w = step_toward(self.w, w, self.p.max_angular_accel_radps2 * dt)
        return Command(self.v, self.w, state, reason)
