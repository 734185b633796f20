"""bench_mapper.py's odometry models: ``calibrated`` is ``sim`` without the wheels' scale
error (the same noise draws), ``exact`` the truth (no ROS master needed)."""
import os
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import bench_mapper  # noqa: E402

from ascc_navigation import synthetic as S  # noqa: E402

SEED = 6  # its wheels' scales (config/asccbot.yaml's sigma 0.003) average 1.0042


def _length(poses):
    return float(np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T)))


def test_calibrated_odometry_is_sim_without_the_scale_error():
    traj = S.waypoint_trajectory([(0.0, 0.0), (40.0, 0.0)], v=0.3, dt=0.1)
    truth = _length(traj)
    sim = bench_mapper.odometry("sim", traj, np.random.default_rng(SEED))
    calibrated = bench_mapper.odometry("calibrated", traj, np.random.default_rng(SEED))
    scale = 1.0 + 0.003 * np.random.default_rng(SEED).standard_normal(2)  # sim's first draw
    # the wheel noise over 40 m is ~2 cm (0.004 m per sqrt(m) per wheel): 0.05 %
    assert _length(sim) / truth == pytest.approx(scale.mean(), abs=1e-3)
    assert _length(calibrated) / truth == pytest.approx(1.0, abs=1e-3)
    assert abs(_length(sim) - _length(calibrated)) > 0.1  # 0.42 % of 40 m
    assert np.array_equal(bench_mapper.odometry("exact", traj, np.random.default_rng(SEED)),
                          traj[:, :3])


def test_wall_calibration_removes_most_of_the_scale_error():
    # the same wheels as "sim" (the same draws), corrected by the factor calibrate_odometry's
    # runs against a wall would give: what is left is the wheels' noise on those runs and
    # on this path (40 m: ~0.05 % each), not the 0.42 % scale error
    traj = S.waypoint_trajectory([(0.0, 0.0), (40.0, 0.0)], v=0.3, dt=0.1)
    truth = _length(traj)
    sim = bench_mapper.odometry("sim", traj, np.random.default_rng(SEED))
    wall = bench_mapper.odometry("wall", traj, np.random.default_rng(SEED))
    assert abs(_length(sim) / truth - 1.0) > 0.003
    assert abs(_length(wall) / truth - 1.0) < 0.0015
    # before the correction, the same noise as sim: the first step's heading error agrees
    assert wall[1, 2] == pytest.approx(sim[1, 2], abs=1e-12)


def test_create1_odometry_reports_the_turn_in_whole_degrees():
    # the same wheels as "sim"; the heading lags the unquantised one by less than a degree
    # (the remainder is carried, not lost) and moves in whole degrees only
    traj = S.waypoint_trajectory([(0.0, 0.0), (10.0, 0.0), (10.0, 8.0), (0.0, 8.0)],
                                 v=0.3, w=0.8, dt=0.1)
    sim = bench_mapper.odometry("sim", traj, np.random.default_rng(SEED))
    c1 = bench_mapper.odometry("create1", traj, np.random.default_rng(SEED))
    lag = np.angle(np.exp(1j * (sim[:, 2] - c1[:, 2])))
    one = np.radians(1.0)
    assert np.all(np.abs(lag) < one + 1e-9)
    assert np.abs(lag).max() > 0.5 * one     # it does lag
    steps = np.diff(np.unwrap(c1[:, 2])) / one
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    assert _length(c1) == pytest.approx(_length(sim), rel=1e-3)


@pytest.mark.parametrize("heading", [0.0, 0.7, -2.9])
def test_oracle_corrects_only_the_part_it_names(heading):
    truth = np.array([3.0, -1.0, heading])
    c, s = np.cos(heading), np.sin(heading)
    along, across, dtheta = 0.3, -0.2, 0.05
    pose = np.array([[3.0 + along * c - across * s, -1.0 + along * s + across * c,
                      heading + dtheta]])

    def parts(p):  # (along, across, heading error) of p against the truth
        ex, ey = p[0, 0] - truth[0], p[0, 1] - truth[1]
        return c * ex + s * ey, -s * ex + c * ey, p[0, 2] - truth[2]

    assert parts(pose) == pytest.approx((along, across, dtheta))
    assert parts(bench_mapper.apply_oracle(pose.copy(), truth, "along")) == \
        pytest.approx((0.0, across, dtheta))
    assert parts(bench_mapper.apply_oracle(pose.copy(), truth, "across")) == \
        pytest.approx((along, 0.0, dtheta))
    assert parts(bench_mapper.apply_oracle(pose.copy(), truth, "position")) == \
        pytest.approx((0.0, 0.0, dtheta))
    assert parts(bench_mapper.apply_oracle(pose.copy(), truth, "heading")) == \
        pytest.approx((along, across, 0.0))
    with pytest.raises(ValueError):
        bench_mapper.apply_oracle(pose.copy(), truth, "speed")


def test_oracle_position_builds_the_map_at_the_true_positions():
    # the synthetic office, a few metres: with the position set to the truth before each
    # registration, the filter's trajectory is the true path (to the float), its heading not
    world = bench_mapper.SyntheticWorld(np.random.default_rng(1))
    world.route = world.route[:3]
    r = bench_mapper.run(world, bench_mapper.load_params(bench_mapper.CONFIG), 1, "sim",
                         oracle="position")
    assert r["along"] < 1e-9 and r["across"] < 1e-9
    assert r["heading_mrad"][1] > 0.0
