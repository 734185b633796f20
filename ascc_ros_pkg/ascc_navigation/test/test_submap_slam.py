"""Tests of the particle-free front end (``submap_slam``, ``frontend: submap``) without a
ROS master."""

import math

import cv2
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


def _still_start(mapper, seed, still_scans, p0=(2.0, 2.0, 0.3)):
    """``still_scans`` noisy scans from the start pose (the odometry unchanged), then one
    0.3 m on; returns the scans' world and the start pose."""
    truth, tinfo = S.office_world()
    rng = np.random.default_rng(seed)
    p0 = np.asarray(p0, dtype=float)
    for k in range(still_scans):
        scan = S.simulate_scan(truth == OCCUPIED, tinfo, p0, MOUNT, SPEC, rng)
        out = mapper.handle_scan(_scan_input(0.1 * k, scan), p0, MOUNT)
        assert out.status == (M.STARTED if k == 0 else M.SKIPPED), out.reason
    return truth, tinfo, rng, p0


def _reference_mapper(frontend, scans):
    if frontend == "submap":
        return _mapper(submap_wall_reference_scans=scans)
    return _mapper(frontend="rbpf", particles=5, wall_axis_std_rad=0.01,
                   wall_axis_reference_scans=scans)


@pytest.mark.parametrize("frontend", ["submap", "rbpf"])
def test_the_walls_reference_is_the_mean_of_the_scans_before_the_robot_moves(frontend):
    """One scan's walls' direction is noisy: over six seeds (the same start pose) the
    first scan's alone scatters; the mean of the scans taken before the robot first moves
    scatters far less (what stays is the synthetic ray caster's own bias of the walls'
    direction, the same in every scan). The robot's first motion ends the averaging. The
    same for the filter's wall-axis prior (``wall_axis_reference_scans``)."""
    errors = {1: [], 30: []}
    for cap in errors:
        for seed in range(6):
            mapper = _reference_mapper(frontend, cap)
            truth, tinfo, rng, p0 = _still_start(mapper, seed, 40)
            slam = mapper.slam
            assert slam.reference_scans == cap
            errors[cap].append(float(F.wrap_right_angle(slam.wall_reference)))
    assert np.std(errors[30]) < 0.5 * np.std(errors[1]), errors
    # once it has moved, scans from the start pose are not averaged any more
    mapper = _reference_mapper(frontend, 30)
    truth, tinfo, rng, p0 = _still_start(mapper, 0, 5)
    p1 = p0 + [0.3, 0.0, 0.0]
    scan = S.simulate_scan(truth == OCCUPIED, tinfo, p1, MOUNT, SPEC, rng)
    assert mapper.handle_scan(_scan_input(1.0, scan), p1, MOUNT).status == M.UPDATED
    reference = mapper.slam.wall_reference
    for k in range(3):
        scan = S.simulate_scan(truth == OCCUPIED, tinfo, p1, MOUNT, SPEC, rng)
        assert mapper.handle_scan(_scan_input(1.1 + 0.1 * k, scan), p1,
                                  MOUNT).status == M.SKIPPED
    assert mapper.slam.reference_scans == 5
    assert mapper.slam.wall_reference == reference


def test_a_match_far_outside_the_prediction_covariance_is_left_out():
    """The odometry says the robot moved 0.3 m along x and claims 15 mm of uncertainty;
    the scan says it also moved 0.15 m sideways. The match is far outside
    the prediction's covariance: left out (``submap_match_gate``), the pose follows the
    odometry; with the gate off the match moves the pose towards the scans."""
    tight = {"submap_odom_along_m": 0.015, "submap_odom_along_per_m": 0.0,
             "submap_odom_across_m": 0.015, "submap_odom_across_per_m": 0.0}
    poses = {}
    for gate in (16.27, 0.0):
        mapper = _mapper(submap_match_gate=gate, **tight)
        truth, tinfo, rng, p0 = _still_start(mapper, 1, 1, p0=(2.0, 2.0, 0.0))
        odom = p0 + [0.3, 0.0, 0.0]
        scan = S.simulate_scan(truth == OCCUPIED, tinfo, p0 + [0.3, 0.15, 0.0], MOUNT, SPEC,
                               rng)
        assert mapper.handle_scan(_scan_input(1.0, scan), odom, MOUNT).status == M.UPDATED
        poses[gate] = (mapper.robot_pose(), mapper.slam.gated_matches)
    pose, gated = poses[16.27]
    assert gated == 1
    assert abs(pose[1] - 2.0) < 0.01, pose
    pose, gated = poses[0.0]
    assert gated == 0
    assert pose[1] - 2.0 > 0.04, pose


def test_the_chord_takes_the_odometrys_distance_along_the_fused_turn():
    heading = 0.4
    # an arc of 0.3 m turning 0.1 rad: its chord leaves at half the turn
    arc = np.array([0.3 * math.cos(0.05), 0.3 * math.sin(0.05), 0.1])
    same = F.chord(arc, heading, 0.1)
    assert np.allclose(same, P.compose((0.0, 0.0, heading), arc)[:2])
    # the odometry turned 0.1 rad, the fused estimate not at all: straight on, same length
    straight = F.chord(arc, heading, 0.0)
    assert np.allclose(straight, 0.3 * np.array([math.cos(heading), math.sin(heading)]))
    # backwards: still along the heading's line, behind
    back = F.chord(np.array([-0.2, 0.0, 0.0]), heading, 0.0)
    assert np.allclose(back, -0.2 * np.array([math.cos(heading), math.sin(heading)]))
    assert np.allclose(F.chord(np.array([0.0, 0.0, 0.5]), heading, 0.3), 0.0)


def _bare_slam(**cfg):
    slam = F.SubmapSlam(F.SubmapConfig(**cfg), 0.05, 0.25, (0.0, 0.0, 4.0, 4.0), 1.0)
    slam.wall_references = [0.0]
    return slam


def test_walls_off_every_reference_become_one_after_enough_agreeing_scans():
    slam = _bare_slam(wall_learn_scans=5, wall_learn_tol_rad=0.01)
    rng = np.random.default_rng(0)
    skew = 0.3  # rad, walls 17 degrees off the start's
    for _ in range(4):
        slam._learn(skew + 0.002 * rng.standard_normal())
    assert slam.wall_references == [0.0]
    slam._learn(skew + 0.002 * rng.standard_normal())
    assert len(slam.wall_references) == 2
    assert slam.wall_references[1] == pytest.approx(skew, abs=0.003)
    # the same direction again (modulo a right angle) is known now: nothing new
    for _ in range(10):
        slam._learn(skew - math.pi / 2 + 0.002 * rng.standard_normal())
    assert len(slam.wall_references) == 2


def test_a_disagreeing_scan_restarts_the_direction_being_learned():
    slam = _bare_slam(wall_learn_scans=3, wall_learn_tol_rad=0.01)
    for direction in (0.2, 0.2, 0.25, 0.25, 0.25):
        slam._learn(direction)
    # 0.2 twice, then 0.25 (off by 50 mrad) restarted it: 0.25 three times learned
    assert slam.wall_references == [0.0, pytest.approx(0.25)]


def _skewed_wing(angle=0.3):
    """A 4 m x 3 m room with walls along the axes, its east door opening on a 2 m wide
    corridor whose walls run at ``angle`` [rad] for 9 m; and the route: across the room,
    through the door, along the corridor."""
    truth, tinfo = S.rect_world((16.0, 10.0), 0.05, [
        (0.0, 0.0, 16.0, 1.0), (0.0, 4.0, 16.0, 10.0),  # the room's floor: y 1..4
        (4.0, 0.0, 4.5, 2.0), (4.0, 3.0, 4.5, 10.0),  # its east wall, a door at y 2..3
        (4.5, 0.0, 16.0, 10.0)])  # solid beyond, but for the corridor
    c, s = math.cos(angle), math.sin(angle)
    start = np.array([4.5, 2.5])
    floor = np.array([start + t * np.array([c, s]) + w * np.array([-s, c])
                      for t, w in ((0.0, -1.0), (9.0, -1.0), (9.0, 1.0), (0.0, 1.0))])
    cells = np.round((floor - [tinfo.origin_x, tinfo.origin_y]) / tinfo.resolution - 0.5)
    cv2.fillPoly(truth, [cells.astype(np.int32)], 0)  # FREE
    end = start + 8.0 * np.array([c, s])
    route = [(1.0, 2.5), (4.3, 2.5), tuple(start + 0.5 * np.array([c, s])), tuple(end)]
    return truth, tinfo, route


@pytest.mark.parametrize("seed", [1, 2])
def test_a_learned_wall_direction_holds_the_heading_along_a_skewed_wing(seed):
    """The odometry's heading drifts 0.04 rad per metre; after an axis-aligned room the
    robot drives 8 m along a corridor 0.3 rad off the room's walls, where the start's
    reference is gated out. With its walls learned as a direction of their own the
    heading error at the end is smaller than with the chain of matches alone
    (``submap_wall_learn_scans`` 0)."""
    truth, tinfo, route = _skewed_wing()
    errors = {}
    for learn in (10, 0):
        mapper = _mapper(submap_wall_learn_scans=learn, xmax=16.0, ymax=10.0)
        rng = np.random.default_rng(seed)
        traj = S.waypoint_trajectory(route)
        odom = S.noisy_odometry(traj, rng, rot_bias=0.04)
        for k in range(0, traj.shape[0], 2):
            scan = S.simulate_scan(truth == OCCUPIED, tinfo, traj[k], MOUNT, SPEC, rng)
            out = mapper.handle_scan(_scan_input(0.1 * k, scan), odom[k], MOUNT)
            assert out.status in (M.STARTED, M.UPDATED, M.SKIPPED), out.reason
        errors[learn] = abs(P.wrap_angle(mapper.robot_pose()[2] - traj[k][2]))
        if learn:
            assert len(mapper.slam.wall_references) >= 2
            assert min(abs(float(F.wrap_right_angle(r - 0.3)))
                       for r in mapper.slam.wall_references) < 0.03
    assert errors[10] < errors[0], errors
