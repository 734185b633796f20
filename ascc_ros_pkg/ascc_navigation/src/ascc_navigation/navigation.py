"""The move_base state machine: plan, follow, recover, succeed or abort (no ROS).

``Navigator.step`` runs once per control period with the robot pose in the map frame and
the laser points in the base frame, and returns the velocity command and the goal status.

* A new goal is planned at once. Goals off the map or with an invalid orientation are
  aborted at once; a goal the planner cannot reach is re-planned on every map update (and
  at least once a second) and aborted when ``planner_patience`` has passed without a plan.
* The path is re-planned when the map changes (at most at ``planner_frequency`` if > 0)
  and periodically at ``planner_frequency``.
* Recovery, when the controller, once blocked by the laser, has not got
  ``oscillation_distance`` away from there within ``controller_patience``:
  (1) re-plan with the laser obstacles marked in the costmap; (2) if blocked again, turn a
  full circle on the spot (``clearing_rotation_allowed``), gathering laser obstacles, and
  re-plan with them; (3) if still blocked, abort. The stage is reset once the robot has
  made ``progress_reset_distance`` of progress.
* Planning can run off the control loop (``Navigator(executor=...)``, as move_base's planner
  thread): the step that finds a plan due hands a snapshot of map, start, goal and laser
  marks to the executor and keeps following the current path; the result is taken over by
  the first step after it is ready (a result for an older goal is dropped). When a goal
  replaces an active one, the robot keeps following the previous path (it never reports
  that path's end as success) until the new goal's first plan arrives, instead of stopping
  for the planning time. Without an executor every plan is made inside ``step``.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import nested, param
from ascc_common.pose2d import transform_points, z_axis_from_quaternion
from ascc_common.pose2d import yaw_from_quaternion as _yaw
from ascc_navigation import controller as ctl
from ascc_navigation import planner as pln

IDLE = "idle"
ACTIVE = "active"
SUCCEEDED = "succeeded"
ABORTED = "aborted"


def goal_yaw(x: float, y: float, z: float, w: float) -> float:
    """Yaw [rad] of a goal's quaternion; ValueError if it is not a usable planar orientation.

    As move_base: a (near) zero quaternion, or one whose z axis is not vertical, is invalid.
    """
    q = np.array([x, y, z, w], dtype=float)
    if not np.all(np.isfinite(q)):
        raise ValueError("goal orientation has NaN/inf components")
    norm = float(np.linalg.norm(q))
    if norm < 1e-6:
        raise ValueError("goal orientation is a zero quaternion")
    q /= norm
    if z_axis_from_quaternion(*q)[2] < 1.0 - 1e-3:
        raise ValueError("goal orientation is not a rotation about the vertical axis")
    return _yaw(*q)


@dataclass
class NavParams:
    """Read as move_base's parameters (``ascc_common.params``; package README)."""

    planner_frequency: float = param(0.0, "[Hz] periodic re-planning; 0 = on map updates "
                                     "only", ge=0.0)
    planner_patience: float = param(5.0, "[s] without a plan before the goal is aborted")
    controller_patience: float = param(3.0, "[s] blocked before a recovery stage starts")
    oscillation_distance: float = param(0.3, "[m] of travel that ends a blocked episode")
    recovery_behavior_enabled: bool = param(True, "run the recovery stages when blocked")
    clearing_rotation_allowed: bool = param(True, "recovery stage 2: turn a full circle")
    obstacle_range: float = param(2.5, "[m] laser points nearer than this are marked on "
                                  "re-plans", "global_costmap/obstacle_layer/obstacle_range")
    progress_reset_distance: float = 0.5  # [m] of travel that resets the recovery stage
    rotation_speed: float = param(0.8, "[rad/s] of the clearing rotation",
                                  "stand_in/rotation_speed")
    replan_retry_period: float = 1.0  # [s] between attempts while no plan is found
    base_cmd_timeout: float = param(0.5, "[s] the base's command watchdog (the driver's "
                                    "~cmd_timeout_s; launch arg cmd_timeout_s)",
                                    "stand_in/base_cmd_timeout_s", ge=0.0)


@dataclass
class MoveBaseParams:
    """Everything the move_base stand-in reads (move_base's names, relative to its
    namespace): the navigator's three parameter sets and the node's own settings."""

    planner: pln.PlannerParams = nested(pln.PlannerParams)
    controller: ctl.ControllerParams = nested(ctl.ControllerParams)
    nav: NavParams = nested(NavParams)
    controller_frequency: float = param(10.0, "[Hz] of the control loop", gt=0.0)
    async_planning: bool = param(True, "plan in a thread while the controller follows the "
                                 "current path", "stand_in/async_planning")
    scan_timeout_s: float = param(0.5, "[s] with no scan newer than this the robot stops",
                                  "stand_in/scan_timeout_s", gt=0.0)
    global_frame: str = param("map", "frame of plans and goals", "global_costmap/global_frame")
    robot_base_frame: str = param("base_link", "the robot's frame",
                                  "global_costmap/robot_base_frame")
    transform_tolerance: float = param(0.5, "[s] a TF may be this old",
                                       "global_costmap/transform_tolerance")
    raytrace_range: float = param(3.0, "[m] laser points beyond are not used",
                                  "global_costmap/obstacle_layer/raytrace_range")


@dataclass
class Step:
    v: float = 0.0  # [m/s]
    w: float = 0.0  # [rad/s]
    status: str = IDLE
    reason: str = ""  # why the goal was aborted, or what the navigator is doing
    new_path: Optional[np.ndarray] = None  # (N, 2) [m] when a plan was just made
    controller_state: str = ""


@dataclass
class _Goal:
    xy: np.ndarray
    yaw: Optional[float]
    received: float  # [s]


@dataclass
class _MapData:
    grid: np.ndarray
    info: GridInfo
    stamp: int  # increases with every update


class CostmapCache:
    """The costmap of the newest map planned on, brought up to date incrementally
    (``Costmap.updated``: only the cells near what changed are recomputed). Thread-safe:
    the control loop and the planner thread may both plan."""

    def __init__(self, params: pln.PlannerParams):
        self.params = params
        self.lock = threading.Lock()
        self.stamp = -1
        self.costmap: Optional[pln.Costmap] = None

    def get(self, m: _MapData) -> pln.Costmap:
        with self.lock:
            if m.stamp != self.stamp or self.costmap is None:
                self.costmap = pln.Costmap(m.grid, m.info, self.params) \
                    if self.costmap is None else self.costmap.updated(m.grid, m.info)
                self.stamp = m.stamp
            return self.costmap


def _make_plan(costmaps: CostmapCache, m: _MapData, marks: Optional[np.ndarray],
               start_xy: np.ndarray, goal_xy: np.ndarray) -> pln.PlanResult:
    """Costmap + plan from a snapshot of the inputs (runs in the executor when async).
    Laser marks (recovery) make a costmap of their own; else the cached one is used."""
    if marks is not None and len(marks):
        costmap = pln.Costmap(m.grid, m.info, costmaps.params, marks)
    else:
        costmap = costmaps.get(m)
    return pln.plan(costmap, start_xy, goal_xy)


class Navigator:
    def __init__(self, planner_params: Optional[pln.PlannerParams] = None,
                 controller_params: Optional[ctl.ControllerParams] = None,
                 params: Optional[NavParams] = None, executor=None):
        """``executor``: an object with ``submit(fn, *args)`` returning a future
        (``concurrent.futures.ThreadPoolExecutor(1)``) to plan off the control loop;
        None plans inside ``step``."""
        self.planner_params = planner_params or pln.PlannerParams()
        self.params = params or NavParams()
        self.follower = ctl.PathFollower(controller_params)
        self.executor = executor
        self.map: Optional[_MapData] = None
        self.costmaps = CostmapCache(self.planner_params)
        self.goal: Optional[_Goal] = None
        self.status = IDLE
        # the executor's future of the plan being made for the current goal (None: none)
        self.job = None
        self.bridging = False  # following the replaced goal's path until the first plan
        self.last_step_time: Optional[float] = None  # [s] of the previous control cycle
        self._reset_goal_state()

    def _reset_goal_state(self) -> None:
        self.have_path = False
        self.planned_map = -1  # map stamp the path was planned on
        self.last_plan_time = -np.inf
        self.plan_fail_since: Optional[float] = None
        self.last_plan_error = ""
        self.blocked_since: Optional[float] = None
        self.blocked_at = np.zeros(2)
        self.recovery_stage = 0
        self.recovery_anchor: Optional[np.ndarray] = None
        self.rotating_left = 0.0  # [rad] of clearing rotation still to turn
        self.rotation_obstacles: List[np.ndarray] = []

    # -- inputs ---------------------------------------------------------------------
    def set_map(self, grid: np.ndarray, info: GridInfo) -> None:
        """A new or updated map (int8 -1/0/100 grid); the path is re-planned on it.
        ValueError for a rotated map (planning works on axis-aligned grids)."""
        info.check_axis_aligned()
        stamp = 0 if self.map is None else self.map.stamp + 1
        self.map = _MapData(np.asarray(grid), info, stamp)

    def set_goal(self, x: float, y: float, yaw: Optional[float], now: float) -> None:
        """A new goal (map frame) replaces any active one."""
        # async: a robot driving on a path keeps to it until the new goal's first plan
        self.bridging = self.executor is not None and self.status == ACTIVE \
            and self.have_path and self.rotating_left <= 0.0
        self.goal = _Goal(np.array([x, y], dtype=float), yaw, now)
        self.status = ACTIVE
        self.job = None  # a plan in the making is for the old goal: dropped when it lands
        self._reset_goal_state()
        if self.bridging:  # same path, the replaced goal's "reached" state forgotten
            index = self.follower.index
            self.follower.set_path(self.follower.path, self.follower.goal_yaw)
            self.follower.index = index
        else:
            self.follower.set_path(np.zeros((0, 2)))

    def cancel(self) -> None:
        """Drops the goal; the caller sends a zero command."""
        self.goal = None
        self.status = IDLE
        self.job = None
        self.bridging = False
        self.follower.reset()
        self._reset_goal_state()

    def max_command_latency(self) -> float:
        """[s] the longest a command may take from its inputs (pose, scan) to being sent.

        Its arc was checked against the laser for ``obstacle_horizon`` s from the inputs'
        time; once sent, the base may drive it for up to ``base_cmd_timeout`` s before its
        watchdog stops the robot. So it is safe only if sent within the difference."""
        return self.follower.params.obstacle_horizon - self.params.base_cmd_timeout

    def drop_late_command(self, latency: float) -> bool:
        """True if a command whose inputs are ``latency`` s old must not be sent (more than
        ``max_command_latency``, e.g. on a CPU-starved machine); the controller then
        starts from rest and the caller stops the robot instead."""
        if latency <= self.max_command_latency():
            return False
        self.follower.reset()
        return True

    # -- helpers --------------------------------------------------------------------
    def _abort(self, reason: str) -> Step:
        self.status = ABORTED
        self.goal = None
        self.job = None
        self.bridging = False
        self.follower.reset()
        return Step(0.0, 0.0, ABORTED, reason)

    def _world_obstacles(self, pose: Sequence[float], obstacles: Optional[np.ndarray]):
        if obstacles is None or len(obstacles) == 0:
            return np.zeros((0, 2))
        near = obstacles[np.hypot(obstacles[:, 0], obstacles[:, 1]) < self.params.obstacle_range]
        return transform_points(pose, near)

    def _plan(self, pose: Sequence[float], now: float,
              marks: Optional[np.ndarray]) -> pln.PlanResult:
        m = self.map
        result = _make_plan(self.costmaps, m, marks, np.asarray(pose[:2], dtype=float),
                            self.goal.xy)
        self.last_plan_time = now
        self.planned_map = m.stamp
        return result

    def _submit(self, pose: Sequence[float], now: float, marks: Optional[np.ndarray]) -> None:
        """Async: hands a snapshot of the planning inputs to the executor."""
        m = self.map
        self.job = self.executor.submit(_make_plan, self.costmaps, m, marks,
                                        np.array(pose[:2], dtype=float), self.goal.xy.copy())
        self.last_plan_time = now
        self.planned_map = m.stamp

    def _collect(self) -> Optional[pln.PlanResult]:
        """Async: the finished plan for the current goal, if any (else None). A plan for a
        replaced goal never lands here: set_goal/cancel/abort forget its future."""
        job = self.job
        if job is None or not job.done():
            return None
        self.job = None
        return job.result()

    def _replan_due(self, now: float) -> bool:
        f = self.params.planner_frequency
        if not self.have_path:
            return now - self.last_plan_time >= self.params.replan_retry_period \
                or self.planned_map != self.map.stamp
        if f > 0.0 and now - self.last_plan_time >= 1.0 / f:
            return True
        return self.planned_map != self.map.stamp

    # -- the cycle ------------------------------------------------------------------
    def step(self, now: float, pose: Sequence[float], obstacles: Optional[np.ndarray],
             dt: float) -> Step:
        """One control cycle. ``pose`` (x, y, yaw) in the map frame, ``obstacles`` (K, 2)
        laser points in the base frame, ``dt`` [s] since the previous cycle.

        A cycle more than ``base_cmd_timeout`` after the previous one starts the controller
        from rest: the base's watchdog has stopped the robot meanwhile, so the acceleration
        limits count from zero, not from the last command."""
        gap = None if self.last_step_time is None else now - self.last_step_time
        self.last_step_time = now
        if gap is not None and gap > self.params.base_cmd_timeout:
            self.follower.reset()
        if self.status != ACTIVE or self.goal is None:
            self.follower.reset()
            return Step(0.0, 0.0, self.status)
        if self.rotating_left > 0.0:
            return self._rotate(now, pose, obstacles, dt)
        new_path, abort = self._update_plan(now, pose, obstacles)
        if abort:
            return self._abort(abort)
        if not self.have_path and self.bridging and self.job is not None:
            cmd = self.follower.compute(pose, obstacles, dt)  # the replaced goal's path
            if cmd.state == ctl.GOAL_REACHED:  # its end is not this goal's: wait there
                self.follower.reset()
                return Step(0.0, 0.0, ACTIVE, "planning (at the previous path's end)")
            return Step(cmd.v, cmd.w, ACTIVE, "planning (following the previous path)")
        if not self.have_path:  # nothing to follow yet: stand still, keep trying
            self.follower.reset()
            return Step(0.0, 0.0, ACTIVE, "planning: " + self.last_plan_error)
        # a failed re-plan keeps the previous path until planner_patience runs out
        cmd = self.follower.compute(pose, obstacles, dt)
        if cmd.state == ctl.GOAL_REACHED:
            self.status = SUCCEEDED
            self.goal = None
            return Step(0.0, 0.0, SUCCEEDED, "goal reached", new_path, cmd.state)
        self._track_progress(pose)
        if self._stuck(now, pose, cmd.state == ctl.BLOCKED):
            return self._recover(now, pose, new_path)
        return Step(cmd.v, cmd.w, ACTIVE, cmd.state, new_path, cmd.state)

    def _stuck(self, now: float, pose: Sequence[float], blocked: bool) -> bool:
        """True once the robot, blocked at some point, has not got ``oscillation_distance``
        away from there within ``controller_patience`` (inching up to an obstacle and
        stopping again counts as blocked all along)."""
        if blocked and self.blocked_since is None:
            self.blocked_since = now
            self.blocked_at = np.asarray(pose[:2], dtype=float)
        if self.blocked_since is None:
            return False
        if np.hypot(*(np.asarray(pose[:2]) - self.blocked_at)) \
                >= self.params.oscillation_distance:
            self.blocked_since = None
            return False
        return now - self.blocked_since >= self.params.controller_patience

    def _update_plan(self, now: float, pose: Sequence[float], obstacles: Optional[np.ndarray]):
        """Re-plans when due; returns (new path or None, abort reason or "")."""
        new_path = None
        if self.map is None:
            self.last_plan_error = "waiting for a map"
            self.plan_fail_since = self.goal.received
        else:
            result = None
            if self.executor is not None:
                result = self._collect()
                if self.job is None and result is None and self._replan_due(now):
                    marks = self._world_obstacles(pose, obstacles) \
                        if self.recovery_stage else None
                    self._submit(pose, now, marks)
            elif self._replan_due(now):
                marks = self._world_obstacles(pose, obstacles) if self.recovery_stage else None
                result = self._plan(pose, now, marks)
            if result is None:
                pass
            elif result.failure == pln.INVALID_GOAL:
                return None, result.reason
            elif result.ok:
                # the goal's first path starts afresh (a bridged path's state is not ours)
                self.follower.set_path(result.path, self.goal.yaw,
                                       keep_goal_state=self.have_path)
                self.plan_fail_since = None
                self.have_path = True
                self.bridging = False
                new_path = result.path
            else:
                self.last_plan_error = result.reason
                if self.plan_fail_since is None:
                    self.plan_fail_since = now
        if self.plan_fail_since is not None \
                and now - self.plan_fail_since >= self.params.planner_patience:
            return new_path, "no plan for %.1f s: %s" % (now - self.plan_fail_since,
                                                         self.last_plan_error)
        return new_path, ""

    def _track_progress(self, pose: Sequence[float]) -> None:
        if self.recovery_anchor is None:
            return
        if np.hypot(*(np.asarray(pose[:2]) - self.recovery_anchor)) \
                >= self.params.progress_reset_distance:
            self.recovery_stage = 0
            self.recovery_anchor = None

    def _recover(self, now: float, pose: Sequence[float], new_path) -> Step:
        p = self.params
        self.blocked_since = None
        self.follower.reset()
        if not p.recovery_behavior_enabled or self.recovery_stage >= 2 \
                or (self.recovery_stage == 1 and not p.clearing_rotation_allowed):
            return self._abort("blocked by an obstacle for %.1f s; recovery behaviours "
                               "failed" % p.controller_patience)
        self.recovery_stage += 1
        self.recovery_anchor = np.asarray(pose[:2], dtype=float)
        if self.recovery_stage == 1:
            self.planned_map = -1  # re-plan now, with the laser obstacles marked
            return Step(0.0, 0.0, ACTIVE, "recovery: re-planning around laser obstacles",
                        new_path, ctl.BLOCKED)
        self.rotating_left = 2.0 * np.pi
        self.rotation_obstacles = []
        return Step(0.0, 0.0, ACTIVE, "recovery: clearing rotation", new_path, ctl.ROTATING)

    def _rotate(self, now: float, pose: Sequence[float], obstacles, dt: float) -> Step:
        """The clearing rotation; re-plans with everything seen once it is done."""
        self.rotation_obstacles.append(self._world_obstacles(pose, obstacles))
        w = self.params.rotation_speed
        self.rotating_left -= w * dt
        if self.rotating_left > 0.0:
            return Step(0.0, w, ACTIVE, "recovery: clearing rotation", None, ctl.ROTATING)
        self.rotating_left = 0.0
        marks = np.concatenate(self.rotation_obstacles + [np.zeros((0, 2))])
        self.rotation_obstacles = []
        result = self._plan(pose, now, marks)
        if not result.ok:
            return self._abort("no path after the clearing rotation: %s" % result.reason)
        self.follower.set_path(result.path, self.goal.yaw, keep_goal_state=True)
        self.have_path = True
        return Step(0.0, 0.0, ACTIVE, "recovery: re-planned", result.path, ctl.ROTATING)

    @property
    def path(self) -> np.ndarray:
        return self.follower.path

    def describe(self) -> dict:
        """State for logs and tests."""
        return {"status": self.status, "recovery_stage": self.recovery_stage,
                "have_path": self.have_path, "last_plan_error": self.last_plan_error}
