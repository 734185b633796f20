"""Following the target's trail: where the followed person walked is where the robot drives.

Heading straight for the target cuts corners: when a person turns through a door, the
straight line from the robot to the person crosses the door frame, and the laser safety
stop then holds the robot at the wall (the robot turns toward the person, the person is
behind the wall, nothing moves). The target's own path is free space the robot fits
through (a person is wider than an iRobot Create), so the follower steers along it, the
"breadcrumb" strategy of person-following robots:

* the target's measured positions (odom frame; measured, not the tracker's prediction,
  which runs on past a corner) are appended to the trail every ``trail_spacing_m``;
* trail points the robot has come within ``trail_reached_m`` of are passed, with every
  point before them;
* the robot steers toward the first remaining point at least ``trail_lookahead_m`` away
  (pure pursuit on the trail; the target itself when no point is that far), and its range
  to the target is the length of the path robot -> trail -> target, so on a straight
  walk it is the straight range and around a corner it is the distance still to drive.

Inside the set distance along the path, or nearer than ``direct_within_m`` in a straight
line, the robot faces the target itself (thesis 5.3: keep it in the middle of the view).
Right after a person turns a corner the straight line is shorter than the path (0.85 m
against 1.2 m half-way through a right-angle turn): with ``direct_within_m`` at the set
distance (1.3 m) the robot waited at each corner and fell ~1 m behind (straight-segment
error 0.61 m over 5 seeds); at 0.9 m (the default) the path decides the speed round the
corner. A target that walks back toward the robot (nearer than where its trail starts, or
within the set distance plus ``trail_max_detour_m`` in a straight line with the trail that
much longer) restarts the trail at itself. That
needed a trail without bad points (``trail_max_innovation_m``), a way out
when a trail point is out of reach (``note_blocked``) and a safety stop along the arc
being driven (follower.py): docs/results/target_follower.md. When the
target is lost from view (a person turning through a door is hidden by the wall), the
robot drives along the trail to where it was last seen and looks there (``search_aim``);
a target found again near the trail's end continues the trail (``restart``). Pure: no
rospy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Tuple

from ascc_common.params import param
from ascc_common.pose2d import wrap_angle

from .follower import Aim

Point = Tuple[float, float]


@dataclass
class TrailParams:
    """How the follower follows the target's trail (module doc)."""

    follow_trail: bool = param(True, "steer along the target's path (false: straight at "
                                     "the target)")
    trail_spacing_m: float = param(0.1, "[m] distance between trail points", gt=0.0)
    trail_lookahead_m: float = param(0.5, "[m] steer toward the first trail point at "
                                          "least this far away", gt=0.0)
    trail_reached_m: float = param(0.3, "[m] trail points this close to the robot are "
                                        "passed", gt=0.0)
    direct_within_m: float = param(0.9, "[m] straight range below which the robot faces "
                                        "the target whatever the path (module doc)",
                                   gt=0.0)
    trail_join_m: float = param(2.0, "[m] a target found again this close to the trail's "
                                     "end continues the trail (farther: a new trail)",
                                ge=0.0)
    trail_max_points: int = param(400, "keep at most this many trail points (the oldest "
                                       "go first)", gt=1)
    trail_max_innovation_m: float = param(0.25, "[m] a measured position this far from "
                                                "the track's prediction is not a trail "
                                                "point (a laser range off the target)",
                                          gt=0.0)
    trail_max_detour_m: float = param(1.0, "[m] the target within the set distance plus "
                                           "this in a straight line while the path along "
                                           "the trail is this much longer: it came back "
                                           "(the trail is restarted at it, the robot faces "
                                           "it; a right-angle corner makes at most 0.41 x "
                                           "the straight range)", gt=0.0)
    trail_blocked_s: float = param(2.0, "[s] held by the safety stop this long while "
                                        "steering along the trail: the trail is dropped "
                                        "(its next point is out of reach)", gt=0.0)


class Trail:
    """The followed target's path in the odom frame (module doc)."""

    def __init__(self, p: TrailParams):
        self.p = p
        self.points: List[Point] = []
        self.steering = False  # the last aim steered along the trail (not direct)
        self.blocked_since: Optional[float] = None

    def clear(self) -> None:
        self.points = []
        self.blocked_since = None

    def note_blocked(self, now_s: float, blocked: bool) -> bool:
        """The safety stop's verdict on the last command; True when it has held the robot
        for ``trail_blocked_s`` while it steered along the trail: the trail is then
        dropped (a point beside an obstacle, or a bad one, is out of reach) and the robot
        faces the target until a new trail is laid."""
        if not (blocked and self.steering and self.points):
            self.blocked_since = None
            return False
        if self.blocked_since is None:
            self.blocked_since = now_s
        if now_s - self.blocked_since < self.p.trail_blocked_s:
            return False
        self.clear()
        return True

    def restart(self, xy: Point) -> None:
        """A new track starts at ``xy``: continue the trail when ``xy`` is within
        ``trail_join_m`` of its end (the same person found again after a corner), else
        start a new one."""
        if self.points and math.hypot(xy[0] - self.points[-1][0], xy[1] - self.points[-1][1]) \
                > self.p.trail_join_m:
            self.clear()
        self.add(xy)

    def add(self, xy: Point, innovation_m: float = math.nan) -> None:
        """The target's measured position [m, odom]; kept when ``trail_spacing_m`` from
        the last point and, when ``innovation_m`` (its distance from the track's
        prediction) is known, within ``trail_max_innovation_m`` of the prediction."""
        if not (math.isfinite(xy[0]) and math.isfinite(xy[1])):
            return
        if math.isfinite(innovation_m) and innovation_m > self.p.trail_max_innovation_m:
            return
        if self.points and math.hypot(xy[0] - self.points[-1][0],
                                      xy[1] - self.points[-1][1]) < self.p.trail_spacing_m:
            return
        self.points.append((float(xy[0]), float(xy[1])))
        if len(self.points) > self.p.trail_max_points:
            del self.points[0]

    def prune(self, robot_xy: Point) -> None:
        """Drop the points the robot has reached, and all before the last reached one."""
        last = -1
        for i, (x, y) in enumerate(self.points):
            if math.hypot(x - robot_xy[0], y - robot_xy[1]) <= self.p.trail_reached_m:
                last = i
        if last >= 0:
            del self.points[:last + 1]

    def _to_target(self, target_xy: Point) -> List[Point]:
        """The trail without its last points within ``trail_reached_m`` of the target
        (where the target is now: a point just beyond it would count twice)."""
        pts = self.points
        while pts and math.hypot(pts[-1][0] - target_xy[0],
                                 pts[-1][1] - target_xy[1]) < self.p.trail_reached_m:
            pts = pts[:-1]
        return pts

    def steer_point(self, robot_xy: Point, target_xy: Point) -> Point:
        """The first trail point at least the lookahead away; the target when none is."""
        for x, y in self._to_target(target_xy):
            if math.hypot(x - robot_xy[0], y - robot_xy[1]) >= self.p.trail_lookahead_m:
                return x, y
        return target_xy

    def path_length(self, robot_xy: Point, target_xy: Point) -> float:
        """Length [m] of robot -> remaining trail points -> target."""
        length, prev = 0.0, robot_xy
        for pt in self._to_target(target_xy) + [target_xy]:
            length += math.hypot(pt[0] - prev[0], pt[1] - prev[1])
            prev = pt
        return length

    def search_aim(self, pose, distance_m: float) -> Optional[Aim]:
        """With the target lost: an aim along the trail to its end, where the target was
        last seen (``Aim.searching``), its range ``distance_m`` + the path length so that
        the control law drives all the way; None when there is no trail or its end is
        reached (the trail is then cleared)."""
        self.steering = False
        if not self.p.follow_trail:
            return None
        robot = (pose[0], pose[1])
        self.prune(robot)
        if not self.points:
            return None
        self.steering = True
        end = self.points[-1]
        rng = self.path_length(robot, end)
        if rng <= self.p.trail_reached_m:
            self.clear()
            return None
        sx, sy = self.steer_point(robot, end)
        bearing = wrap_angle(math.atan2(sy - pose[1], sx - pose[0]) - pose[2])
        return Aim(bearing, distance_m + rng, searching=True)

    def aim(self, pose, target_xy: Point, direct: Aim, distance_m: float,
            velocity: Point = (0.0, 0.0)) -> Aim:
        """The aim for the control law: toward the steer point with the path length as
        range, or ``direct`` (the target itself) inside ``distance_m`` or when the trail
        is off. ``pose``: the robot's (x, y, yaw) in odom; ``target_xy``: the target now;
        ``velocity``: its velocity [m/s, odom], whose component along the trail's last
        leg is the rate at which the path lengthens."""
        self.steering = False
        if not self.p.follow_trail or not math.isfinite(direct.range_m):
            return direct
        robot = (pose[0], pose[1])
        self.prune(robot)
        rng = self.path_length(robot, target_xy)
        detour = self.p.trail_max_detour_m
        first = math.hypot(self.points[0][0] - robot[0], self.points[0][1] - robot[1]) \
            if self.points else math.inf
        nearer = direct.range_m < first - self.p.trail_spacing_m  # than where its trail starts
        if (direct.range_m <= distance_m + detour and rng > direct.range_m + detour) \
                or nearer:
            self.clear()  # the target walked back toward the robot: the trail is a detour
            self.add(target_xy)
            return direct
        if rng <= distance_m or direct.range_m <= self.p.direct_within_m:
            return direct  # close enough along the path, or too close straight: face it
        self.steering = bool(self.points)
        sx, sy = self.steer_point(robot, target_xy)
        bearing = wrap_angle(math.atan2(sy - pose[1], sx - pose[0]) - pose[2])
        rate = direct.range_rate_mps
        if self.points:  # along the last leg of the trail, toward the target
            lx, ly = target_xy[0] - self.points[-1][0], target_xy[1] - self.points[-1][1]
            leg = math.hypot(lx, ly)
            if leg > 1e-6:
                rate = (velocity[0] * lx + velocity[1] * ly) / leg
        return Aim(bearing, rng, direct.area_px, rate)
