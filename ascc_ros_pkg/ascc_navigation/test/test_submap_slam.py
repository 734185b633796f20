"""Tests of the particle-free front end (``submap_slam``, ``frontend: submap``) without a
ROS master."""

import math

import numpy as np
import pytest

from ascc_common import pose2d as P
from ascc_common.grid import OCCUPIED
from ascc_common.params import from_params
from ascc_navigation import grid as G
from ascc_navigation import mapper as M
from ascc_navigation import submap_slam as F
from ascc_navigation import synthetic as S
from ascc_navigation.laser import LaserMount

SPEC = S.LaserSpec()
MOUNT = LaserMount(0.05, 0.0, 0.0)


def _scan_input(stamp, ranges):
    return M.ScanInput(stamp, ranges, SPEC.angle_min, SPEC.angle_increment, SPEC.range_min,
                       SPEC.range_max)


def _mapper(**params):
    base = {"frontend": "submap", "xmin": 0.0, "ymin": 0.0, "xmax": 6.0, "ymax": 4.0,
            "linearUpdate": 0.25, "angularUpdate": 0.25, "maxUrange": 3.9, "maxRange": 4.5}
    base.update(params)
    return M.SlamMapper(from_params(M.MapperConfig, base.get), seed=0)


def _run_office(mapper, seed=7, every=2, odometry=S.noisy_odometry):
    truth, tinfo = S.office_world()
    rng = np.random.default_rng(seed)
    traj = S.waypoint_trajectory(S.office_loop_waypoints()[:6])
    odom = odometry(traj, rng)
    for k in range(0, traj.shape[0], every):
        scan = S.simulate_scan(truth == OCCUPIED, tinfo, traj[k], MOUNT, SPEC, rng)
        out = mapper.handle_scan(_scan_input(0.1 * k, scan), odom[k], MOUNT)
        assert out.status in (M.STARTED, M.UPDATED, M.SKIPPED), out.reason
    return traj, odom, k, truth, tinfo


def test_the_frontend_parameter_selects_the_particle_free_mapper():
    assert isinstance(_mapper().slam, F.SubmapSlam)
    assert not isinstance(_mapper(frontend="rbpf").slam, F.SubmapSlam)
    with pytest.raises(ValueError, match="frontend"):
        _mapper(frontend="particles")


@pytest.mark.parametrize("seed", [7, 8])
def test_mapping_a_loop_of_the_synthetic_office(seed):
    """Drifting odometry (synthetic's defaults: 1 % scale, 3 % noise, a heading bias),
    noisy scans: the map agrees with the truth, the pose through map -> odom stays far
    closer than the odometry's, and the map grows beyond its start."""
    mapper = _mapper()
    traj, odom, k, truth, tinfo = _run_office(mapper, seed)
    est, einfo = mapper.occupancy()
    res = G.map_agreement(est, einfo, truth, tinfo)
    assert res["accuracy"] >= 0.95, res
    assert einfo.xmax > 6.0 and einfo.ymax > 4.0
    final = P.compose(mapper.map_to_odom(), odom[k])
    error = math.hypot(*(final[:2] - traj[k][:2]))
    assert error < 0.1
    assert error < 0.5 * math.hypot(*(odom[k][:2] - traj[k][:2]))
    # one pose per update, the last one the mapper's
    path = mapper.slam.trajectory()
    assert path.shape == (mapper.slam.updates, 3)
    assert np.allclose(path[-1], mapper.robot_pose())


def test_the_walls_heading_measurement_holds_a_drifting_heading():
    """The odometry's heading drifts 0.04 rad per metre (four times synthetic's default)
    in the office loop: with the walls' heading the estimate's heading stays within a few
    milliradians; without it (``submap_wall_std_rad`` 0) it follows more of the drift."""
    def drifting(traj, rng):
        return S.noisy_odometry(traj, rng, rot_bias=0.04)

    errors = {}
    for std in (0.002, 0.0):
        mapper = _mapper(submap_wall_std_rad=std)
        traj, odom, k, _, _ = _run_office(mapper, 3, odometry=drifting)
        errors[std] = abs(P.wrap_angle(mapper.robot_pose()[2] - traj[k][2]))
    assert errors[0.002] < 0.005, errors
    assert errors[0.002] < errors[0.0], errors


def test_odometry_covariance_is_along_and_across_the_motion():
    cfg = F.SubmapConfig()
    cov = F.odometry_covariance(np.array([0.0, 0.25, 0.0]), math.pi / 2, cfg)
    along = cfg.odom_along_m + cfg.odom_along_per_m * 0.25
    across = cfg.odom_across_m + cfg.odom_across_per_m * 0.25
    # heading pi/2, motion to the robot's left: along the motion is -x in the map
    assert cov[0, 0] == pytest.approx(along ** 2)
    assert cov[1, 1] == pytest.approx(across ** 2)
    assert abs(cov[0, 1]) < 1e-12
    turn = F.odometry_covariance(np.array([0.0, 0.0, 0.5]), 0.0, cfg)
    assert math.sqrt(turn[2, 2]) == pytest.approx(cfg.odom_heading_rad
                                                  + 0.5 * cfg.odom_heading_per_rad)


def test_gaussian_entropy_grows_with_the_covariance():
    small = F.gaussian_entropy(np.diag([1e-4, 1e-4, 1e-5]))
    large = F.gaussian_entropy(np.diag([1e-2, 1e-4, 1e-5]))
    assert large - small == pytest.approx(0.5 * math.log(100.0))


def test_a_scan_without_returns_keeps_the_odometry_and_the_mapper_running():
    mapper = _mapper()
    truth, tinfo = S.office_world()
    rng = np.random.default_rng(0)
    p0 = np.array([2.0, 2.0, 0.0])
    scan = S.simulate_scan(truth == OCCUPIED, tinfo, p0, MOUNT, SPEC, rng)
    assert mapper.handle_scan(_scan_input(0.0, scan), p0, MOUNT).status == M.STARTED
    p1 = p0 + [0.3, 0.0, 0.0]
    empty = np.full(len(scan), np.inf)
    out = mapper.handle_scan(_scan_input(0.1, empty), p1, MOUNT)
    assert out.status == M.UPDATED and "odometry only" in out.reason
    assert np.allclose(mapper.robot_pose(), p1)
