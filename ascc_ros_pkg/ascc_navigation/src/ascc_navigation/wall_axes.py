"""The direction of a scan's straight walls, modulo a right angle (no ROS imports).

Indoors most walls are straight and meet at right angles. A scan of a corridor or a room
then shows long straight runs of end points along two perpendicular directions, and their
direction in the robot's frame is measured more precisely (about 1.5 mrad std on the
simulated corridor's scans as the mapper prepares them, 0.7 mrad from the end points at
their measured ranges: docs/results/ascc_navigation.md, "The walls' direction, measured on
the surface") than a scan matcher holds the heading against a map it built itself (walls
one to two cells thick: about a hundredth of a radian of play). The mapper
(``rbpf``, ``wall_axis_std_rad``) compares each particle's heading plus this direction with
the direction the first scan showed, so the map's walls keep the directions they started
with over a long corridor. Walls that are not at right angles to the first ones are left
out by a gate.

``scan_wall_axis``: a coarse search for the rotation whose x and y histograms of the end
points are sharpest (straight walls along the axes fall into few bins), then a pooled
least-squares fit: the end points within ``gate_m`` of each histogram peak that holds a
wall (``min_points`` end points spread over ``min_extent_m``) are lines of one common
direction, and that direction is refined from all of them at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

RIGHT_ANGLE = math.pi / 2.0


def wrap_right_angle(a):
    """Angles [rad] wrapped into [-pi/4, pi/4): directions modulo a right angle."""
    return (np.asarray(a, dtype=float) + RIGHT_ANGLE / 2.0) % RIGHT_ANGLE - RIGHT_ANGLE / 2.0


def mean_direction(reference: Optional[float], count: int, direction: float) -> float:
    """The mean, modulo a right angle, of ``count`` directions [rad] whose mean is
    ``reference`` (None: no direction yet) and one more, ``direction``; near
    ``reference`` (a running mean of the walls' directions of scans from one pose)."""
    if reference is None or count <= 0:
        return float(direction)
    return float(reference + wrap_right_angle(direction - reference) / (count + 1))


@dataclass
class WallAxis:
    """A scan's wall direction: ``angle`` [rad, in [-pi/4, pi/4)] of the walls (modulo a right
    angle) in the frame of the end points; ``points`` end points on the fitted walls;
    ``spread_m2``: sum over those points of their squared distance along their wall from the
    wall's centre [m^2] (the fit's information: the angle's std is the end points' noise
    across the wall divided by its square root); ``disagreement`` [rad]: the largest
    difference between one wall's own direction and the common one, less DISAGREE_STDS of
    that wall's own fit (the noise across the walls estimated from all of them), at least
    0: a stretch of another family of walls a few degrees off, caught near a peak, shows
    by about that many degrees; walls of one direction by about nothing."""

    angle: float
    points: int
    spread_m2: float
    disagreement: float = 0.0


def _sharpness(pts: np.ndarray, angles: np.ndarray, bin_m: float) -> np.ndarray:
    """Sum of squared histogram counts of the end points' x and y after rotating them by each
    angle (one bincount over all angles per axis)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    x, y = pts[:, 0][None], pts[:, 1][None]
    sharp = np.zeros(angles.size)
    rows = np.arange(angles.size)[:, None]
    for coord in (x * c + y * s, -x * s + y * c):
        idx = np.floor(coord / bin_m).astype(np.int64)
        idx -= idx.min()
        width = int(idx.max()) + 1
        counts = np.bincount((idx + width * rows).ravel(), minlength=width * angles.size)
        sharp += (counts.astype(np.float64) ** 2).reshape(angles.size, width).sum(axis=1)
    return sharp


def scan_wall_axis(pts: np.ndarray, bin_m: float = 0.04, coarse_step_rad: float = 0.0175,
                   gate_m: float = 0.06, min_points: int = 20, min_extent_m: float = 0.8,
                   refinements: int = 2) -> Optional[WallAxis]:
    """The direction of the straight walls in ``pts`` ((N, 2) end points [m]), or None if no
    histogram peak holds a wall (fewer than ``min_points`` end points within ``gate_m`` of
    its line, or spread over less than ``min_extent_m`` along it)."""
    pts = np.asarray(pts, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[0] < min_points:
        return None
    angles = np.arange(-RIGHT_ANGLE / 2.0, RIGHT_ANGLE / 2.0, coarse_step_rad)
    a = float(angles[int(np.argmax(_sharpness(pts, angles, bin_m)))])
    result = None
    for _ in range(refinements):
        ca, sa = math.cos(a), math.sin(a)
        u = pts[:, 0] * ca + pts[:, 1] * sa
        v = -pts[:, 0] * sa + pts[:, 1] * ca
        num = spread = 0.0
        points = 0
        walls = []  # per wall: sign, sum al*ac, sum al^2, sum ac^2 (centred)
        # Walls along u (v constant) turned by +d have dv/du = tan d; walls along v (u
        # constant) have du/dv = -tan d: one pooled slope for both.
        for along, across, sign in ((u, v, 1.0), (v, u, -1.0)):
            idx = np.floor(across / bin_m).astype(np.int64)
            lo = int(idx.min())
            counts = np.bincount(idx - lo)
            padded = np.concatenate(([0], counts, [0]))
            peaks = np.nonzero((counts >= min_points) & (counts > padded[:-2])
                               & (counts >= padded[2:]))[0]
            for peak in peaks:
                centre = (peak + lo + 0.5) * bin_m
                on = np.abs(across - centre) <= gate_m
                al, ac = along[on], across[on]
                if al.size < min_points or al.max() - al.min() < min_extent_m:
                    continue
                al = al - al.mean()
                ac = ac - ac.mean()
                cov, var = float(np.dot(al, ac)), float(np.dot(al, al))
                num += sign * cov
                spread += var
                points += int(al.size)
                walls.append((sign, cov, var, float(np.dot(ac, ac))))
        if spread <= 0.0:
            return None
        result = WallAxis(angle=float(wrap_right_angle(a + math.atan2(num, spread))),
                          points=points, spread_m2=spread,
                          disagreement=_disagreement(walls, num / spread, points))
        a = result.angle
    return result


DISAGREE_STDS = 4.0  # a wall's own direction counts as off the others beyond this many stds
NOISE_FLOOR_M = 0.01  # [m] walls' unevenness and the grid's steps: a near-perfect laser's
                     # residuals would otherwise make a milliradian look like many stds


def _disagreement(walls, slope: float, points: int) -> float:
    """The largest |own slope - common slope| - DISAGREE_STDS std of own slope (at least 0)
    of the walls ``walls`` ((sign, cov, var, ss) of their centred along / across
    coordinates), the noise across the walls from the residuals about the common slope (at
    least NOISE_FLOOR_M); 0 for one wall."""
    if len(walls) < 2 or points <= 2 * len(walls):
        return 0.0
    w = np.array(walls)
    sign, cov, var, ss = w[:, 0], w[:, 1], w[:, 2], w[:, 3]
    expected = sign * slope
    residual = float(np.sum(ss - 2.0 * expected * cov + expected ** 2 * var))
    noise = max(NOISE_FLOOR_M, math.sqrt(max(residual, 0.0) / (points - 2 * len(walls))))
    off = np.abs(cov / var - expected) - DISAGREE_STDS * noise / np.sqrt(var)
    return max(0.0, float(np.max(off)))
