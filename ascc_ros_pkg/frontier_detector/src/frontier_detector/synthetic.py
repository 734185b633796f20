"""Synthetic occupancy grids for tests and benchmarks (no ROS).

`office_building` draws a ground-truth floor plan (0 free / 100 occupied): an outer wall,
horizontal corridors, two rows of rooms between neighbouring corridors with a door each,
vertical corridors every few rooms and a few boxes of furniture per room.
`partially_explored` turns a ground truth into a map in the middle of an exploration
(-1 outside an explored disc and inside a few unvisited rooms).

Coordinates: arrays are indexed [row, col] = [y, x] with row 0 at the map origin (as in a
nav_msgs/OccupancyGrid); every length is in metres.
"""

from __future__ import annotations

from typing import Tuple

import numpy as np

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN


def _cells(length_m: float, resolution: float) -> int:
    return max(1, int(round(length_m / resolution)))


def office_building(
    size_m: float,
    resolution: float = 0.05,
    seed: int = 0,
    room_w_m: float = 5.0,
    room_d_m: float = 6.0,
    corridor_w_m: float = 2.0,
    wall_m: float = 0.1,
    door_w_m: float = 1.0,
    rooms_between_halls: int = 6,
    boxes_per_room: int = 2,
) -> np.ndarray:
    """Square floor plan of `size_m` x `size_m`; returns an int8 grid of FREE/OCCUPIED."""
    rng = np.random.default_rng(seed)
    n = _cells(size_m, resolution)
    grid = np.full((n, n), FREE, dtype=np.int8)
    wall = _cells(wall_m, resolution)
    cor = _cells(corridor_w_m, resolution)
    rw, rd = _cells(room_w_m, resolution), _cells(room_d_m, resolution)
    door = _cells(door_w_m, resolution)
    # Bands from top to bottom: corridor, room row (doors up), room row (doors down), ...
    band = cor + 2 * rd + 2 * wall
    y = wall
    while y + band <= n:
        rows = ((y + cor + wall, -1), (y + cor + wall + rd, +1))
        grid[y + cor: y + cor + wall, :] = OCCUPIED                       # corridor/room wall
        grid[y + cor + rd: y + cor + rd + wall, :] = OCCUPIED             # back-to-back rooms
        grid[y + band - wall: y + band, :] = OCCUPIED                     # next corridor wall
        for top, door_side in rows:
            x, k = wall, 0
            while x + rw <= n - wall:
                if k % (rooms_between_halls + 1) == rooms_between_halls:   # vertical hall
                    grid[top: top + rd, x: x + rw] = FREE
                    grid[top: top + rd, x - wall: x] = OCCUPIED
                    grid[top: top + rd, x + rw: x + rw + wall] = OCCUPIED
                    x, k = x + rw + wall, k + 1
                    continue
                grid[top: top + rd, x + rw: x + rw + wall] = OCCUPIED      # side wall
                d0 = x + int(rng.integers(wall, max(wall + 1, rw - door - wall)))
                wall_row = top - wall if door_side < 0 else top + rd
                grid[wall_row: wall_row + wall, d0: d0 + door] = FREE
                for _ in range(boxes_per_room):
                    bw, bh = (int(v) for v in rng.integers(4, max(5, rw // 4), size=2))
                    bx = x + int(rng.integers(wall + 1, max(wall + 2, rw - bw - 1)))
                    by = top + int(rng.integers(door + 1, max(door + 2, rd - bh - door)))
                    grid[by: by + bh, bx: bx + bw] = OCCUPIED
                x, k = x + rw + wall, k + 1
        y += band
    # Vertical halls cut through the room bands; reopen the corridor/room walls there.
    hall_x = wall + np.arange(rooms_between_halls, n, rooms_between_halls + 1) * (rw + wall)
    for hx in hall_x:
        if hx + rw <= n - wall:
            corridor_walls = np.all(grid[:, hx: hx + rw] == OCCUPIED, axis=1)
            grid[corridor_walls, hx: hx + rw] = FREE
    grid[:wall, :] = OCCUPIED
    grid[-wall:, :] = OCCUPIED
    grid[:, :wall] = OCCUPIED
    grid[:, -wall:] = OCCUPIED
    return grid


def first_free_cell_near(grid: np.ndarray, row: int, col: int) -> Tuple[int, int]:
    """The FREE cell closest to (row, col) (Euclidean in cells)."""
    rr, cc = np.nonzero(grid == FREE)
    if rr.size == 0:
        raise ValueError("grid has no free cell")
    k = int(np.argmin((rr - row) ** 2 + (cc - col) ** 2))
    return int(rr[k]), int(cc[k])


def partially_explored(
    truth: np.ndarray,
    center_rc: Tuple[int, int],
    radius_cells: float,
    seed: int = 0,
    unknown_rooms: int = 0,
    room_cells: int = 60,
) -> np.ndarray:
    """Copy of `truth` that is UNKNOWN outside a disc and inside `unknown_rooms` squares."""
    rng = np.random.default_rng(seed)
    h, w = truth.shape
    out = truth.copy()
    rows = np.arange(h)[:, None] - center_rc[0]
    cols = np.arange(w)[None, :] - center_rc[1]
    out[rows * rows + cols * cols > radius_cells * radius_cells] = UNKNOWN
    for _ in range(unknown_rooms):
        r0 = int(rng.integers(0, max(1, h - room_cells)))
        c0 = int(rng.integers(0, max(1, w - room_cells)))
        if abs(r0 + room_cells // 2 - center_rc[0]) + abs(c0 + room_cells // 2 - center_rc[1]) \
                < 2 * room_cells:
            continue                                   # keep the robot's surroundings known
        out[r0: r0 + room_cells, c0: c0 + room_cells] = UNKNOWN
    return out
