"""Synthetic worlds, trajectories, noisy odometry and URG-04LX-like scans for tests and
benchmarks of the navigation stand-ins (no ROS imports).

The world is an int8 -1/0/100 grid built from rectangles; scans are ray-cast on it with
``grid.raycast``. Everything is seeded, so a test or benchmark run is reproducible.
"""

from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.grid import FREE, OCCUPIED, GridInfo
from ascc_common.pose2d import compose, relative, wrap_angle
from ascc_navigation.grid import raycast
from ascc_navigation.laser import LaserMount

# Hokuyo URG-04LX as in the thesis (section 2.2): 240 deg field of view, 0.36 deg steps
# (683 beams over 240 deg: the scanner's 1024 steps per revolution), 0.02 .. 4.094 m.
URG_FOV_RAD = math.radians(240.0)
URG_INCREMENT_RAD = 2.0 * math.pi / 1024.0
URG_RANGE_MIN_M = 0.02
URG_RANGE_MAX_M = 4.094


class LaserSpec:
    """Geometry of a simulated planar laser scan (LaserScan fields, SI units)."""

    def __init__(self, fov: float = URG_FOV_RAD, increment: float = URG_INCREMENT_RAD,
                 range_min: float = URG_RANGE_MIN_M, range_max: float = URG_RANGE_MAX_M):
        self.n = int(math.floor(fov / increment + 1e-6)) + 1  # beams within the field of view
        self.angle_min = -0.5 * (self.n - 1) * increment
        self.angle_increment = increment
        self.range_min = range_min
        self.range_max = range_max

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(self.n)


def rect_world(size_xy: Tuple[float, float], resolution: float,
               walls: Sequence[Tuple[float, float, float, float]]) -> Tuple[np.ndarray, GridInfo]:
    """Grid of ``size_xy`` [m] (origin at 0, 0): free, with occupied rectangles
    ``(x0, y0, x1, y1)`` [m]. The outermost ring of cells is occupied (a closed world)."""
    info = GridInfo.from_bounds(resolution, 0.0, 0.0, size_xy[0], size_xy[1])
    grid = np.full(info.shape, FREE, dtype=np.int8)
    for x0, y0, x1, y1 in walls:
        ix0, iy0 = info.world_to_cell(x0, y0)
        ix1, iy1 = info.world_to_cell(x1 - 1e-9, y1 - 1e-9)
        grid[max(int(iy0), 0): int(iy1) + 1, max(int(ix0), 0): int(ix1) + 1] = OCCUPIED
    grid[[0, -1], :] = OCCUPIED
    grid[:, [0, -1]] = OCCUPIED
    return grid, info


def office_world(resolution: float = 0.05) -> Tuple[np.ndarray, GridInfo]:
    """A 14 m x 10 m office floor: a corridor loop around a central block, three rooms on the
    north side with doors, furniture and pillars. The loop (about 30 m) is driven by
    ``office_loop_waypoints``."""
    t = 0.1  # wall thickness [m]
    walls = [
        # outer shell
        (0.0, 0.0, 14.0, t), (0.0, 10.0 - t, 14.0, 10.0), (0.0, 0.0, t, 10.0),
        (14.0 - t, 0.0, 14.0, 10.0),
        # central block (the loop goes around it): x 3..11, y 3..5.5
        (3.0, 3.0, 11.0, 5.5),
        # rooms along the north, wall at y = 7.5 with doors
        (0.0, 7.5, 2.5, 7.5 + t), (3.5, 7.5, 6.5, 7.5 + t), (7.5, 7.5, 10.5, 7.5 + t),
        (11.5, 7.5, 14.0, 7.5 + t),
        (5.0, 7.5, 5.0 + t, 10.0), (9.5, 7.5, 9.5 + t, 10.0),
        # furniture in the rooms and corridor features
        (1.0, 8.6, 2.2, 9.4), (6.0, 8.8, 7.0, 9.5), (11.0, 8.3, 12.5, 9.0),
        (7.0, 0.8, 7.4, 1.2), (12.3, 1.5, 12.7, 1.9), (1.2, 4.0, 1.6, 4.4),
        # wall pilasters along the south corridor and the block (what real corridors have)
        (3.5, 0.0, 3.7, 0.35), (5.5, 0.0, 5.7, 0.35), (9.0, 0.0, 9.2, 0.35),
        (10.5, 0.0, 10.7, 0.35), (5.0, 2.8, 5.2, 3.0), (8.5, 2.8, 8.7, 3.0),
    ]
    return rect_world((14.0, 10.0), resolution, walls)


def office_loop_waypoints() -> List[Tuple[float, float]]:
    """A closed loop around the central block of ``office_world``, peeking into a room."""
    return [(2.0, 2.0), (6.0, 2.0), (9.5, 1.9), (12.0, 2.5), (12.2, 6.5), (8.0, 6.5),
            (8.0, 8.4), (8.3, 6.5), (4.0, 6.5), (2.0, 6.5), (1.8, 4.0), (2.0, 2.0), (5.0, 2.0)]


def waypoint_trajectory(waypoints: Sequence[Tuple[float, float]], v: float = 0.3,
                        w: float = 0.8, dt: float = 0.1) -> np.ndarray:
    """True poses (T, 3) every ``dt`` [s]: turn in place at ``w`` [rad/s] towards each
    waypoint, then drive straight at ``v`` [m/s]. Starts at the first waypoint facing the
    second."""
    wp = np.asarray(waypoints, dtype=float)
    heading = math.atan2(wp[1, 1] - wp[0, 1], wp[1, 0] - wp[0, 0])
    poses = [(wp[0, 0], wp[0, 1], heading)]
    for (x0, y0), (x1, y1) in zip(wp[:-1], wp[1:]):
        target = math.atan2(y1 - y0, x1 - x0)
        turn = float(wrap_angle(target - heading))
        k = max(int(math.ceil(abs(turn) / (w * dt))), 1)
        for i in range(1, k + 1):  # per time step, not per beam or cell
            poses.append((x0, y0, float(wrap_angle(heading + turn * i / k))))
        heading = target
        dist = math.hypot(x1 - x0, y1 - y0)
        k = max(int(math.ceil(dist / (v * dt))), 1)
        s = np.arange(1, k + 1) / k
        poses.extend(zip(x0 + s * (x1 - x0), y0 + s * (y1 - y0), np.full(k, heading)))
    return np.asarray(poses, dtype=float)


def noisy_odometry(true_poses: np.ndarray, rng: np.random.Generator,
                   trans_noise: float = 0.03, rot_noise: float = 0.03,
                   scale_error: float = 0.01, rot_bias: float = 0.01) -> np.ndarray:
    """Odometry poses that drift like wheel odometry: each true increment is scaled by
    (1 + scale_error), gets a rotation bias of ``rot_bias`` [rad per m], and Gaussian noise
    (std ``trans_noise`` per metre, ``rot_noise`` per radian + per metre); increments are
    integrated from the first true pose."""
    inc = relative(true_poses[:-1], true_poses[1:])
    dist = np.hypot(inc[:, 0], inc[:, 1])
    turn = np.abs(inc[:, 2])
    noisy = inc.copy()
    noisy[:, :2] *= (1.0 + scale_error)
    noisy[:, 0] += trans_noise * dist * rng.standard_normal(dist.size)
    noisy[:, 1] += 0.3 * trans_noise * dist * rng.standard_normal(dist.size)
    noisy[:, 2] += rot_bias * dist + rot_noise * (turn + dist) * rng.standard_normal(dist.size)
    odom = np.empty_like(true_poses)
    odom[0] = true_poses[0]
    for i in range(inc.shape[0]):  # sequential integration along the trajectory
        odom[i + 1] = compose(odom[i], noisy[i])
    return odom


def wheel_odometry(true_poses: np.ndarray, rng: np.random.Generator,
                   wheel_base: float = 0.258, scale_sigma: float = 0.003,
                   noise_k: float = 0.004, scale: Optional[np.ndarray] = None,
                   angle_unit_rad: float = 0.0) -> np.ndarray:
    """Odometry of a differential drive from noisy wheel encoders, the error model of
    ascc_sim (``config/asccbot.yaml``): each wheel's travel is scaled by a calibration error
    drawn once (std ``scale_sigma``; or the given (left, right) ``scale``, and then nothing
    is drawn for it) plus noise of std ``noise_k`` * sqrt(|travel|) [m]; increments are
    integrated on arcs from the first true pose. ``wheel_base`` [m]. ``angle_unit_rad`` > 0:
    the turn is reported in whole units, the remainder carried to the next step, as the
    Create 1's angle packet (whole degrees: ``math.radians(1)``) in ascc_sim's virtual
    Create; the odometry's heading then lags its own by up to one unit."""
    inc = relative(true_poses[:-1], true_poses[1:])
    forward = inc[:, 0]
    half_turn = 0.5 * wheel_base * inc[:, 2]
    wheels = np.stack([forward - half_turn, forward + half_turn], axis=1)  # left, right
    if scale is None:
        scale = 1.0 + scale_sigma * rng.standard_normal(2)
    wheels = wheels * scale + noise_k * np.sqrt(np.abs(wheels)) * rng.standard_normal(
        wheels.shape)
    dist = wheels.mean(axis=1)
    turn = (wheels[:, 1] - wheels[:, 0]) / wheel_base
    if angle_unit_rad > 0.0:
        carried = 0.0
        for i in range(turn.size):  # sequential: each report carries the last remainder
            carried += turn[i]
            turn[i] = math.trunc(carried / angle_unit_rad) * angle_unit_rad
            carried -= turn[i]
    noisy = np.stack([dist * np.cos(0.5 * turn), dist * np.sin(0.5 * turn), turn], axis=1)
    odom = np.empty_like(true_poses)
    odom[0] = true_poses[0]
    for i in range(noisy.shape[0]):  # sequential integration along the trajectory
        odom[i + 1] = compose(odom[i], noisy[i])
    return odom


def simulate_scan(occupied: np.ndarray, info: GridInfo, pose, mount: LaserMount,
                  spec: LaserSpec, rng: np.random.Generator,
                  noise_std: float = 0.01) -> np.ndarray:
    """Ranges [m] of one scan from robot pose (x, y, theta) with the laser at ``mount``;
    +inf where nothing is within range_max (REP 117 'no return')."""
    lx, ly, lth = compose(pose, (mount.x, mount.y, mount.yaw))
    angles = spec.angles()
    world_angles = lth - angles if mount.upside_down else lth + angles
    r = raycast(occupied, info, lx, ly, world_angles, spec.range_max)
    r = r + noise_std * rng.standard_normal(r.size)
    r[r > spec.range_max] = np.inf
    return r

