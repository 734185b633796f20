"""Tests of the path-following controller (pure code, no ROS master)."""

import numpy as np
import pytest

from ascc_navigation import controller as ctl

DT = 0.1


def _line(x0, y0, x1, y1, step=0.05):
    n = max(int(np.hypot(x1 - x0, y1 - y0) / step), 1)
    t = np.linspace(0.0, 1.0, n + 1)
    return np.column_stack([x0 + t * (x1 - x0), y0 + t * (y1 - y0)])


def _drive(follower, pose, steps, obstacles_world=None):
    """Unicycle simulation; returns poses and commands."""
    poses, cmds = [np.array(pose, float)], []
    for _ in range(steps):
        p = poses[-1]
        obs = None
        if obstacles_world is not None:
            c, s = np.cos(p[2]), np.sin(p[2])
            d = obstacles_world - p[:2]
            obs = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
        cmd = follower.compute(p, obs, DT)
        cmds.append(cmd)
        if cmd.state == ctl.GOAL_REACHED:
            break
        poses.append(p + [cmd.v * DT * np.cos(p[2]), cmd.v * DT * np.sin(p[2]), cmd.w * DT])
    return np.array(poses), cmds


def test_starts_with_limited_acceleration_and_reaches_cruise_speed():
    p = ctl.ControllerParams()
    f = ctl.PathFollower(p)
    f.set_path(_line(0, 0, 5, 0))
    first = f.compute((0.0, 0.0, 0.0), None, DT)
    assert first.state == ctl.FOLLOWING
    assert first.v == pytest.approx(p.acc_lim_x * DT)
    assert abs(first.w) < 1e-6
    for _ in range(20):
        cmd = f.compute((0.0, 0.0, 0.0), None, DT)
    assert cmd.v == pytest.approx(p.max_vel_x)


def test_large_heading_error_turns_on_the_spot_the_right_way():
    f = ctl.PathFollower()
    f.set_path(_line(0, 0, 0, 3))  # path goes +y, robot faces +x
    cmd = f.compute((0.0, 0.0, 0.0), None, DT)
    assert cmd.state == ctl.ROTATING and cmd.v == 0.0 and cmd.w > 0.0
    f.set_path(_line(0, 0, 0, -3))
    f.reset()
    assert f.compute((0.0, 0.0, 0.0), None, DT).w < 0.0


def test_goal_position_then_goal_yaw():
    p = ctl.ControllerParams()
    f = ctl.PathFollower(p)
    f.set_path(_line(0, 0, 1, 0), goal_yaw=np.pi / 2)
    cmd = f.compute((0.95, 0.0, 0.0), None, DT)  # within xy tolerance, yaw off by 90 deg
    assert cmd.state == ctl.ROTATING and cmd.v == 0.0 and cmd.w > 0.0
    # xy is latched: drifting a little outside the tolerance while turning is fine
    cmd = f.compute((0.80, 0.0, 1.0), None, DT)
    assert cmd.state == ctl.ROTATING
    cmd = f.compute((0.80, 0.0, np.pi / 2 - 0.1), None, DT)
    assert cmd.state == ctl.GOAL_REACHED and cmd.v == 0.0 and cmd.w == 0.0


def test_any_yaw_accepted_without_goal_yaw():
    f = ctl.PathFollower()
    f.set_path(_line(0, 0, 1, 0), goal_yaw=None)
    assert f.compute((1.0, 0.05, 2.5), None, DT).state == ctl.GOAL_REACHED


def test_obstacle_ahead_slows_then_stops_at_once_and_reports_blocked():
    p = ctl.ControllerParams()
    f = ctl.PathFollower(p)
    f.set_path(_line(0, 0, 5, 0))
    for _ in range(20):
        f.compute((0.0, 0.0, 0.0), None, DT)
    assert f.v == pytest.approx(p.max_vel_x)
    reach = p.robot_radius + p.obstacle_margin
    # within a second at full speed, not at half: half speed at once
    ahead = np.array([[reach + 0.2, 0.0], [reach + 0.2, 0.05]])
    cmd = f.compute((0.0, 0.0, 0.0), ahead, DT)
    assert cmd.state == ctl.FOLLOWING and cmd.v == pytest.approx(p.max_vel_x / 2)
    # within a second even at the slowest speed: stop at once
    close = np.array([[reach + 0.5 * p.min_vel_x, 0.0]])
    cmd = f.compute((0.0, 0.0, 0.0), close, DT)
    assert cmd.state == ctl.BLOCKED and cmd.v == 0.0 and cmd.w == 0.0


def test_obstacles_behind_or_beside_do_not_block():
    f = ctl.PathFollower()
    f.set_path(_line(0, 0, 5, 0))
    behind = np.array([[-0.25, 0.0]])
    beside = np.array([[0.3, 0.5], [0.8, -0.45]])  # clear of the 0.22 m swept band
    for obs in (behind, beside):
        cmd = f.compute((0.0, 0.0, 0.0), obs, DT)
        assert cmd.state == ctl.FOLLOWING and cmd.v > 0.0


def test_arc_check_follows_the_turn():
    f = ctl.PathFollower()
    # turning left at 0.3 m/s and 1 rad/s: radius 0.3 m, the arc goes up, not straight on
    straight_on = np.array([[0.45, 0.0]])
    on_arc = np.array([[0.3, 0.3]])
    assert f.arc_is_free(0.3, 1.0, straight_on)
    assert not f.arc_is_free(0.3, 1.0, on_arc)
    assert not f.arc_is_free(0.3, 0.0, straight_on)


def test_follows_an_l_shaped_path_closely():
    f = ctl.PathFollower()
    path = np.vstack([_line(0, 0, 3, 0), _line(3, 0, 3, 3)[1:]])
    f.set_path(path, goal_yaw=np.pi / 2)
    poses, cmds = _drive(f, (0.0, 0.0, 0.0), 600)
    assert cmds[-1].state == ctl.GOAL_REACHED
    assert np.hypot(*(poses[-1, :2] - [3.0, 3.0])) <= f.params.xy_goal_tolerance + 0.02
    # cross-track error: distance of every pose to the path polyline's points
    d = np.min(np.hypot(poses[:, None, 0] - path[None, :, 0],
                        poses[:, None, 1] - path[None, :, 1]), axis=1)
    assert d.max() < 0.2
    speeds = np.array([c.v for c in cmds])
    assert speeds.max() <= f.params.max_vel_x + 1e-9
    assert np.all(np.abs(np.diff(speeds)) <= f.params.acc_lim_x * DT + 1e-9)


def test_stops_before_a_wall_across_the_path():
    f = ctl.PathFollower()
    f.set_path(_line(0, 0, 4, 0))
    wall = np.column_stack([np.full(21, 2.0), np.linspace(-0.5, 0.5, 21)])
    poses, cmds = _drive(f, (0.0, 0.0, 0.0), 200, obstacles_world=wall)
    assert cmds[-1].state == ctl.BLOCKED
    gap = 2.0 - poses[:, 0].max()
    assert gap >= f.params.robot_radius  # never touched the wall
    assert gap < 0.6  # but drove up to it


def test_margin_applies_to_points_approached_not_to_points_left_behind():
    f = ctl.PathFollower()
    reach = f.params.robot_radius + f.params.obstacle_margin
    # a door jamb slightly ahead and to the right: driving on passes it at its lateral offset
    assert not f.arc_is_free(0.3, 0.0, np.array([[0.05, -(reach - 0.005)]]))
    assert f.arc_is_free(0.3, 0.0, np.array([[0.05, -(reach + 0.005)]]))
    # a point already inside the margin, behind on the left: moving away is allowed
    assert f.arc_is_free(0.3, -0.5, np.array([[-0.05, reach - 0.03]]))
    assert not f.arc_is_free(0.3, 1.0, np.array([[0.05, reach - 0.03]]))  # turning into it
