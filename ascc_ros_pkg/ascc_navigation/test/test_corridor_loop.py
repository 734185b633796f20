"""The mapper closes the corridor loop (thesis fig. 2.11; ascc_sim's corridor world, about
100 m x 25 m, a 242 m drive round it) within the correction bound. No ROS master: the
node's core (``SlamMapper``, config/gmapping.yaml but 10 particles to keep the test short
and every third beam, see ``_config``) is fed with scans of ascc_sim's URG-04LX model and
odometry of its wheel-encoder error model, one scan per filter update (about 1000 updates;
10-35 s per seed alone, up to 120 s under load). Three seeds: 7, and 1 and 4, on which
a wrong match along the corridor closed the loop before 2026-12-01 (see the test)."""

import math
import os

import numpy as np
import pytest
import yaml

from ascc_common.params import from_params, parameters
from ascc_common.pose2d import compose
from ascc_navigation import mapper as M
from ascc_navigation import synthetic as S
from ascc_navigation.grid import map_agreement
from ascc_navigation.laser import LaserMount

HERE = os.path.dirname(os.path.abspath(__file__))
NAV = os.path.dirname(HERE)
SIM = os.path.join(os.path.dirname(NAV), "ascc_sim")
# the loop (world frame): east along the south side, round, and 10 m past the start
ROUTE = [(5.0, 1.9), (98.1, 1.9), (98.1, 23.1), (1.9, 23.1), (1.9, 1.9), (15.0, 1.9)]


def _config():
    with open(os.path.join(NAV, "config", "gmapping.yaml")) as f:
        values = yaml.safe_load(f)
    known = {p.name for p in parameters(M.MapperConfig)}
    params = {k: v for k, v in values.items() if k in known}
    params["particles"] = 10
    params["loop_closure"] = True
    # The closure (opt-in, off by default) with the wall-axis prior of config/gmapping.yaml,
    # its heading measurements in the graph (loop_wall_headings), two agreeing matches
    # (loop_confirm, opt-in) and the direct solve (loop_solver's default). With the trust
    # region instead, Ubuntu 20.04's numpy and OpenCV made one closure double the keyframes'
    # mean error (0.124 -> 0.264 m); without the prior the direct solve's minimum turns the
    # loop's headings (0.19 -> 0.36 m): docs/results/ascc_navigation.md, "A direct solve
    # for the graph".
    params["loop_confirm"] = True
    # Every third beam keeps the test near half a minute; with all beams (the shipped
    # lskip 0) the closures pass as well (0.336 -> 0.130 m, Debian 12's libraries).
    params["lskip"] = 2
    return from_params(M.MapperConfig, params.get)


def _update_poses(traj, linear, angular):
    """Indices of the trajectory where the mapper updates (one scan each)."""
    keep = [0]
    travelled = turned = 0.0
    for k in range(1, traj.shape[0]):
        travelled += math.hypot(*(traj[k, :2] - traj[k - 1, :2]))
        turned += abs(math.remainder(traj[k, 2] - traj[k - 1, 2], 2 * math.pi))
        if travelled >= linear or turned >= angular:
            keep.append(k)
            travelled = turned = 0.0
    return np.array(keep)


@pytest.mark.parametrize("seed", [7, 1, 4])
def test_corridor_loop_closes_within_the_bound(seed):
    pytest.importorskip("ascc_sim")
    from ascc_sim.laser import LaserConfig, LaserModel
    from ascc_sim.world import load_world

    world = load_world(os.path.join(SIM, "worlds", "corridor.yaml"))
    with open(os.path.join(SIM, "config", "asccbot.yaml")) as f:
        robot = yaml.safe_load(f)
    mount = LaserMount(robot["laser_x_m"], robot["laser_y_m"],
                       math.radians(robot["laser_yaw_deg"]))
    laser_cfg = LaserConfig()
    laser = LaserModel(world.grid, laser_cfg, world.dropout)
    rng = np.random.default_rng(seed)
    traj = S.waypoint_trajectory(ROUTE, v=0.3, w=0.8, dt=0.1)
    odom = S.wheel_odometry(traj, rng, robot["wheel_base_m"], robot["encoder_scale_sigma"],
                            robot["encoder_noise_m_per_sqrt_m"])
    cfg = _config()
    assert cfg.loop.enabled and cfg.loop.solver == "direct" and cfg.rbpf.wall_axis_std_rad > 0
    mapper = M.SlamMapper(cfg, seed=seed)
    steps = _update_poses(traj, cfg.linear_update, cfg.angular_update)
    truth_kf, closed, before_after = [], [], []
    n_beams = laser_cfg.n_beams
    angle_min = laser_cfg.angle_min_rad
    increment = laser_cfg.angle_increment_rad
    for k in steps:
        lx, ly, lth = compose(traj[k], (mount.x, mount.y, mount.yaw))
        ranges = laser.scan(lx, ly, lth, world.circles, rng)
        assert len(ranges) == n_beams
        poses_before = mapper.graph.poses.copy()
        out = mapper.handle_scan(M.ScanInput(0.1 * k, ranges, angle_min, increment,
                                             laser_cfg.range_min_m, laser_cfg.range_max_m),
                                 odom[k], mount)
        assert out.status in (M.STARTED, M.UPDATED), out
        truth_kf.append(traj[k])
        if out.loop is not None and out.loop.status == "closed":
            closed.append(out.loop)
            truth = np.array(truth_kf)
            err = np.hypot(*(mapper.graph.poses[:, :2] - truth[:, :2]).T)
            old = np.hypot(*(poses_before[:, :2] - truth[:-1, :2]).T)
            before_after.append((old.mean(), err[:-1].mean()))
    assert closed, "the corridor loop did not close"
    # every applied closure stayed within the bound and did no harm: the trajectory
    # (keyframes vs the truth) no worse than before it by more than 5 cm. The filter
    # itself keeps this loop's error at 0.1-0.3 m. A right closure spreads the end's
    # error along the corridor over the loop's legs, which no corridor match tells apart,
    # and added up to 3 cm to the mean on seeds 1-10; a wrong match along the corridor,
    # confirmed by a second match that left that axis free, added 15-37 cm on 4 of seeds
    # 1-10 before each match of a pair kept only the axes both fix (2026-12-01). (This
    # test ran seed 7 alone then, with a 1 cm bound, which that seed's closures kept.) A
    # match pulled 0.7 m along the corridor by end points where the submap never looked,
    # confirmed by a right one that fixed both axes, added 7.6 cm (seed 4, Ubuntu 20.04's
    # libraries, prior_along_adaptive on) before a loop match scored only what the submap
    # saw; since then, 2.1 cm at most on seeds 1-10 with either library set and either
    # prior (docs/results/ascc_navigation.md).
    # That a closure removes a known drift is test_posegraph.py's test (0.318 -> 0.105 m).
    assert all(r.correction_m <= cfg.loop.max_correction_m for r in closed)
    assert all(after <= before + 0.05 for before, after in before_after), before_after
    # the loop's end: map -> odom -> base near the truth, map close to the floor plan
    end = compose(mapper.map_to_odom(), odom[steps[-1]])
    assert math.hypot(end[0] - traj[steps[-1], 0], end[1] - traj[steps[-1], 1]) < 0.2
    grid, info = mapper.occupancy()
    truth_map = world.truth_map
    acc = map_agreement(grid, info, truth_map.occupancy, truth_map.info)
    assert acc["accuracy"] > 0.92, acc
