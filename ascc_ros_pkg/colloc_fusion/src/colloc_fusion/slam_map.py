"""A map of the colloc office built by the SLAM stand-in, in its own frame (no ROS).

As on the real robots: before the experiment one robot drives through the office with
the mapper (ascc_navigation's gmapping stand-in, config/gmapping.yaml) and the map is
saved; its ``map`` frame is where that robot started, so the calibration of thesis 3.4.1
(truth/Vicon -> map, from the desk corners) is no longer the identity. Here the drive is
simulated offline: ascc_sim's laser model scans the world (walls, furniture, legs; no
cone, no other robot: they were not there when the office was mapped) along a waypoint
route, with ascc_sim's wheel-odometry error model starting at zero.
"""
from __future__ import annotations

from typing import Sequence, Tuple

import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import from_params
from ascc_common.pose2d import compose, inverse
from ascc_navigation import mapper as M
from ascc_navigation import synthetic as S
from ascc_sim.laser import LaserConfig, LaserModel

from .calibration import Rigid2D
from .landmarks import calibrate, measure
from .still_localization import LASER_MOUNT

SCAN_PERIOD_S = 0.1  # [s] the URG-04LX
FEED_EVERY = 2  # every 2nd scan to the mapper (5 Hz, as the node's timer keeps up)
# a loop through the three_robots office (8.5 m x 7 m), clear of the desks, and back
OFFICE_ROUTE = [(2.2, 3.6), (2.6, 1.3), (6.4, 1.3), (6.9, 3.2), (6.3, 5.3), (2.6, 5.3),
                (2.2, 3.6), (2.6, 1.3), (4.4, 1.6)]


def build_map(world, mapper_params: dict, seed: int = 0,
              route: Sequence[Tuple[float, float]] = OFFICE_ROUTE, wheel_base_m: float = 0.258,
              encoder_scale_sigma: float = 0.003, encoder_noise: float = 0.004
              ) -> Tuple[np.ndarray, GridInfo, np.ndarray]:
    """Drives ``route`` in ``world`` (an ascc_sim World) with the mapper; returns the
    best particle's grid (-1/0/100), its GridInfo (in the map frame) and the true pose of
    the map frame's origin in the world (the robot's start)."""
    rng = np.random.default_rng(seed)
    cfg = LaserConfig()
    laser = LaserModel(world.grid, cfg, world.dropout)
    circles = np.concatenate([o.circles for o in world.objects
                              if len(o.circles) and o.type != "cone"] or [np.zeros((0, 3))])
    traj = S.waypoint_trajectory(list(route), v=0.3, w=0.8, dt=SCAN_PERIOD_S)
    odom_world = S.wheel_odometry(traj, rng, wheel_base_m, encoder_scale_sigma, encoder_noise)
    start = traj[0].copy()
    to_start = inverse(start)
    mapper = M.SlamMapper(from_params(M.MapperConfig, mapper_params.get), seed=seed)
    for k in range(0, len(traj), FEED_EVERY):
        lx, ly, lth = compose(traj[k], (LASER_MOUNT.x, LASER_MOUNT.y, LASER_MOUNT.yaw))
        ranges = laser.scan(lx, ly, lth, circles, rng)
        scan = M.ScanInput(k * SCAN_PERIOD_S, ranges, cfg.angle_min_rad,
                           cfg.angle_increment_rad, cfg.range_min_m, cfg.range_max_m)
        mapper.handle_scan(scan, compose(to_start, odom_world[k]), LASER_MOUNT)
    grid, info = mapper.occupancy()
    return grid, info, start


def truth_to_map(start: Sequence[float]):
    """The exact truth -> map transform (theta, tx, ty) of a map started at ``start``."""
    x, y, th = inverse(start)
    return th, x, y


def calibrated_map(world, mapper_params: dict, seed: int = 0):
    """``build_map`` and the calibration of thesis 3.4.1 in it: the world's ``landmark``
    objects (desk corners) measured in the SLAM map (landmarks.measure; the rough guesses
    are the corners moved by the exact transform, as a person would click them) and the
    truth -> map transform fitted to them. Returns (grid, info, fit, exact, failed): the
    fit (Rigid2D with its residuals), the exact transform (Rigid2D) and the corners that
    could not be measured with why."""
    grid, info, start = build_map(world, mapper_params, seed=seed)
    exact = Rigid2D(*truth_to_map(start), np.zeros(0))
    truth = {o.name: (o.pose.x, o.pose.y) for o in world.objects if o.type == "landmark"}
    found, failed = measure(grid, info, {n: exact.apply(np.array(p)) for n, p in truth.items()})
    fit, _ = calibrate(truth, found)
    return grid, info, fit, exact, failed


def describe(seed: int, fit: Rigid2D, exact: Rigid2D, failed: dict, world, path: str) -> str:
    """Two lines on a calibrated SLAM map: the fit, its residuals, its error."""
    corners = np.array([(o.pose.x, o.pose.y) for o in world.objects
                        if o.type == "landmark" and o.name not in failed])
    moved = np.hypot(*(fit.apply(corners) - exact.apply(corners)).T)
    start = inverse((exact.tx, exact.ty, exact.theta))
    return ("SLAM map %s (mapper seed %d, drive started at true (%.2f, %.2f, %.2f))%s\n"
            "calibration truth -> map from %d corners: theta %.4f rad, t (%.3f, %.3f) m; "
            "residuals %s m, rms %.3f m; against the exact transform: %.4f rad, the corners "
            "moved %.3f m (mean)"
            % (path, seed, start[0], start[1], start[2],
               ("; not found: %s" % failed) if failed else "", len(corners), fit.theta,
               fit.tx, fit.ty, np.round(fit.residuals_m, 3).tolist(), fit.rms_m,
               fit.theta - exact.theta, moved.mean()))
