"""The offline CLI on the hand-made test map, and the ROS message conversions (no master)."""

import os

import numpy as np
import pytest
from geometry_msgs.msg import Quaternion
from nav_msgs.msg import OccupancyGrid
from visualization_msgs.msg import Marker

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_common.pose2d import quaternion_from_yaw, yaw_of
from frontier_detector import cli
from frontier_detector.goal_selection import plan
from frontier_detector.rosmsg import grid_from_msg, plan_markers

MAP = os.path.join(os.path.dirname(os.path.abspath(__file__)), "maps", "office_partial.yaml")


def test_cli_prints_candidates_and_total_last(capsys):
    assert cli.main([MAP, "--robot", "6.0", "1.0", "--repeat", "3"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[-1].startswith("total_ms=")
    total = float(out[-1].split("=")[1])
    timings = dict(kv.split("=") for kv in out[-2].split(": ")[1].split())
    assert set(timings) == {"phase1_ms", "phase2_ms", "phase3_ms", "utility_ms"}
    assert total >= max(float(v) for v in timings.values()) > 0.0
    rows = [line for line in out if line[:1] in "*x " and line[1:5].strip().isdigit()]
    assert len(rows) >= 5
    assert sum(1 for line in rows if line.startswith("*")) == 1
    assert any(line.startswith("goal: x=") for line in out)


def test_cli_bad_inputs(capsys, tmp_path):
    assert cli.main([MAP, "--robot", "500", "1"]) == 3
    assert "robot_outside_map" in capsys.readouterr().out
    assert cli.main([str(tmp_path / "none.yaml"), "--robot", "0", "0"]) == 2
    assert cli.main([MAP, "--robot", "6", "1", "--repeat", "0"]) == 2
    assert cli.main([MAP, "--robot", "6", "1", "--strategy", "nearest", "--top", "2"]) == 0
    out = capsys.readouterr().out
    assert "strategy nearest" in out


def make_msg(grid, res=0.05, ox=1.0, oy=-2.0, yaw=0.0):
    m = OccupancyGrid()
    m.header.frame_id = "map"
    m.info.resolution = res
    m.info.height, m.info.width = grid.shape
    m.info.origin.position.x, m.info.origin.position.y = ox, oy
    m.info.origin.orientation = Quaternion(*quaternion_from_yaw(yaw))
    m.data = grid.ravel().tolist()
    return m


def test_grid_from_msg_thresholds_cartographer_values():
    g = np.array([[-1, 0, 10], [50, 70, 100]], np.int8)
    grid, info, counts = grid_from_msg(make_msg(g, yaw=0.5))
    assert grid.tolist() == [[UNKNOWN, FREE, FREE], [UNKNOWN, OCCUPIED, OCCUPIED]]
    assert counts["non_trinary"] == 3
    assert info.origin_x == 1.0 and info.origin_yaw == pytest.approx(0.5)
    bad = make_msg(g)
    bad.info.width = 4
    with pytest.raises(ValueError):
        grid_from_msg(bad)
    empty = make_msg(np.zeros((0, 0), np.int8))
    grid, _, _ = grid_from_msg(empty)
    assert grid.size == 0


def test_markers_show_every_phase_and_the_goal():
    g = np.full((40, 200), FREE, np.int8)
    g[20:, :] = UNKNOWN
    info = GridInfo(0.05, 200, 40)
    result = plan(g, info, (5.0, 0.25))
    arr = plan_markers(result, "map", None, (5.0, 0.25), [(1.0, 1.0)], max_points=50)
    by_ns = {}
    for m in arr.markers:
        by_ns.setdefault(m.ns, []).append(m)
    assert arr.markers[0].action == Marker.DELETEALL
    assert len(by_ns["phase1"][0].points) == 50        # 200 cells subsampled
    assert len(by_ns["phase2"][0].points) == 50
    assert len(by_ns["phase3"][0].points) == result.frontiers.n_candidates
    goal = [m for m in by_ns["goal"] if m.type == Marker.SPHERE][0]
    assert (goal.pose.position.x, goal.pose.position.y) == pytest.approx(result.goal_xy)
    assert len(by_ns["blacklist"][0].points) == 1
    assert all(m.header.frame_id == "map" for m in arr.markers)
    # No goal: the goal markers are deleted, not left stale.
    none = plan(np.full((10, 10), OCCUPIED, np.int8), info, (0.2, 0.2))
    arr = plan_markers(none, "map", None, None)
    assert all(m.action == Marker.DELETE for m in arr.markers if m.ns == "goal")
    # nothing to show (no frontier, no blacklist): no list marker without points, which
    # rviz shows as an error of the whole display
    assert [m.ns for m in arr.markers if m.action == Marker.ADD and not m.points
            and m.type in (Marker.POINTS, Marker.SPHERE_LIST, Marker.CUBE_LIST)] == []
    assert arr.markers[0].action == Marker.DELETEALL


def test_goal_faces_its_frontier():
    import math

    from frontier_detector.rosmsg import goal_pose

    g = np.full((40, 200), FREE, np.int8)
    g[20:, :] = UNKNOWN                                # frontier north (+y) of the robot
    result = plan(g, GridInfo(0.05, g.shape[1], g.shape[0]), (5.0, 0.25))
    assert result.goal_yaw == pytest.approx(math.pi / 2, abs=0.2)
    ps = goal_pose("map", None, result.goal_xy, (5.0, 0.25), result.goal_yaw)
    assert yaw_of(ps.pose.orientation) == pytest.approx(result.goal_yaw)
    # Without a yaw the goal faces along the approach from the robot.
    ps = goal_pose("map", None, (6.0, 0.25), (5.0, 0.25))
    assert yaw_of(ps.pose.orientation) == pytest.approx(0.0)
