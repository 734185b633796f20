"""Local controller: pure pursuit along the global path, with a laser safety check (no ROS).

Each call of ``PathFollower.compute`` turns (robot pose, laser points, dt) into a velocity
command (v [m/s], w [rad/s]):

* progress along the path is tracked (the nearest path point, searched only ahead of the
  last one so loops in a path do not confuse it), and the target is the first path point
  ``lookahead`` metres away;
* heading error above ``rotate_in_place_angle``: turn on the spot; else pure pursuit,
  curvature kappa = 2 y / L^2 of the target (x, y) in the robot frame, w = v kappa, with the
  speed lowered in tight turns and near the goal;
* at the goal position (``xy_goal_tolerance``, latched as move_base's
  ``latch_xy_goal_tolerance``) it turns to the goal yaw (``yaw_goal_tolerance``);
* safety: the arc the command would drive over ``obstacle_horizon`` seconds (at least the
  braking distance) is swept with the robot's circle; if it brings the robot closer to a
  laser point that is or gets within ``obstacle_margin`` of the robot, the speed is halved
  (same curvature, down to ``min_vel_x``) until the arc is free, so the robot creeps past
  door jambs; if none is, forward motion stops at once (braking for obstacles is not rate
  limited): the robot turns on the spot to face the target if it does not yet (more than
  ``blocked_turn_angle`` off), else the result says "blocked". Moving away from a point
  already that close is allowed, and so is turning on the spot (the robot is round);
* acceleration limits ``acc_lim_x`` / ``acc_lim_theta`` on every other change.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from ascc_common.params import param
from ascc_common.pose2d import wrap_angle

FOLLOWING = "following"
ROTATING = "rotating"  # on the spot towards the path or the goal yaw
BLOCKED = "blocked"
GOAL_REACHED = "goal_reached"


@dataclass
class ControllerParams:
    """Read as base_local_planner's TrajectoryPlannerROS parameters where one exists, else
    as the stand-in's ``stand_in/`` ones (``ascc_common.params``; package README)."""

    max_vel_x: float = param(0.3, "[m/s] the thesis drives the ASCCbot at 0.3 m/s",
                             "TrajectoryPlannerROS/max_vel_x", gt=0.0)
    min_vel_x: float = param(0.05, "[m/s] slowest forward speed while following",
                             "TrajectoryPlannerROS/min_vel_x", ge=0.0)
    max_vel_theta: float = param(1.0, "[rad/s]", "TrajectoryPlannerROS/max_vel_theta", gt=0.0)
    min_in_place_vel_theta: float = param(0.3, "[rad/s]",
                                          "TrajectoryPlannerROS/min_in_place_vel_theta")
    acc_lim_x: float = param(0.5, "[m/s^2]", "TrajectoryPlannerROS/acc_lim_x", gt=0.0)
    acc_lim_theta: float = param(2.0, "[rad/s^2]", "TrajectoryPlannerROS/acc_lim_theta",
                                 gt=0.0)
    xy_goal_tolerance: float = param(0.15, "[m]", "TrajectoryPlannerROS/xy_goal_tolerance")
    yaw_goal_tolerance: float = param(0.2, "[rad]", "TrajectoryPlannerROS/yaw_goal_tolerance")
    lookahead: float = param(0.4, "[m] pure-pursuit look-ahead distance", "stand_in/lookahead",
                             gt=0.0)
    rotate_in_place_angle: float = param(0.5, "[rad] heading error that stops forward motion",
                                         "stand_in/rotate_in_place_angle")
    blocked_turn_angle: float = param(0.1, "[rad] heading error turned away on the spot if "
                                      "blocked", "stand_in/blocked_turn_angle")
    heading_gain: float = 1.5  # [1/s] w = gain * heading error when turning on the spot
    robot_radius: float = param(0.17, "[m]", "global_costmap/robot_radius", gt=0.0)
    obstacle_margin: float = param(0.02, "[m] clearance kept to laser points (approached "
                                   "ones)", "stand_in/obstacle_margin")
    obstacle_horizon: float = param(1.0, "[s] of motion checked against the laser",
                                    "stand_in/obstacle_horizon")


@dataclass
class Command:
    v: float  # [m/s]
    w: float  # [rad/s]
    state: str
    distance_to_goal: float = float("nan")  # [m] along the straight line


class PathFollower:
    def __init__(self, params: Optional[ControllerParams] = None):
        self.params = params or ControllerParams()
        self.path = np.zeros((0, 2))
        self.goal_yaw: Optional[float] = None
        self.index = 0
        self.xy_reached = False
        self.v = 0.0
        self.w = 0.0

    def set_path(self, path: np.ndarray, goal_yaw: Optional[float] = None,
                 keep_goal_state: bool = False) -> None:
        """A new path (N, 2) [m] ending at the goal; ``goal_yaw`` [rad] or None (any)."""
        self.path = np.asarray(path, dtype=float).reshape(-1, 2)
        self.goal_yaw = goal_yaw
        self.index = 0
        if not keep_goal_state:
            self.xy_reached = False

    def reset(self) -> None:
        """Stops: the next command starts from rest."""
        self.v = self.w = 0.0

    # -- geometry -------------------------------------------------------------------
    def _advance(self, xy: np.ndarray) -> None:
        """Moves ``index`` to the nearest path point within a window ahead of it."""
        end = min(len(self.path), self.index + 60)
        seg = self.path[self.index:end]
        if len(seg):
            self.index += int(np.argmin(np.sum((seg - xy) ** 2, axis=1)))

    def _target(self, xy: np.ndarray) -> np.ndarray:
        ahead = self.path[self.index:]
        far = np.flatnonzero(np.hypot(*(ahead - xy).T) >= self.params.lookahead)
        return ahead[far[0]] if far.size else self.path[-1]

    def arc_is_free(self, v: float, w: float, obstacles: Optional[np.ndarray]) -> bool:
        """True unless driving (v, w) over the horizon brings the robot closer to a point
        that is, or would then be, within ``robot_radius + obstacle_margin`` of its centre.

        ``obstacles`` (K, 2) [m] are laser points in the robot's base frame. A point already
        inside the margin does not block a motion that moves away from it, so the robot can
        always leave a tight spot.
        """
        if obstacles is None or len(obstacles) == 0 or v <= 0.0:
            return True
        p = self.params
        horizon = max(p.obstacle_horizon, v / max(p.acc_lim_x, 1e-3))
        t = np.linspace(0.0, horizon, 12)
        yaw = w * t
        if abs(w) > 1e-6:
            xs, ys = v / w * np.sin(yaw), v / w * (1.0 - np.cos(yaw))
        else:
            xs, ys = v * t, np.zeros_like(t)
        reach = p.robot_radius + p.obstacle_margin
        near = obstacles[np.hypot(obstacles[:, 0], obstacles[:, 1]) < v * horizon + reach]
        if len(near) == 0:
            return True
        d2 = (near[:, None, 0] - xs[None, :]) ** 2 + (near[:, None, 1] - ys[None, :]) ** 2
        closest = d2[:, 1:].min(axis=1)  # closest approach along the arc
        return not np.any((closest < reach ** 2) & (closest < d2[:, 0] - 1e-9))

    # -- control --------------------------------------------------------------------
    def _limit(self, v: float, w: float, dt: float) -> None:
        p = self.params
        dv, dw = p.acc_lim_x * dt, p.acc_lim_theta * dt
        self.v = float(np.clip(v, self.v - dv, self.v + dv))
        self.w = float(np.clip(w, self.w - dw, self.w + dw))

    def _turn(self, err: float) -> float:
        p = self.params
        w = float(np.clip(p.heading_gain * err, -p.max_vel_theta, p.max_vel_theta))
        if abs(w) < p.min_in_place_vel_theta:
            w = float(np.copysign(p.min_in_place_vel_theta, err))
        return w

    def compute(self, pose: Sequence[float], obstacles: Optional[np.ndarray],
                dt: float) -> Command:
        """The command for the robot at ``pose`` (x, y, yaw) in the path's frame."""
        p = self.params
        if len(self.path) == 0:
            self._limit(0.0, 0.0, dt)
            return Command(self.v, self.w, GOAL_REACHED, 0.0)
        xy = np.asarray(pose[:2], dtype=float)
        yaw = float(pose[2])
        goal = self.path[-1]
        dist_goal = float(np.hypot(*(goal - xy)))
        if dist_goal <= p.xy_goal_tolerance:
            self.xy_reached = True
        if self.xy_reached:  # slow down (within the limits), then turn to the goal yaw
            err = 0.0 if self.goal_yaw is None else wrap_angle(self.goal_yaw - yaw)
            done = abs(err) <= p.yaw_goal_tolerance
            self._limit(0.0, 0.0 if done else self._turn(err), dt)
            if done and self.v == 0.0:
                self.w = 0.0
                return Command(0.0, 0.0, GOAL_REACHED, dist_goal)
            return self._checked(Command(self.v, self.w, ROTATING, dist_goal), obstacles)
        self._advance(xy)
        target = self._target(xy)
        c, s = np.cos(yaw), np.sin(yaw)
        dx, dy = target[0] - xy[0], target[1] - xy[1]
        tx, ty = c * dx + s * dy, -s * dx + c * dy  # target in the robot frame
        alpha = float(np.arctan2(ty, tx))
        if abs(alpha) > p.rotate_in_place_angle:
            state = ROTATING
            self._limit(0.0, self._turn(alpha), dt)  # forward speed decays at acc_lim_x
        else:
            state = FOLLOWING
            kappa = 2.0 * ty / max(tx * tx + ty * ty, 1e-6)
            v = p.max_vel_x * max(np.cos(alpha), 0.0)
            v = min(v, p.max_vel_theta / max(abs(kappa), 1e-6))  # keep w within its limit
            # brake at half acc_lim_x (slack for the rate limit) to arrive at about min_vel_x
            # where the goal tolerance begins; the rest is braked inside it
            v = min(v, np.sqrt(p.min_vel_x ** 2 + p.acc_lim_x
                               * max(dist_goal - p.xy_goal_tolerance, 0.0)))
            v = max(v, p.min_vel_x)
            self._limit(v, float(np.clip(v * kappa, -p.max_vel_theta, p.max_vel_theta)), dt)
        cmd = self._checked(Command(self.v, self.w, state, dist_goal), obstacles)
        if cmd.state == BLOCKED and abs(alpha) > p.blocked_turn_angle:
            # blocked while not facing the target (e.g. cutting a door jamb): turn to face
            # it on the spot; driving straight at it usually clears the obstacle
            self._limit(0.0, self._turn(alpha), dt)
            self.v = 0.0
            return Command(0.0, self.w, ROTATING, dist_goal)
        return cmd

    def _checked(self, cmd: Command, obstacles: Optional[np.ndarray]) -> Command:
        """The safety check of the module doc: the fastest of v, v/2, v/4 ... (not below
        ``min_vel_x``, same curvature) whose arc is free; none free: stop, "blocked"."""
        v, w = self.v, self.w
        while v > 0.0:
            if self.arc_is_free(v, w, obstacles):
                if v < self.v:  # slowing for an obstacle is not rate limited
                    self.v, self.w = v, w
                    return Command(v, w, cmd.state, cmd.distance_to_goal)
                return cmd
            if v <= self.params.min_vel_x:
                break
            slower = max(0.5 * v, self.params.min_vel_x)
            w *= slower / v
            v = slower
        if self.v <= 0.0:
            return cmd
        self.v = 0.0  # stop at once
        if cmd.state == FOLLOWING:
            self.w = 0.0
            return Command(0.0, 0.0, BLOCKED, cmd.distance_to_goal)
        return Command(0.0, self.w, cmd.state, cmd.distance_to_goal)
