"""How well does amcl localise a robot that stands still? (no ROS; the benchmark's robots)

The colloc_fusion robots are placed and never move: amcl (here the ascc_navigation
stand-in) starts from the placement with its initial covariance and gets one update from
the first scan plus ``nomotion_updates`` no-motion updates (``request_nomotion_update``).
This replays that offline for a placement: the simulator's laser model (ascc_sim: the
world's grid, its circles and the other robots, noise and dropouts) scans from the true
pose, the filter runs with the parameters of config/amcl.yaml, and the pose error of the
cloud's mean and of the scan-matched refinement (``MclParams.refine_estimate``) is
returned for each robot. Both come from the same filter run (the refinement is not fed
back), so the comparison is paired.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, Optional

import numpy as np

from ascc_common.pose2d import wrap_angle
from ascc_navigation import mcl
from ascc_navigation.laser import LaserMount
from ascc_sim.laser import LaserConfig, LaserModel

from .bench import Placement
from .calibration import Rigid2D

LASER_MOUNT = LaserMount(0.05, 0.0, 0.0)  # ascc_sim's default laser mount in base_link
ROBOT_RADIUS_M = 0.165  # the other robots seen by the laser (ascc_sim default)
INITIAL_COV = np.diag([0.25, 0.25, 0.0685])  # config/amcl.yaml initial_cov_xx/yy/aa


def still_robot_errors(world, placement: Placement, params: mcl.MclParams,
                       nomotion_updates: int = 10, seed: int = 0,
                       initial_cov: Optional[np.ndarray] = None, amcl_map=None,
                       to_map: Optional[Rigid2D] = None, judge_map: Optional[Rigid2D] = None
                       ) -> Dict[str, Dict[str, np.ndarray]]:
    """For each robot of ``placement`` in ``world`` (an ascc_sim World with the placement's
    cone): {"mcl": (dx, dy, dyaw), "refined": (dx, dy, dyaw)}, the final estimate minus
    the true pose [m, m, rad], after 1 + ``nomotion_updates`` filter updates.

    amcl's map is the world's ground-truth grid, or ``amcl_map`` = (occupancy, GridInfo)
    (e.g. slam_map.build_map's) with ``to_map`` the truth -> map transform (the landmark
    calibration): it places the robots' initial poses in that map and the true poses the
    errors are taken against (so they include the calibration's error), unless
    ``judge_map`` (e.g. the exact transform) is given for the latter."""
    rng = np.random.default_rng(seed)
    cfg = LaserConfig()
    laser = LaserModel(world.grid, cfg, world.dropout)
    occ, info = amcl_map if amcl_map is not None else (world.truth_map.occupancy,
                                                       world.truth_map.info)
    to_map = to_map if to_map is not None else Rigid2D(0.0, 0.0, 0.0, np.zeros(0))
    field = mcl.LikelihoodField(occ, info, params.laser_sigma_hit, params.laser_z_hit,
                                params.laser_z_rand, params.laser_likelihood_max_dist,
                                cfg.range_max_m)
    refine = replace(params, refine_estimate=True)
    cov = INITIAL_COV if initial_cov is None else initial_cov
    out = {}
    for name, pose in placement.robots.items():
        others = [(p[0], p[1], ROBOT_RADIUS_M) for n, p in placement.robots.items()
                  if n != name]
        circles = np.concatenate([world.circles, np.array(others).reshape(-1, 3)])
        c, s = np.cos(pose[2]), np.sin(pose[2])
        lx, ly = pose[0] + c * LASER_MOUNT.x, pose[1] + s * LASER_MOUNT.x
        loc = mcl.MonteCarloLocalizer(field, refine, rng)
        loc.initialize_gaussian(to_map.apply_pose(pose), cov)
        truth = (judge_map or to_map).apply_pose(pose)
        odom = np.zeros(3)  # odometry of a robot that does not move
        pts = many = np.zeros((0, 2))
        for k in range(1 + nomotion_updates):
            ranges = laser.scan(lx, ly, pose[2], circles, rng)
            pts = mcl.scan_endpoints(ranges, cfg.angle_min_rad, cfg.angle_increment_rad,
                                     LASER_MOUNT, cfg.range_min_m, cfg.range_max_m,
                                     params.laser_max_beams)
            many = mcl.scan_endpoints(ranges, cfg.angle_min_rad, cfg.angle_increment_rad,
                                      LASER_MOUNT, cfg.range_min_m, cfg.range_max_m,
                                      refine.refine_max_beams)
            if k:
                loc.request_nomotion_update()
            loc.process(odom, pts)
        plain, _ = loc.estimate()
        refined, _ = loc.refined_estimate(many)
        out[name] = {k: np.array([v[0] - truth[0], v[1] - truth[1],
                                  float(wrap_angle(v[2] - truth[2]))])
                     for k, v in (("mcl", plain), ("refined", refined))}
    return out
