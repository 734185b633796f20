"""The calibration landmarks (thesis 3.4.1, the desk corners) measured in a map.

The thesis reads the four desk corners off the robots' map (its fig. 3.4) and off the
Vicon's (fig. 3.3). ``desk_corner`` finds a corner of an occupied block in an occupancy
grid near a rough guess: the occupied cells within ``radius_m`` of the guess, their
centroid c (inside the block), and the cell farthest from c in the direction u from c to
the guess; for a convex corner this is the corner cell whenever u lies between the two
edges' outward normals (a guess within about ``radius_m`` / 2 of the corner), and the
corner itself is that cell's outer corner (half a cell further along the signs of u, for
a grid aligned with the map). Accuracy: half a cell. ``measure`` does every landmark and
``calibrate`` fits the truth -> map transform to them (calibration.fit_rigid_2d).
"""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.grid import GridInfo

from .calibration import Rigid2D, fit_rigid_2d

OCCUPIED_MIN = 50  # occupancy value [0..100] from which a cell counts as occupied


def occupied_points(occupancy: np.ndarray, info: GridInfo) -> np.ndarray:
    """(N, 2) map coordinates [m] of the occupied cells' centres (grid aligned with map)."""
    if abs(info.origin_yaw) > 1e-9:
        raise ValueError("a rotated grid (origin yaw %g rad) is not supported"
                         % info.origin_yaw)
    iy, ix = np.nonzero(np.asarray(occupancy) >= OCCUPIED_MIN)
    return np.stack([info.origin_x + (ix + 0.5) * info.resolution,
                     info.origin_y + (iy + 0.5) * info.resolution], axis=1)


def desk_corner(points: np.ndarray, resolution: float, guess: Sequence[float],
                radius_m: float = 0.3) -> Tuple[Optional[np.ndarray], str]:
    """The corner near ``guess`` of the occupied block ``points`` (cell centres) and "",
    or None and why not."""
    g = np.asarray(guess, dtype=float)
    near = points[np.hypot(*(points - g).T) <= radius_m]
    if len(near) < 3:
        return None, "fewer than 3 occupied cells within %.2f m of (%.2f, %.2f)" \
            % (radius_m, g[0], g[1])
    c = near.mean(axis=0)
    u = g - c
    if np.hypot(*u) < 0.5 * resolution:
        return None, "the guess (%.2f, %.2f) is inside the block: no corner direction" \
            % (g[0], g[1])
    u = u / np.hypot(*u)
    k = int(np.argmax(near @ u))
    return near[k] + 0.5 * resolution * np.sign(u), ""


def measure(occupancy: np.ndarray, info: GridInfo, guesses: Dict[str, Sequence[float]],
            radius_m: float = 0.3) -> Tuple[Dict[str, np.ndarray], Dict[str, str]]:
    """Each landmark's corner in the map, and the landmarks that could not be measured
    with why."""
    pts = occupied_points(occupancy, info)
    found, failed = {}, {}
    for name, guess in guesses.items():
        corner, why = desk_corner(pts, info.resolution, guess, radius_m)
        if corner is None:
            failed[name] = why
        else:
            found[name] = corner
    return found, failed


def calibrate(truth: Dict[str, Sequence[float]], in_map: Dict[str, np.ndarray]
              ) -> Tuple[Rigid2D, List[str]]:
    """The truth-frame -> map transform from the landmarks measured in both (>= 3)."""
    names = sorted(set(truth) & set(in_map))
    src = np.array([truth[n] for n in names], dtype=float)
    dst = np.array([in_map[n] for n in names], dtype=float)
    return fit_rigid_2d(src, dst), names
