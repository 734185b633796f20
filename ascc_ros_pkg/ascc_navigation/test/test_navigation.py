"""Tests of the move_base state machine (pure code, no ROS master)."""

import numpy as np
import pytest

from ascc_common.grid import OCCUPIED
from ascc_common.params import from_params, tree_getter
from ascc_navigation import controller as ctl
from ascc_navigation import navigation as nav
from ascc_navigation import planner as pln
from ascc_navigation import synthetic as syn

DT = 0.1


@pytest.fixture(scope="module")
def office():
    return syn.office_world()


def _drive(pose, step):
    """Moves a unicycle pose (in place) by one step's command for DT."""
    pose += [step.v * DT * np.cos(pose[2]), step.v * DT * np.sin(pose[2]), step.w * DT]


def _run(navigator, pose, t0=0.0, seconds=120.0, obstacles=None):
    """Drives a unicycle with the navigator's commands; returns (last step, pose, steps)."""
    pose = np.array(pose, dtype=float)
    steps, t = [], t0
    while t - t0 < seconds:
        obs = obstacles(pose) if obstacles else None
        step = navigator.step(t, pose, obs, DT)
        steps.append(step)
        if step.status != nav.ACTIVE:
            break
        _drive(pose, step)
        t += DT
    return steps[-1], pose, steps


def test_goal_yaw_validation():
    assert nav.goal_yaw(0.0, 0.0, np.sin(0.4), np.cos(0.4)) == pytest.approx(0.8)
    assert nav.goal_yaw(0.0, 0.0, 0.0, 2.0) == pytest.approx(0.0)  # not normalised: fine
    for bad in [(0.0, 0.0, 0.0, 0.0), (np.nan, 0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0)]:
        with pytest.raises(ValueError):
            nav.goal_yaw(*bad)


def test_reaches_a_goal_in_the_office(office):
    navigator = nav.Navigator()
    navigator.set_map(*office)
    navigator.set_goal(8.0, 8.4, np.pi / 2, 0.0)
    last, pose, steps = _run(navigator, (2.0, 2.0, 0.0))
    assert last.status == nav.SUCCEEDED, last.reason
    assert np.hypot(pose[0] - 8.0, pose[1] - 8.4) <= ctl.ControllerParams().xy_goal_tolerance
    assert steps[0].new_path is not None and len(steps[0].new_path) > 10
    assert navigator.step(100.0, pose, None, DT).status == nav.SUCCEEDED  # stays done


def test_waits_for_a_map_then_aborts_after_planner_patience():
    navigator = nav.Navigator(params=nav.NavParams(planner_patience=2.0))
    navigator.set_goal(1.0, 1.0, None, 10.0)
    last, _, steps = _run(navigator, (0.0, 0.0, 0.0), t0=10.0, seconds=10.0)
    assert last.status == nav.ABORTED and "waiting for a map" in last.reason
    assert (len(steps) - 1) * DT == pytest.approx(2.0, abs=DT + 1e-6)
    assert all(s.v == 0.0 and s.w == 0.0 for s in steps)


def test_unreachable_goal_aborts_after_planner_patience(office):
    grid, info = office
    sealed = grid.copy()
    sealed[160:162, 256:] = OCCUPIED  # closet walls: y 8.0 .. 8.1, x 12.8 ..
    sealed[160:, 256:258] = OCCUPIED
    navigator = nav.Navigator()
    navigator.set_map(sealed, info)
    navigator.set_goal(13.4, 9.0, 0.0, 0.0)
    last, _, steps = _run(navigator, (2.0, 2.0, 0.0))
    assert last.status == nav.ABORTED and "not reachable" in last.reason
    assert len(steps) * DT <= nav.NavParams().planner_patience + 0.2


def test_invalid_goals_abort_at_once(office):
    for goal, why in [((30.0, 1.0), "outside the map"), ((7.0, 4.2), "obstacle")]:
        navigator = nav.Navigator()
        navigator.set_map(*office)
        navigator.set_goal(goal[0], goal[1], None, 0.0)
        step = navigator.step(0.0, (2.0, 2.0, 0.0), None, DT)
        assert step.status == nav.ABORTED and why in step.reason


def test_map_update_triggers_a_replan(office):
    navigator = nav.Navigator()
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    assert navigator.step(0.0, (2.0, 2.0, 0.0), None, DT).new_path is not None
    assert navigator.step(0.1, (2.0, 2.0, 0.0), None, DT).new_path is None
    grid, info = office
    blocked = grid.copy()
    blocked[2:60, 160:164] = OCCUPIED  # wall across the south corridor at x = 8 m
    navigator.set_map(blocked, info)
    path = navigator.step(0.2, (2.0, 2.0, 0.0), None, DT).new_path
    assert path is not None and path[:, 1].max() > 5.5  # now around the north side


def test_replans_on_updated_maps_equal_plans_on_fresh_costmaps(office):
    """The navigator keeps one costmap and updates it incrementally: its plans after a
    series of map edits (walls added and removed again) are those of a fresh costmap."""
    grid, info = office
    navigator = nav.Navigator()
    navigator.set_map(grid, info)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    navigator.step(0.0, (2.0, 2.0, 0.0), None, DT)
    t = 0.0
    edits = [((slice(2, 60), slice(160, 164)), OCCUPIED), ((slice(2, 60), slice(160, 164)), 0),
             ((slice(30, 34), slice(60, 200)), -1)]
    for k, (rows, value) in enumerate(edits):
        grid = grid.copy()
        grid[rows] = value
        navigator.set_map(grid, info)
        t += 0.1
        path = navigator.step(t, (2.0, 2.0, 0.0), None, DT).new_path
        fresh = pln.plan(pln.Costmap(grid, info, navigator.planner_params), (2.0, 2.0),
                         (12.0, 2.0))
        assert path is not None and fresh.ok, k
        assert np.array_equal(path, fresh.path), k


def test_cancel_stops_and_idles(office):
    navigator = nav.Navigator()
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    for k in range(5):
        navigator.step(k * DT, (2.0, 2.0, 0.0), None, DT)
    navigator.cancel()
    step = navigator.step(1.0, (2.0, 2.0, 0.0), None, DT)
    assert step.status == nav.IDLE and step.v == 0.0 and step.w == 0.0


def test_blocked_robot_recovers_then_aborts(office):
    """An obstacle that stays 0.2 m ahead of the robot whatever it does (a stuck sensor):
    re-plan, then a full clearing rotation, then abort with a reason."""
    params = nav.NavParams(controller_patience=1.0)
    navigator = nav.Navigator(params=params)
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    stuck = np.array([[0.2, 0.0], [0.2, 0.1], [0.2, -0.1]])
    last, pose, steps = _run(navigator, (2.0, 2.0, 0.0), obstacles=lambda p: stuck)
    # what the rotation saw (the phantom all around) leaves no way out
    assert last.status == nav.ABORTED and "after the clearing rotation" in last.reason
    reasons = [s.reason for s in steps]
    assert any("re-planning" in r for r in reasons)
    rotation = [s for s in steps if s.reason == "recovery: clearing rotation"]
    turned = sum(s.w for s in rotation) * DT
    assert turned == pytest.approx(2 * np.pi, abs=params.rotation_speed * DT)
    assert all(s.v == 0.0 for s in steps if s.controller_state == ctl.BLOCKED)
    assert len(steps) * DT < 30.0


def test_box_missing_from_the_map_is_avoided_after_replanning(office):
    grid, info = office
    box = np.array([[x, y] for x in np.arange(7.6, 8.25, 0.05)
                    for y in np.arange(1.4, 2.65, 0.05)])  # blocks the straight line

    def laser(pose):  # points of the box within 4 m, in the base frame (no occlusion)
        c, s = np.cos(pose[2]), np.sin(pose[2])
        d = box - pose[:2]
        pts = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
        return pts[np.hypot(pts[:, 0], pts[:, 1]) < 4.0]

    navigator = nav.Navigator(params=nav.NavParams(controller_patience=1.0))
    navigator.set_map(grid, info)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    last, pose, steps = _run(navigator, (2.0, 2.0, 0.0), obstacles=laser)
    assert last.status == nav.SUCCEEDED, last.reason
    assert any(s.controller_state == ctl.BLOCKED for s in steps)  # it did meet the box


def test_params_from_move_base_names():
    tree = {"planner_patience": 7.0, "NavfnROS": {"allow_unknown": False},
            "TrajectoryPlannerROS": {"max_vel_x": 0.2},
            "global_costmap": {"robot_radius": 0.2,
                               "inflation_layer": {"inflation_radius": 0.8}},
            "stand_in": {"planner_resolution": 0.05}}
    p = from_params(nav.MoveBaseParams, tree_getter(tree))
    planner, controller, params = p.planner, p.controller, p.nav
    assert params.planner_patience == 7.0
    assert planner.allow_unknown is False and planner.resolution == 0.05
    assert planner.robot_radius == 0.2 and controller.robot_radius == 0.2
    assert planner.inflation_radius == 0.8 and controller.max_vel_x == 0.2
    assert controller.acc_lim_x == ctl.ControllerParams().acc_lim_x  # default kept


def test_blocked_twice_without_rotation_aborts(office):
    params = nav.NavParams(controller_patience=1.0, clearing_rotation_allowed=False)
    navigator = nav.Navigator(params=params)
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    stuck = np.array([[0.2, 0.0]])
    last, _, steps = _run(navigator, (2.0, 2.0, 0.0), obstacles=lambda p: stuck)
    assert last.status == nav.ABORTED and "recovery behaviours failed" in last.reason
    assert not any("rotation" in s.reason for s in steps)


def _cruising(office):
    """A navigator driving at full speed along a straight corridor of the office."""
    navigator = nav.Navigator()
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    _, pose, steps = _run(navigator, (2.0, 2.0, 0.0), seconds=3.0)
    assert steps[-1].v == pytest.approx(ctl.ControllerParams().max_vel_x, abs=0.01)
    return navigator, pose, len(steps) * DT


def test_cycle_after_a_stall_starts_from_rest(office):
    """A control cycle later than the base's watchdog (the robot was stopped meanwhile)
    accelerates from zero; a punctual one continues at speed."""
    acc = ctl.ControllerParams().acc_lim_x
    navigator, pose, t = _cruising(office)
    assert navigator.step(t + DT, pose, None, DT).v == pytest.approx(0.3, abs=0.01)
    navigator, pose, t = _cruising(office)
    late = navigator.step(t + navigator.params.base_cmd_timeout + 0.1, pose, None, DT)
    assert late.status == nav.ACTIVE and 0.0 < late.v <= acc * DT + 1e-9


def test_late_command_is_dropped_and_the_controller_restarts(office):
    navigator, pose, t = _cruising(office)
    limit = navigator.max_command_latency()
    assert limit == pytest.approx(ctl.ControllerParams().obstacle_horizon
                                  - nav.NavParams().base_cmd_timeout)
    assert not navigator.drop_late_command(0.9 * limit)
    assert navigator.step(t, pose, None, DT).v == pytest.approx(0.3, abs=0.01)  # still at speed
    assert navigator.drop_late_command(1.1 * limit)
    after = navigator.step(t + DT, pose, None, DT)
    assert after.status == nav.ACTIVE and 0.0 < after.v <= ctl.ControllerParams().acc_lim_x * DT


def test_base_cmd_timeout_from_move_base_names():
    tree = {"stand_in": {"base_cmd_timeout_s": 0.3}}
    params = from_params(nav.MoveBaseParams, tree_getter(tree)).nav
    assert params.base_cmd_timeout == 0.3


# -- planning off the control loop (executor) -------------------------------------------
class _Deferred:
    """An executor whose jobs run only when the test says so (a slow planner thread)."""

    class Future:
        def __init__(self, fn, args):
            self.fn, self.args, self.value, self.ran = fn, args, None, False

        def done(self):
            return self.ran

        def result(self):
            return self.value

    def __init__(self):
        self.jobs = []

    def submit(self, fn, *args):
        job = self.Future(fn, args)
        self.jobs.append(job)
        return job

    def run_all(self):
        for job in self.jobs:
            if not job.ran:
                job.value, job.ran = job.fn(*job.args), True


def test_async_planning_with_a_thread_reaches_the_goal(office):
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=1) as executor:
        navigator = nav.Navigator(executor=executor)
        navigator.set_map(*office)
        navigator.set_goal(8.0, 8.4, np.pi / 2, 0.0)
        pose = np.array((2.0, 2.0, 0.0))
        last = None
        for k in range(2000):
            last = navigator.step(k * DT, pose, None, DT)
            if last.status != nav.ACTIVE:
                break
            _drive(pose, last)
            if navigator.job is not None:
                navigator.job.result()  # deterministic: wait as a fast planner would
    assert last.status == nav.SUCCEEDED, last.reason
    assert np.hypot(pose[0] - 8.0, pose[1] - 8.4) <= ctl.ControllerParams().xy_goal_tolerance


def test_async_planning_stands_still_until_the_first_plan(office):
    executor = _Deferred()
    navigator = nav.Navigator(executor=executor)
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    for k in range(3):  # the plan is being made: nothing to follow, no second job
        step = navigator.step(k * DT, (2.0, 2.0, 0.0), None, DT)
        assert step.status == nav.ACTIVE and step.v == 0.0 and step.new_path is None
    assert len(executor.jobs) == 1
    executor.run_all()
    step = navigator.step(0.3, (2.0, 2.0, 0.0), None, DT)
    assert step.new_path is not None and np.allclose(step.new_path[-1], (12.0, 2.0), atol=0.1)
    step = navigator.step(0.4, (2.0, 2.0, 0.0), None, DT)
    assert step.v > 0.0


def _async_navigator(office, goal_x, goal_y):
    """A navigator on a deferred executor, at (2, 2) heading east, whose first plan (to
    the goal) has been made: (executor, navigator, pose)."""
    executor = _Deferred()
    navigator = nav.Navigator(executor=executor)
    navigator.set_map(*office)
    navigator.set_goal(goal_x, goal_y, None, 0.0)
    pose = np.array((2.0, 2.0, 0.0))
    navigator.step(0.0, pose, None, DT)
    executor.run_all()
    return executor, navigator, pose


def test_async_replaced_goal_keeps_the_robot_on_its_path_until_the_new_plan(office):
    executor, navigator, pose = _async_navigator(office, 12.0, 2.0)
    for k in range(1, 30):  # drive east along the south corridor
        step = navigator.step(k * DT, pose, None, DT)
        _drive(pose, step)
    assert step.v > 0.1
    old_path = navigator.path.copy()
    navigator.set_goal(8.0, 8.4, None, 3.0)  # its plan is slow in coming
    for k in range(5):
        step = navigator.step(3.0 + k * DT, pose, None, DT)
        assert step.status == nav.ACTIVE and step.v > 0.1, step.reason
        assert "previous path" in step.reason
        _drive(pose, step)
    assert np.array_equal(navigator.path, old_path)
    executor.run_all()
    step = navigator.step(3.5, pose, None, DT)
    assert step.new_path is not None and np.allclose(step.new_path[-1], (8.0, 8.4), atol=0.1)


def test_async_bridge_never_reports_the_old_path_end_as_success(office):
    executor, navigator, pose = _async_navigator(office, 3.0, 2.0)
    navigator.step(0.1, pose, None, DT)
    navigator.set_goal(12.0, 2.0, None, 0.2)  # replaced; its plan never comes here
    for k in range(100):  # 10 s: far longer than the 1 m to the old path's end
        step = navigator.step(0.3 + k * DT, pose, None, DT)
        assert step.status == nav.ACTIVE
        _drive(pose, step)
    assert step.v == 0.0 and "previous path's end" in step.reason
    assert pose[0] < 3.3  # waited at the old end, did not wander


def test_async_result_for_a_replaced_goal_is_dropped(office):
    executor = _Deferred()
    navigator = nav.Navigator(executor=executor)
    navigator.set_map(*office)
    navigator.set_goal(12.0, 2.0, None, 0.0)
    navigator.step(0.0, (2.0, 2.0, 0.0), None, DT)   # job for goal 1
    navigator.set_goal(8.0, 8.4, None, 0.1)          # before it finished
    executor.run_all()                               # goal 1's plan lands
    step = navigator.step(0.2, (2.0, 2.0, 0.0), None, DT)
    assert step.new_path is None and step.v == 0.0   # not taken as goal 2's path
    executor.run_all()                               # goal 2's plan
    step = navigator.step(0.3, (2.0, 2.0, 0.0), None, DT)
    assert step.new_path is not None and np.allclose(step.new_path[-1], (8.0, 8.4), atol=0.1)
