"""Image detections -> observations in base_link: bearing, elevation, range, position.

A blob's centroid gives its bearing and elevation through the shared camera model
(``PanoramicCamera.pixel_to_ray``; in the double panorama a blob lies in one strip, the
strip of its centroid, and its top and bottom rows are read in that strip). The range:

1. **laser** (``RANGE_LASER``): the scan's beams, transformed into base_link with the
   laser's pose there, whose hit points lie within ``radius_m`` of the camera ray towards
   the target and whose distance along the ray is within ``gate_m`` of the size estimate
   (the beam hits the target, not the wall behind it or an obstacle in front; for a blob
   cut off by its strip's top or bottom row, anywhere nearer than that too: see below);
   of those,
   the nearest group (sorted along the ray, split where consecutive hits are more than
   ``CLUSTER_GAP_M`` apart; the first group of at least two hits): a real laser sees a
   person's legs, two thin posts, and a wall 0.3 m behind them has more hits within the
   ray's radius, so the median of all hits put the person 0.2 m too far; the range is
   that group's median;
2. else **size** (``RANGE_SIZE``): the cone from its floor contact (the blob's bottom edge,
   ``range_from_floor_contact``), the shirt and the logo from their vertical extent and
   known height (``range_from_extent``);
3. else none (``RANGE_NONE``, range and position NaN).

**Cut-off blobs.** The camera sees 33.75 deg above and below its horizon (0.55 m up): a
shirt's top (1.43 m on a 1.75 m person) leaves the picture nearer than about 1.3 m, and a
cone's foot below about 0.8 m. The blob then ends at its strip's edge, the measured extent
is short and the size estimate too long: at 0.6-0.8 m a shirt measured 1.6-2.2 m, and the
laser's hits on the person, outside the gate around that, were dropped (the simulator's
apartment runs, `docs/results/target_follower.md`). For a blob touching its strip's top or
bottom row (``cut_off``) the estimate is an upper bound, and the laser's hits count from
the camera out to the estimate plus the gate.

Ranges are horizontal, from the camera for the estimate and from base_link's origin in the
result; NaN or inf beams are ignored (the caller warns about them).

**Times.** The bearing belongs to the picture's time (the frame's stamp less the camera's
latency), the scan to its own stamp; a robot turning at 0.5 rad/s turns 0.15 rad (9 deg)
in 0.3 s, which at 1.5 m puts the ray 0.22 m beside the target, beyond its radius. So the
scan's points are brought into base_link *at the picture's time* through ``Scan.motion``:
the pose of base_link at the scan's stamp in base_link at the picture's time (from the
odometry, ``motion_between``). The observation (bearing, range, position) is then all of
the picture's time, where the follower places it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ascc_common.camera_model import PanoramicCamera
from ascc_common.pose2d import compose, relative

from .color_detector import Blob

RANGE_NONE, RANGE_LASER, RANGE_SIZE = 0, 1, 2  # Detection.msg's range_source values
CLUSTER_GAP_M = 0.15  # [m] hits farther apart along the ray belong to different objects
CUT_OFF_PX = 1  # [px] a blob whose box reaches this close to its strip's top or bottom
# edge is cut off (1: it touches the edge row)


@dataclass
class TargetShape:
    """What the geometry knows of a kind of target."""

    floor_contact: bool  # its blob's bottom edge touches the floor (cone)
    height_m: float  # vertical extent of the detected region [m] (for range_from_extent)
    radius_m: float  # horizontal half-size: laser hits within it count [m]


SHAPES = {"cone": TargetShape(True, 0.45, 0.2),
          "shirt": TargetShape(False, 0.6, 0.3),
          "logo": TargetShape(False, 0.4, 0.3)}


@dataclass
class Scan:
    """The part of a sensor_msgs/LaserScan the geometry needs, and the laser's pose in
    base_link (x, y [m], yaw [rad])."""

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    pose: Sequence[float] = (0.0, 0.0, 0.0)
    # base_link at the scan's stamp in base_link at the picture's time (module doc)
    motion: Sequence[float] = (0.0, 0.0, 0.0)

    def points_in_base(self) -> np.ndarray:
        """(n, 2) base_link points (at the picture's time: ``motion``) of the valid beams
        (finite, within [range_min, range_max])."""
        r = np.asarray(self.ranges, dtype=np.float64)
        a = self.angle_min + self.angle_increment * np.arange(r.size)
        with np.errstate(invalid="ignore"):  # NaN compares False (numpy < 1.19 warns)
            ok = np.isfinite(r) & (r >= self.range_min) & (r <= self.range_max)
        x, y, yaw = compose(self.motion, self.pose)
        r, a = r[ok], a[ok] + yaw
        return np.stack([x + r * np.cos(a), y + r * np.sin(a)], axis=1)


def motion_between(pose_picture: Sequence[float], pose_scan: Sequence[float]) -> tuple:
    """``Scan.motion`` from the odometry poses (x, y, yaw) at the picture's time and at
    the scan's stamp."""
    return tuple(float(v) for v in relative(pose_picture, pose_scan))


@dataclass
class Located:
    kind: str
    bearing_rad: float  # base_link bearing (from the camera's position)
    elevation_rad: float
    range_m: float  # horizontal, from base_link's origin; NaN when unknown
    range_source: int
    x_m: float  # position in base_link; NaN when unknown
    y_m: float
    blob: Blob


def _ray(cam: PanoramicCamera, u: float, v: float, strip: int):
    """Bearing and elevation of (u, v), v clamped into ``strip``."""
    sh = cam.strip_height_px
    v = min(max(v, strip * sh), (strip + 1) * sh - 1e-6)
    b, e = cam.pixel_to_ray(u, v)
    return float(b), float(e)


def cut_off(cam: PanoramicCamera, blob: Blob) -> bool:
    """The blob touches its strip's top or bottom row: part of the target is out of the
    picture, so its size range is an upper bound (module doc)."""
    sh = cam.strip_height_px
    strip = int(min(cam.strips - 1, max(0, blob.v // sh)))
    top, bottom = strip * sh, (strip + 1) * sh  # the strip's rows: [top, bottom)
    _, y, _, h = blob.bbox  # the box's rows: [y, y + h)
    return y < top + CUT_OFF_PX or y + h > bottom - CUT_OFF_PX


def size_range(cam: PanoramicCamera, blob: Blob, shape: TargetShape) -> float:
    """Horizontal range from the camera [m] estimated from the blob's size; inf if none."""
    strip = int(min(cam.strips - 1, max(0, blob.v // cam.strip_height_px)))
    x, y, w, h = blob.bbox
    _, bottom = _ray(cam, blob.u, y + h, strip)
    if shape.floor_contact:
        return float(cam.range_from_floor_contact(bottom))
    _, top = _ray(cam, blob.u, y, strip)
    return float(cam.range_from_extent(top, bottom, shape.height_m))


def laser_range(cam: PanoramicCamera, bearing_cam: float, estimate_m: float, scan: Scan,
                radius_m: float, gate_m: float, upper_bound: bool = False) -> Optional[float]:
    """Horizontal range from the camera [m] of the laser hits on the target (see the
    module doc), or None. ``upper_bound``: the estimate is one (a cut-off blob), hits
    nearer than it count however near."""
    if not math.isfinite(estimate_m):
        return None
    pts = scan.points_in_base()
    if pts.size == 0:
        return None
    b = float(cam.base_bearing(bearing_cam))
    d = np.array([math.cos(b), math.sin(b)])
    rel = pts - np.array([cam.mount_x_m, cam.mount_y_m])
    along = rel @ d
    perp = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0])
    near_m = 0.0 if upper_bound else estimate_m - gate_m
    hit = (along > 0) & (perp <= radius_m) & (along >= near_m) & (along <= estimate_m + gate_m)
    if not np.any(hit):
        return None
    d = np.sort(along[hit])
    groups = np.split(d, np.flatnonzero(np.diff(d) > CLUSTER_GAP_M) + 1)
    nearest = next((g for g in groups if g.size >= 2), d)
    return float(np.median(nearest))


def locate(cam: PanoramicCamera, blob: Blob, shape: TargetShape, scan: Optional[Scan] = None,
           gate_m: float = 0.5, gate_fraction: float = 0.3) -> Located:
    """The observation of ``blob``: laser range when a beam hits the target within
    ``max(gate_m, gate_fraction x estimate)`` of the size estimate (below it however far,
    for a cut-off blob), else the estimate."""
    strip = int(min(cam.strips - 1, max(0, blob.v // cam.strip_height_px)))
    b_cam, elev = _ray(cam, blob.u, blob.v, strip)
    est = size_range(cam, blob, shape)
    r_cam, source = None, RANGE_NONE
    if scan is not None:
        r_cam = laser_range(cam, b_cam, est, scan, shape.radius_m,
                            max(gate_m, gate_fraction * est) if math.isfinite(est) else 0.0,
                            upper_bound=cut_off(cam, blob))
        source = RANGE_LASER if r_cam is not None else RANGE_NONE
    if r_cam is None and math.isfinite(est) and est > 0:
        r_cam, source = est, RANGE_SIZE
    bearing = float(cam.base_bearing(b_cam))
    if r_cam is None:
        return Located(blob.kind, bearing, elev, math.nan, RANGE_NONE, math.nan, math.nan,
                       blob)
    x, y = cam.point_in_base(b_cam, r_cam)
    return Located(blob.kind, bearing, elev, math.hypot(float(x), float(y)), source,
                   float(x), float(y), blob)
