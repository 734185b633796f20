"""Conversions between ROS messages and this package's arrays (message classes only, no
rospy: usable and testable without a master).

* `grid_from_msg`: nav_msgs/OccupancyGrid -> trinary int8 grid + GridInfo + odd-value counts
  (thresholding rule in ascc_common.grid).
* `plan_markers`: visualization_msgs/MarkerArray showing fig. 2.6's stages: namespace
  `phase1` (preliminary candidates, small blue points), `phase2` (after filtering, orange
  points), `unreachable` (frontier segments with no reachable cell, grey points),
  `phase3` (cluster goal points, spheres coloured from red = low to green = high
  utility; view points of unreachable clusters included), `goal` (chosen x*, large green
  sphere + arrow from the robot), `blacklist` (red cubes). Large point sets are
  subsampled to `max_points` per namespace.
"""

from __future__ import annotations

import math
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
from geometry_msgs.msg import Point, PoseStamped, Quaternion
from nav_msgs.msg import OccupancyGrid
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ascc_common.grid import GridInfo, map_from_msg, to_trinary
from ascc_common.pose2d import quaternion_from_yaw

from .goal_selection import Plan


def grid_from_msg(msg: OccupancyGrid, free_max: int = 19, occupied_min: int = 65
                  ) -> Tuple[np.ndarray, GridInfo, Dict[str, int]]:
    """Trinary grid, geometry and odd-value counts; ValueError if data and size disagree
    or the geometry is invalid (e.g. resolution 0)."""
    data, info = map_from_msg(msg)
    grid, counts = to_trinary(data, free_max, occupied_min)
    return grid, info, counts


def goal_pose(frame_id: str, stamp, goal_xy: Tuple[float, float],
              robot_xy: Optional[Tuple[float, float]] = None,
              yaw: Optional[float] = None) -> PoseStamped:
    """Goal pose in frame_id, heading `yaw` [rad], or facing along the approach from the
    robot when yaw is None."""
    ps = PoseStamped()
    ps.header.frame_id = frame_id
    ps.header.stamp = stamp
    ps.pose.position.x, ps.pose.position.y = float(goal_xy[0]), float(goal_xy[1])
    if yaw is None:
        yaw = 0.0
        if robot_xy is not None:
            yaw = math.atan2(goal_xy[1] - robot_xy[1], goal_xy[0] - robot_xy[0])
    ps.pose.orientation = Quaternion(*quaternion_from_yaw(yaw))
    return ps


def _marker(frame_id: str, stamp, ns: str, mtype: int, scale: float,
            rgba: Tuple[float, float, float, float]) -> Marker:
    m = Marker()
    m.header.frame_id = frame_id
    m.header.stamp = stamp
    m.ns, m.id, m.type, m.action = ns, 0, mtype, Marker.ADD
    m.pose.orientation.w = 1.0
    m.scale.x = m.scale.y = m.scale.z = scale
    m.color = ColorRGBA(*rgba)
    return m


def _points(xy: np.ndarray, z: float, max_points: int) -> list:
    if xy.shape[0] > max_points > 0:
        xy = xy[np.linspace(0, xy.shape[0] - 1, max_points).astype(np.int64)]
    return [Point(float(x), float(y), z) for x, y in xy]


_LIST_TYPES = (Marker.LINE_STRIP, Marker.LINE_LIST, Marker.CUBE_LIST, Marker.SPHERE_LIST,
               Marker.POINTS, Marker.TRIANGLE_LIST)


def plan_markers(result: Plan, frame_id: str, stamp, robot_xy: Optional[Tuple[float, float]],
                 blacklist_xy: Sequence[Tuple[float, float]] = (), max_points: int = 5000
                 ) -> MarkerArray:
    """MarkerArray of the plan's phases, chosen goal and blacklist (see module doc)."""
    out = MarkerArray()
    clear = Marker()
    clear.header.frame_id = frame_id
    clear.action = Marker.DELETEALL
    out.markers.append(clear)
    info, fr = result.info, result.frontiers
    res = info.resolution
    for ns, cells, scale, rgba, z in (
            ("phase1", fr.phase1_rc, res, (0.2, 0.4, 1.0, 0.8), 0.01),
            ("phase2", fr.phase2_rc, 1.5 * res, (1.0, 0.55, 0.0, 0.9), 0.02),
            ("unreachable", fr.unreachable_rc, 1.5 * res, (0.5, 0.5, 0.5, 0.9), 0.02)):
        m = _marker(frame_id, stamp, ns, Marker.POINTS, scale, rgba)
        if cells.shape[0]:
            x, y = info.cell_to_world(cells[:, 1], cells[:, 0])
            m.points = _points(np.stack([x, y], axis=1), z, max_points)
        out.markers.append(m)
    m = _marker(frame_id, stamp, "phase3", Marker.SPHERE_LIST, 0.2, (1.0, 1.0, 1.0, 1.0))
    if result.scores is not None and result.goals_xy.shape[0]:
        total = result.scores.total
        finite = np.isfinite(total)
        lo = float(total[finite].min()) if finite.any() else 0.0
        hi = float(total[finite].max()) if finite.any() else 1.0
        for (x, y), u, ok in zip(result.goals_xy, total, result.allowed):
            m.points.append(Point(float(x), float(y), 0.05))
            f = (float(u) - lo) / (hi - lo) if hi > lo and math.isfinite(u) else 1.0
            m.colors.append(ColorRGBA(1.0 - f, f, 0.0, 1.0 if ok else 0.3))
    out.markers.append(m)
    goal = result.goal_xy
    g = _marker(frame_id, stamp, "goal", Marker.SPHERE, 0.35, (0.0, 0.9, 0.2, 0.9))
    arrow = _marker(frame_id, stamp, "goal", Marker.ARROW, 0.05, (0.0, 0.9, 0.2, 0.9))
    arrow.id = 1
    arrow.scale.y, arrow.scale.z = 0.12, 0.15
    if goal is None:
        g.action = arrow.action = Marker.DELETE
    else:
        g.pose.position.x, g.pose.position.y = goal
        if robot_xy is not None:
            arrow.points = [Point(robot_xy[0], robot_xy[1], 0.1), Point(goal[0], goal[1], 0.1)]
        else:
            arrow.action = Marker.DELETE
    out.markers.extend([g, arrow])
    b = _marker(frame_id, stamp, "blacklist", Marker.CUBE_LIST, 0.25, (0.9, 0.0, 0.0, 0.8))
    b.points = [Point(float(x), float(y), 0.05) for x, y in blacklist_xy]
    out.markers.append(b)
    # rviz marks the whole display as an error on a list marker without points ("Points
    # should not be empty"): an empty list is left out (DELETEALL above cleared the old one)
    out.markers = [m for m in out.markers if m.action != Marker.ADD
                   or m.type not in _LIST_TYPES or m.points]
    return out
