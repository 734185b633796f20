"""Planar laser scans turned into geometry in the robot's base frame (no ROS imports).

``LaserMount`` is the laser's pose on the robot (from TF base_link -> laser);
``prepare_scan`` classifies every beam the way gmapping does and returns, in the base frame:
  * ``hits``: end points of beams that returned within ``max_urange`` (obstacles),
  * ``match``: every (lskip+1)-th hit, used for scan matching and weighting (with its
    measured range ``match_range``),
  * ``free_polygon``: the observed free space, one angular wedge per beam up to its range
    (hits pulled back by ``free_pullback`` so the obstacle cell is not cleared; beams between
    ``max_urange`` and ``max_range`` clear up to ``max_urange``; discarded beams leave gaps).
Beam classes (gmapping's semantics; +inf, REP 117's "no return", counts as range_max):
  * NaN, -inf, or < range_min: invalid, discarded;
  * > max_range: discarded completely (so with the default max_range = range_max - 1 cm
    no-return beams are ignored; set max_range above range_max to let them clear space);
  * (max_urange, max_range]: free space up to max_urange, no hit;
  * [range_min, max_urange]: hit.
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ascc_common.pose2d import yaw_from_quaternion, z_axis_from_quaternion

# A laser whose z axis deviates more than this from the base's +-z is not planar with the base.
MAX_TILT_RAD = 0.1
# Free-space pull-back at grazing incidence: divided by sin(grazing angle), at most this many
# times; neighbouring end points further apart than SURFACE_GAP_M are not one surface.
MAX_PULLBACK_GAIN = 4.0
SURFACE_GAP_M = 0.3


class LaserMount:
    """Pose of the laser in the base frame: x, y [m], yaw [rad], mounted upside down or not."""

    __slots__ = ("x", "y", "yaw", "upside_down")

    def __init__(self, x: float = 0.0, y: float = 0.0, yaw: float = 0.0,
                 upside_down: bool = False):
        self.x = float(x)
        self.y = float(y)
        self.yaw = float(yaw)
        self.upside_down = bool(upside_down)

    @classmethod
    def from_transform(cls, tx: float, ty: float, qx: float, qy: float, qz: float,
                       qw: float) -> LaserMount:
        """From a base->laser transform; ValueError if the laser is not level (tilted)."""
        zx, zy, zz = z_axis_from_quaternion(qx, qy, qz, qw)
        if math.hypot(zx, zy) > math.sin(MAX_TILT_RAD):
            raise ValueError("laser frame is tilted (z axis %.2f %.2f %.2f in the base frame); "
                             "only level lasers are supported" % (zx, zy, zz))
        return cls(tx, ty, yaw_from_quaternion(qx, qy, qz, qw), upside_down=zz < 0.0)

    def beam_angles(self, n: int, angle_min: float, angle_increment: float) -> np.ndarray:
        """Directions [rad] of the n beams in the base frame."""
        a = angle_min + angle_increment * np.arange(n, dtype=float)
        return self.yaw - a if self.upside_down else self.yaw + a

    def __repr__(self) -> str:
        return "LaserMount(x=%g, y=%g, yaw=%g, upside_down=%s)" % (
            self.x, self.y, self.yaw, self.upside_down)


class PreparedScan:
    """One scan's geometry in the base frame, ready for the mapper (see module doc)."""

    __slots__ = ("origin", "hits", "match", "match_range", "max_urange", "free_polygon",
                 "n_beams", "n_hits", "n_free_only", "angles", "seen")

    def __init__(self, origin, hits, match, match_range, max_urange, free_polygon, n_beams,
                 n_hits, n_free_only, angles=None, seen=None):
        self.origin = origin
        self.hits = hits
        self.match = match
        self.match_range = match_range
        self.max_urange = max_urange
        self.free_polygon = free_polygon
        self.n_beams = n_beams
        self.n_hits = n_hits
        self.n_free_only = n_free_only
        self.angles = angles  # (n_beams,) base frame [rad], None: unknown
        self.seen = seen      # (n_beams,) [m]

    @property
    def usable(self) -> bool:
        return self.n_hits > 0


def _wedge_polygon(origin: np.ndarray, angles: np.ndarray, half_width: float,
                   reach: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Vertices of the union of beam wedges, ordered by angle, back to the origin at gaps."""
    order = np.argsort(angles, kind="stable")
    angles, reach, valid = angles[order], reach[order], valid[order]
    n = angles.size
    slots = np.empty((n, 3, 2))
    for k, sign in ((0, -1.0), (1, 1.0)):
        a = angles + sign * half_width
        slots[:, k, 0] = origin[0] + reach * np.cos(a)
        slots[:, k, 1] = origin[1] + reach * np.sin(a)
    slots[:, 2, :] = origin
    keep = np.zeros((n, 3), dtype=bool)
    keep[:, 0] = valid
    keep[:, 1] = valid
    next_valid = np.append(valid[1:], False)
    keep[:, 2] = valid & ~next_valid  # close each run of valid beams at the origin
    return np.vstack([origin[None, :], slots[keep]])


def _grazing_gain(origin: np.ndarray, angles: np.ndarray, r: np.ndarray,
                  is_hit: np.ndarray) -> np.ndarray:
    """1 / sin(angle between beam and surface), from the surface direction through the
    neighbouring end points, clipped to [1, MAX_PULLBACK_GAIN]; 1 where unknown. Dividing the
    free-space pull-back by it keeps a beam that grazes a wall from clearing the wall's cells
    just before its end point (which would erode walls seen at a shallow angle)."""
    ex = np.where(is_hit, origin[0] + np.nan_to_num(r) * np.cos(angles), np.nan)
    ey = np.where(is_hit, origin[1] + np.nan_to_num(r) * np.sin(angles), np.nan)
    pad_x = np.concatenate([[np.nan], ex, [np.nan]])
    pad_y = np.concatenate([[np.nan], ey, [np.nan]])
    # central difference, else one-sided where a neighbour is missing
    tx = pad_x[2:] - pad_x[:-2]
    ty = pad_y[2:] - pad_y[:-2]
    for nx, ny in ((pad_x[2:] - ex, pad_y[2:] - ey), (ex - pad_x[:-2], ey - pad_y[:-2])):
        missing = np.isnan(tx)
        tx = np.where(missing, nx, tx)
        ty = np.where(missing, ny, ty)
    length = np.hypot(tx, ty)
    with np.errstate(invalid="ignore", divide="ignore"):  # NaN lengths: numpy < 1.19 warns
        ok = np.isfinite(length) & (length > 1e-9) & (length < SURFACE_GAP_M)
        sin_graze = np.abs(np.cos(angles) * ty - np.sin(angles) * tx) / length
    gain = 1.0 / np.clip(sin_graze, 1.0 / MAX_PULLBACK_GAIN, 1.0)
    return np.where(ok, gain, 1.0)


def prepare_scan(ranges, angle_min: float, angle_increment: float, range_min: float,
                 range_max: float, mount: LaserMount, max_urange: float,
                 max_range: Optional[float] = None, lskip: int = 0,
                 free_pullback: float = 0.0, hit_offset: float = 0.0) -> PreparedScan:
    """Classify beams and build the base-frame geometry of one scan (see module doc).

    ``max_range`` defaults to ``range_max`` - 1 cm like gmapping's; ``max_urange`` is clipped to
    ``max_range``. ``free_pullback`` [m] shortens the free wedge of hit beams (more at grazing
    incidence, see ``_grazing_gain``); ``hit_offset``
    [m] moves hit points along the beam (a positive value puts a reading that lies exactly on a
    cell boundary into the cell behind the surface, i.e. the obstacle's cell).
    """
    r = np.asarray(ranges, dtype=float).ravel().copy()
    r[np.isposinf(r)] = range_max
    n = r.size
    if max_range is None or not max_range > 0.0:
        max_range = range_max - 0.01
    max_urange = min(max_urange, max_range)
    angles = mount.beam_angles(n, angle_min, angle_increment)
    origin = np.array([mount.x, mount.y])
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r >= range_min) & (r <= max_range)
        is_hit = ok & (r <= max_urange)
    free_only = ok & ~is_hit
    hit_r = r[is_hit] + hit_offset
    hit_a = angles[is_hit]
    hits = np.column_stack([origin[0] + hit_r * np.cos(hit_a), origin[1] + hit_r * np.sin(hit_a)])
    stride = max(1, int(lskip) + 1)
    match = hits[::stride]
    match_range = r[is_hit][::stride]
    pullback = free_pullback * _grazing_gain(origin, angles, r, is_hit)
    reach = np.where(is_hit, np.maximum(np.nan_to_num(r) - pullback, 0.0), max_urange)
    span = abs(angle_increment) * n
    if span >= 2.0 * math.pi - 1e-9:  # 360-degree scanners: drop the overlap at the seam
        keep_n = max(int(math.floor((2.0 * math.pi - 1e-6) / abs(angle_increment))), 1)
        ok = ok & (np.arange(n) < keep_n)
    polygon = _wedge_polygon(origin, angles, 0.5 * abs(angle_increment), reach, ok)
    seen = _seen_ranges(np.where(is_hit, np.nan_to_num(r), max_urange), ok)
    return PreparedScan(origin, hits, match, match_range, max_urange, polygon, n,
                        int(is_hit.sum()), int(free_only.sum()), angles, seen)


def _seen_ranges(reach: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """How far each beam saw: ``reach`` where ``ok``; a discarded beam (dropout, NaN) says
    nothing, so it takes the larger of its nearest usable neighbours' (0 if none)."""
    n = reach.size
    if not ok.any():
        return np.zeros(n)
    idx = np.arange(n)
    last = np.maximum.accumulate(np.where(ok, idx, -1))               # usable at or before
    nxt = np.minimum.accumulate(np.where(ok, idx, n)[::-1])[::-1]     # usable at or after
    padded = np.append(np.where(ok, reach, 0.0), 0.0)
    before = np.where(last >= 0, padded[np.maximum(last, 0)], 0.0)
    after = padded[np.minimum(nxt, n)]
    return np.where(ok, reach, np.maximum(before, after))


def seen_before(previous: PreparedScan, motion, pts: np.ndarray, margin: float) -> np.ndarray:
    """Which end points ``pts`` (M, 2, base frame) of a scan taken after the robot moved by
    ``motion`` (dx, dy, dtheta in the frame of ``previous``) lay within what the ``previous``
    scan saw: in its field of view and, along their direction from its laser, no more than
    ``margin`` [m] beyond its range there (the largest of the nearest beam and its two
    neighbours, so a single dropout does not hide a surface). The others are surfaces that
    were out of range, behind the field of view or *occluded* then (a door recess's back
    wall coming into view behind its jamb as the robot drives by): the map built so far
    ends where they begin. Returns a bool mask (M,); all True if ``previous`` carries no
    beam geometry."""
    m = pts.shape[0]
    if previous.angles is None or previous.angles.size < 2:
        return np.ones(m, dtype=bool)
    c, s = math.cos(motion[2]), math.sin(motion[2])
    qx = motion[0] + c * pts[:, 0] - s * pts[:, 1] - previous.origin[0]
    qy = motion[1] + s * pts[:, 0] + c * pts[:, 1] - previous.origin[1]
    angles = previous.angles
    first, step = float(angles[0]), float(angles[1] - angles[0])
    mid = 0.5 * (first + float(angles[-1]))
    # direction relative to the middle of the field of view, wrapped to [-pi, pi)
    phi = np.arctan2(qy, qx)
    rel = np.mod(phi - mid + math.pi, 2.0 * math.pi) - math.pi
    j = np.rint((rel + mid - first) / step).astype(np.int64)
    n = angles.size
    inside = (j >= 0) & (j < n)
    padded = np.concatenate([[0.0], previous.seen, [0.0]])
    k = np.clip(j, 0, n - 1) + 1
    reach = np.maximum(np.maximum(padded[k - 1], padded[k]), padded[k + 1])
    return inside & (np.hypot(qx, qy) <= reach + margin)
