"""Scenario detection for the scenario coefficient wS of eq. (2.1): room or corridor.

Looks at the free space around the robot: the FREE cells within `radius_m` that are
connected to the robot's cell. It is a corridor when that space is
    narrow:    2 x (largest distance from a free cell to the nearest OCCUPIED cell)
               <= corridor_max_width_m, and
    elongated: sqrt(major / minor eigenvalue of the free cells' covariance)
               >= corridor_min_elongation;
otherwise a room. Unknown cells are not obstacles here (unexplored space must not make a
room look narrow). A room cluttered with furniture can look narrow but not elongated, so
it stays a room; an L-shaped corridor corner can come out as a room (known limitation).
No ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import cv2
import numpy as np

from ascc_common.grid import FREE, OCCUPIED
from ascc_common.params import param

ROOM = "room"
CORRIDOR = "corridor"


@dataclass
class ScenarioParams:
    """Room / corridor detection (``ascc_common.params``)."""

    radius_m: float = param(4.0, "[m] look this far around the robot", "scenario_radius_m")
    corridor_max_width_m: float = param(2.5, "[m] wider free space is a room")
    corridor_min_elongation: float = param(1.8, "[-] sqrt eigenvalue ratio of the free cells")
    w_room: float = param(1.0, "wS in rooms", "w_scenario_room")
    w_corridor: float = param(0.5, "wS in corridors: gain counts less than travel",
                              "w_scenario_corridor")


@dataclass
class Scenario:
    name: str              # ROOM or CORRIDOR
    w_scenario: float      # wS for eq. (2.1)
    width_m: float         # 2 x max clearance of the connected free space [m]
    elongation: float      # sqrt eigenvalue ratio [-]


def classify(grid: np.ndarray, resolution: float, robot_rc: Tuple[int, int],
             params: ScenarioParams) -> Scenario:
    """Classify the robot's surroundings; a robot off the free space counts as a room."""
    h, w = grid.shape
    rad = max(1, int(math.ceil(params.radius_m / resolution)))
    r, c = int(robot_rc[0]), int(robot_rc[1])
    r0, r1, c0, c1 = max(0, r - rad), min(h, r + rad + 1), max(0, c - rad), min(w, c + rad + 1)
    room = Scenario(ROOM, params.w_room, float("inf"), 1.0)
    if r0 >= r1 or c0 >= c1 or grid[r, c] != FREE:
        return room
    win = grid[r0:r1, c0:c1].view(np.uint8)
    free = cv2.compare(win, FREE, cv2.CMP_EQ)
    yy, xx = np.ogrid[r0 - r: r1 - r, c0 - c: c1 - c]
    free[(yy * yy + xx * xx) > rad * rad] = 0                       # disc, not square
    mask = np.zeros((free.shape[0] + 2, free.shape[1] + 2), np.uint8)
    flags = 8 | cv2.FLOODFILL_MASK_ONLY | cv2.FLOODFILL_FIXED_RANGE | (255 << 8)
    cv2.floodFill(free, mask, (c - c0, r - r0), 0, 0, 0, flags)
    region = mask[1:-1, 1:-1] > 0
    not_occ = cv2.compare(win, OCCUPIED, cv2.CMP_NE)
    clearance = cv2.distanceTransform(not_occ, cv2.DIST_L2, 5)      # [cells] to occupied
    width_m = 2.0 * float(clearance[region].max()) * resolution
    rows, cols = np.nonzero(region)
    if rows.size < 3:
        return room
    cov = np.cov(np.stack([rows, cols]).astype(np.float64))
    ev = np.linalg.eigvalsh(cov)
    elong = math.sqrt(ev[1] / max(ev[0], 1e-9))
    if width_m <= params.corridor_max_width_m and elong >= params.corridor_min_elongation:
        return Scenario(CORRIDOR, params.w_corridor, width_m, elong)
    return Scenario(ROOM, params.w_room, width_m, elong)
