"""The integrated exploration loop of fig. 2.7 as a pure state machine (no ROS).

The node feeds it the newest map, robot position, pose entropy, whether move_base is up
and the outcome of the last goal; each `step()` returns what to do (send a goal, cancel,
nothing) and the status to publish. Rules:

* plan x* = argmax U (or the nearest candidate) whenever there is no active goal, and on
  every new map; an active goal is kept while it is still a frontier (a candidate goal or a
  filtered frontier cell within `goal_frontier_tolerance_m`) and the robot makes progress;
* an active goal that is no longer a frontier (the frontier receded ahead of the robot) is
  kept while it stays useful: the robot's path to it is longer than `goal_near_m`, the
  laser would still see at least `min_info_gain_m2` of unknown area from it, and no
  candidate is much better: the best candidate's U is at most (1 + `goal_hysteresis`)
  times the goal's own U, evaluated on the new map (`nearest`: the goal's path is at most
  (1 + `goal_hysteresis`) times the nearest candidate's). Otherwise the best candidate is
  sent. `goal_hysteresis` < 0 turns this off (a goal is dropped as soon as it is no
  longer a frontier);
* a goal is blacklisted when move_base aborts/rejects it, when the robot's path length to it
  has not shrunk by `progress_min_m` within `progress_timeout_s`, and also once reached (a
  reached point is never sent again, so an unobservable frontier cannot trap the robot);
* nothing left to explore (no candidate, all blacklisted, or none worth its trip) on
  `done_confirmations` plans in a row: cancel the goal, go back
  to the start pose if `return_to_start`, then publish `done` and stop;
* active loop closing (`loop_revisit_path_m` > 0, off by default; after Stachniss, Hähnel
  and Burgard's exploration with active loop-closing for RBPF mapping): when the robot
  comes within `loop_revisit_radius_m` of a place on its own path that lies more than
  `loop_revisit_path_m` back along it, and its recent path (the last `loop_revisit_path_m`)
  has not come within `LOOP_REVISIT_NEAR_M` of that place, nor is the robot standing on
  such old ground already (driving back along a corridor), it first drives there, so
  that the mapper's scans overlap the old ones where the loop joins instead of only
  touching them; the places within `loop_revisit_radius_m` of that goal are not visited
  again. The goal is neither blacklisted nor counted as a frontier; it ends with its
  outcome or after `progress_timeout_s`;
* start / stop (pause) / resume through `start()` and `stop()`; a stopped explorer cancels
  its goal and sends nothing; start() after done begins a fresh exploration.
Bad input (no map, robot off the map or not in free space, move_base missing) only changes
the status; no goal is sent then.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import nested, param

from .frontiers import STATUS_NO_FRONTIERS, STATUS_OK
from .goal_selection import STATUS_ALL_BLACKLISTED, STATUS_NO_GAIN, Plan, PlannerParams, plan
from .utility import score_candidates

# Published statuses.
IDLE = "idle"
EXPLORING = "exploring"
RETURNING = "returning"
DONE = "done"
WAITING_MAP = "waiting_for_map"
WAITING_POSE = "waiting_for_pose"
WAITING_MOVE_BASE = "waiting_for_move_base"

# Goal outcomes reported by the node (from actionlib's terminal states).
SUCCEEDED = "succeeded"
ABORTED = "aborted"
REJECTED = "rejected"
PREEMPTED = "preempted"
LOST = "lost"                      # server went away or any other terminal state

SEND = "send"
CANCEL = "cancel"
NONE = "none"


@dataclass
class ExplorerParams:
    """The loop's rules (``ascc_common.params``)."""

    progress_timeout_s: float = param(30.0, "[s] no progress for this long -> blacklist")
    progress_min_m: float = param(0.3, "[m] progress = path length shrinks by this")
    goal_frontier_tolerance_m: float = param(0.5, "[m] goal still a frontier if a candidate "
                                             "is closer")
    goal_hysteresis: float = param(0.5, "[-] keep a goal that is no longer a frontier "
                                   "unless a candidate scores this much better (< 0: off)")
    goal_near_m: float = param(1.0, "[m] ... and unless the robot's path to it is shorter")
    done_confirmations: int = param(2, "empty plans in a row before finishing")
    return_to_start: bool = param(False, "drive back to the start pose when done")
    start_tolerance_m: float = param(0.5, "[m] already at the start if closer than this")
    loop_revisit_path_m: float = param(0.0, "[m] active loop closing: a place on the "
                                       "robot's path at least this far back along it, met "
                                       "again, is driven to first (0: off)", ge=0.0)
    loop_revisit_radius_m: float = param(5.0, "[m] ... when the robot comes this close to "
                                         "it", gt=0.0)


# active loop closing: a place the robot's recent path came this close to is being
# revisited already (driving back along a corridor just explored is no loop) [m]
LOOP_REVISIT_NEAR_M = 1.5
# the robot's path is recorded in steps of this length [m]
PATH_STEP_M = 0.25


@dataclass
class ExplorerNodeParams:
    """Everything the frontier_explorer node reads (private parameters)."""

    planner: PlannerParams = nested(PlannerParams)
    explorer: ExplorerParams = nested(ExplorerParams)
    robot_frame: str = param("base_link", "robot frame looked up in the map's frame")
    free_max_percent: int = param(19, "[%] occupancy up to which a cell is free")
    occupied_min_percent: int = param(65, "[%] occupancy from which a cell is occupied")
    tf_timeout_s: float = param(0.2, "[s] wait for the robot's transform")
    max_marker_points: int = param(5000, "points per marker namespace (subsampled)")
    shutdown_when_done: bool = param(False, "exit after done")
    planning_period_s: float = param(1.0, "[s] planning timer period", gt=0.0)
    autostart: bool = param(True, "explore without ~start")


@dataclass
class Decision:
    action: str                                   # SEND, CANCEL or NONE
    status: str
    goal_xy: Optional[Tuple[float, float]] = None
    reason: str = ""
    plan: Optional[Plan] = None
    goal_yaw: Optional[float] = None       # heading at the goal [rad]; None: caller picks


@dataclass
class _Goal:
    xy: Tuple[float, float]
    sent_at: float
    best_path_m: float = math.inf
    improved_at: float = 0.0
    to_start: bool = False
    revisit: bool = False          # active loop closing's goal (not a frontier)


@dataclass
class ExplorationController:
    params: ExplorerParams = field(default_factory=ExplorerParams)
    planner: PlannerParams = field(default_factory=PlannerParams)
    state: str = IDLE
    blacklist: List[Tuple[float, float]] = field(default_factory=list)
    goals_sent: int = 0
    goals_kept: int = 0              # plans that kept a goal no longer on a frontier
    start_xy: Optional[Tuple[float, float]] = None
    _goal: Optional[_Goal] = None
    _outcome: Optional[str] = None
    _empty_plans: int = 0
    _last_map_stamp: Optional[float] = None
    _paused: bool = False
    loops_revisited: int = 0         # active loop closing's goals sent
    # the robot's path (x, y, path length [m]) and, per point, whether its place was
    # revisited (or is being revisited) already
    _path: List[Tuple[float, float, float]] = field(default_factory=list)
    _closed: List[bool] = field(default_factory=list)

    # ---- commands ---------------------------------------------------------------
    def start(self) -> None:
        """Start, or resume after stop(); after done, begin a fresh exploration."""
        if self.state == DONE:
            self.blacklist.clear()
            self.start_xy = None
            self._path.clear()
            self._closed.clear()
        self._paused = False
        self._empty_plans = 0
        self._last_map_stamp = None
        self.state = EXPLORING

    def stop(self) -> bool:
        """Pause; returns True if a goal is active and must be cancelled by the caller."""
        self._paused = True
        self.state = IDLE if self.state != DONE else DONE
        active = self._goal is not None
        self._goal = None
        return active

    def report_outcome(self, outcome: str) -> None:
        """Terminal state of the goal sent last (from the action client's done callback)."""
        self._outcome = outcome

    @property
    def active_goal(self) -> Optional[Tuple[float, float]]:
        return None if self._goal is None else self._goal.xy

    # ---- the loop -----------------------------------------------------------------
    def step(self, now: float, grid: Optional[np.ndarray], info: Optional[GridInfo],
             robot_xy: Optional[Tuple[float, float]], map_stamp: Optional[float],
             move_base_ready: bool, entropy: Optional[float] = None) -> Decision:
        """One planning tick; see the module docstring for the rules."""
        if self._paused or self.state in (IDLE, DONE):
            return Decision(NONE, self.state)
        outcome, self._outcome = self._outcome, None
        if outcome is not None and self._goal is not None:
            done = self._handle_outcome(outcome)
            if done is not None:
                return done
        if not move_base_ready:
            self._goal = None              # whatever was active died with the server
            return Decision(NONE, WAITING_MOVE_BASE, reason="move_base action server not up")
        if grid is None or info is None:
            return Decision(NONE, WAITING_MAP, reason="no map received yet")
        if robot_xy is None:
            return Decision(NONE, WAITING_POSE, reason="no map -> base_link transform")
        if self.start_xy is None:
            self.start_xy = (float(robot_xy[0]), float(robot_xy[1]))
        if self.state == RETURNING:
            return Decision(NONE, RETURNING)
        if self.params.loop_revisit_path_m > 0.0:
            self._record(robot_xy)
            revisit = self._revisit(now, robot_xy)
            if revisit is not None:
                return revisit
        new_map = map_stamp != self._last_map_stamp
        if self._goal is not None and not new_map and not self._stalled(now):
            return Decision(NONE, EXPLORING)
        self._last_map_stamp = map_stamp
        result = plan(grid, info, robot_xy, self.planner, entropy, self.blacklist)
        return self._decide(now, result, robot_xy, grid, entropy)

    # ---- helpers ------------------------------------------------------------------
    def _handle_outcome(self, outcome: str) -> Optional[Decision]:
        goal = self._goal
        assert goal is not None
        if outcome == PREEMPTED:
            return None                    # we replaced it ourselves
        self._goal = None
        if goal.revisit:
            return None                    # loop closed (or not reachable): explore on
        if goal.to_start:
            self.state = DONE
            why = "back at the start pose" if outcome == SUCCEEDED else \
                f"return to start {outcome}; stopping where we are"
            return Decision(NONE, DONE, reason=why)
        self.blacklist.append(goal.xy)     # reached or failed: never send it again
        return None

    def _record(self, robot_xy: Tuple[float, float]) -> None:
        """Append the robot's position to its path every PATH_STEP_M."""
        x, y = float(robot_xy[0]), float(robot_xy[1])
        if not self._path:
            self._path.append((x, y, 0.0))
            self._closed.append(False)
            return
        px, py, s = self._path[-1]
        step = math.hypot(x - px, y - py)
        if step >= PATH_STEP_M:
            self._path.append((x, y, s + step))
            self._closed.append(False)

    def loop_to_close(self, robot_xy: Tuple[float, float]
                      ) -> Optional[Tuple[Tuple[float, float], float]]:
        """Active loop closing's goal and how far back along the path it lies [m], or None:
        the nearest place of the robot's path at least ``loop_revisit_path_m`` back along
        it, within ``loop_revisit_radius_m``, not revisited yet, and not near its recent
        path (module docstring); none while the robot is on such old ground already (within
        ``LOOP_REVISIT_NEAR_M``). Marks the old places within ``loop_revisit_radius_m`` of
        the goal (or of the robot, on old ground) as revisited."""
        p = self.params
        if len(self._path) < 2:
            return None
        path = np.asarray(self._path)
        closed = np.asarray(self._closed)
        recent = path[:, 2] > path[-1, 2] - p.loop_revisit_path_m
        if recent.all():
            return None
        d = np.hypot(path[:, 0] - robot_xy[0], path[:, 1] - robot_xy[1])
        if d[~recent].min() <= LOOP_REVISIT_NEAR_M:
            # on old ground already (driving back along a corridor): nothing to revisit
            self._close(~recent & (d <= p.loop_revisit_radius_m))
            return None
        candidates = ~recent & ~closed & (d <= p.loop_revisit_radius_m)
        if not candidates.any():
            return None
        k = int(np.argmin(np.where(candidates, d, np.inf)))
        target = path[k, :2]
        self._close(~recent & (np.hypot(path[:, 0] - target[0], path[:, 1] - target[1])
                               <= p.loop_revisit_radius_m))
        if np.hypot(path[recent, 0] - target[0], path[recent, 1] - target[1]).min() \
                <= LOOP_REVISIT_NEAR_M:
            return None                    # the recent path runs on into it
        return (float(target[0]), float(target[1])), float(path[-1, 2] - path[k, 2])

    def _close(self, mask: np.ndarray) -> None:
        """Mark the path's places ``mask`` as revisited."""
        self._closed = (np.asarray(self._closed) | mask).tolist()

    def _revisit(self, now: float, robot_xy: Tuple[float, float]) -> Optional[Decision]:
        """Active loop closing: keep its goal while it lasts, or send a new one."""
        g = self._goal
        if g is not None and g.revisit:
            if not self._stalled(now):     # its improved_at stays the time it was sent
                return Decision(NONE, EXPLORING, reason="closing a loop")
            self._goal = None              # not reached in time: explore on
            return None
        found = self.loop_to_close(robot_xy)
        if found is None:
            return None
        target, back_m = found
        self._goal = _Goal(target, now, improved_at=now, revisit=True)
        self.goals_sent += 1
        self.loops_revisited += 1
        return Decision(SEND, EXPLORING, target,
                        "closing a loop: back to (%.2f, %.2f), where the robot was %.0f m "
                        "of path ago" % (target[0], target[1], back_m))

    def _stalled(self, now: float) -> bool:
        g = self._goal
        return g is not None and now - g.improved_at > self.params.progress_timeout_s

    def _decide(self, now: float, result: Plan, robot_xy: Tuple[float, float],
                grid: Optional[np.ndarray] = None, entropy: Optional[float] = None
                ) -> Decision:
        if result.status in (STATUS_NO_FRONTIERS, STATUS_ALL_BLACKLISTED, STATUS_NO_GAIN):
            self._empty_plans += 1
            if self._empty_plans < self.params.done_confirmations:
                return Decision(NONE, EXPLORING, reason=result.status, plan=result)
            return self._finish(now, robot_xy, result)
        if result.status != STATUS_OK:
            # Robot off the map / not in free space / empty map: keep any active goal.
            return Decision(NONE, result.status, reason=result.status, plan=result)
        self._empty_plans = 0
        g = self._goal
        if g is not None:
            path = self._path_to(result, g.xy)
            if path < g.best_path_m - self.params.progress_min_m or not math.isfinite(
                    g.best_path_m):
                g.best_path_m, g.improved_at = path, now
            if now - g.improved_at > self.params.progress_timeout_s:
                self.blacklist.append(g.xy)
                self._goal = None
                reason = f"no progress towards ({g.xy[0]:.2f}, {g.xy[1]:.2f}); blacklisted"
                return self._send_best(now, result, reason, replan=True)
            if self._still_frontier(result, g.xy):
                return Decision(NONE, EXPLORING, plan=result)
            if grid is not None and self._still_useful(result, g.xy, path, grid, entropy):
                self.goals_kept += 1
                return Decision(NONE, EXPLORING, reason="goal kept: still useful", plan=result)
            return self._send_best(now, result, "goal is no longer a frontier")
        return self._send_best(now, result, "new goal")

    def _send_best(self, now: float, result: Plan, reason: str, replan: bool = False
                   ) -> Decision:
        if replan:
            # The plan was made with the old blacklist: mask the newly blacklisted point.
            bx, by = self.blacklist[-1]
            d = np.hypot(result.goals_xy[:, 0] - bx, result.goals_xy[:, 1] - by)
            scores = result.scores
            assert scores is not None
            keep = result.allowed & (d > self.planner.blacklist_radius_m) & np.isfinite(
                scores.path_m)
            if not keep.any():
                return Decision(CANCEL, EXPLORING, reason=reason, plan=result)
            scores.best = int(np.argmax(np.where(keep, scores.total, -np.inf)))
            result.allowed = keep
        goal = result.goal_xy
        if goal is None:
            return Decision(NONE, EXPLORING, reason=reason, plan=result)
        self._goal = _Goal(goal, now, improved_at=now,
                           best_path_m=float(result.scores.path_m[result.best]))
        self.goals_sent += 1
        return Decision(SEND, EXPLORING, goal, reason, result, result.goal_yaw)

    def _finish(self, now: float, robot_xy: Tuple[float, float], result: Plan) -> Decision:
        self._goal = None
        if self.params.return_to_start and self.start_xy is not None and math.hypot(
                robot_xy[0] - self.start_xy[0], robot_xy[1] - self.start_xy[1]
        ) > self.params.start_tolerance_m:
            self.state = RETURNING
            self._goal = _Goal(self.start_xy, now, improved_at=now, to_start=True)
            self.goals_sent += 1
            return Decision(SEND, RETURNING, self.start_xy, "exploration finished", result)
        self.state = DONE
        return Decision(CANCEL, DONE, reason="nothing left to explore", plan=result)

    @staticmethod
    def _path_to(result: Plan, xy: Tuple[float, float]) -> float:
        ix, iy = result.info.world_to_cell(xy[0], xy[1])
        return float(result.frontiers.path_length_m(np.array([iy]), np.array([ix]))[0])

    def _still_useful(self, result: Plan, xy: Tuple[float, float], path_m: float,
                      grid: np.ndarray, entropy: Optional[float]) -> bool:
        """The hysteresis rule for a goal that is no longer a frontier (module docstring)."""
        p = self.params
        scores = result.scores
        if p.goal_hysteresis < 0.0 or scores is None or result.best < 0:
            return False
        if not math.isfinite(path_m) or path_m <= p.goal_near_m:
            return False
        u = self.planner.utility
        ix, iy = result.info.world_to_cell(xy[0], xy[1])
        w_s = result.scenario.w_scenario if result.scenario is not None else 1.0
        own = score_candidates(grid, result.info.resolution, np.array([iy]), np.array([ix]),
                               np.array([path_m]), np.array([1]), u, "utility", w_s, entropy)
        gain_m2 = float(own.info[0]) * math.pi * u.sensor_range_m ** 2
        if gain_m2 < max(u.min_info_gain_m2, 1e-9):
            return False                   # nothing left to see from there
        if self.planner.strategy == "nearest":
            return path_m <= (1.0 + p.goal_hysteresis) * float(scores.path_m[result.best])
        return float(scores.total[result.best]) <= (1.0 + p.goal_hysteresis) * float(
            own.total[0])

    def _still_frontier(self, result: Plan, xy: Tuple[float, float]) -> bool:
        """A candidate goal or a filtered frontier cell within the tolerance of xy."""
        tol2 = self.params.goal_frontier_tolerance_m ** 2
        goals = result.goals_xy[result.allowed] if result.goals_xy.shape[0] else result.goals_xy
        if goals.shape[0] and float(((goals - np.asarray(xy)) ** 2).sum(axis=1).min()) <= tol2:
            return True
        cells = result.frontiers.phase2_rc
        if cells.shape[0] == 0:
            return False
        c, r = result.info.world_to_cell(xy[0], xy[1])
        res = result.info.resolution
        d2 = ((cells[:, 0] - r) ** 2 + (cells[:, 1] - c) ** 2).astype(np.float64) * res * res
        return bool(d2.min() <= tol2)
