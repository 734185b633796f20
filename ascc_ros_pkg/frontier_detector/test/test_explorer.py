"""Unit tests of the exploration loop's rules (pure state machine, no ROS master)."""

import math

import numpy as np

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from frontier_detector import explorer as ex

RES = 0.05
INFO = GridInfo(RES, 300, 40)


def corridor_map():
    """10 m x 2 m known corridor, unknown continuation east; walls north/south."""
    g = np.full((40, 300), UNKNOWN, np.int8)
    g[:, :200] = FREE
    g[0, :200] = OCCUPIED
    g[-1, :200] = OCCUPIED
    g[:, 0] = OCCUPIED
    return g


def closed_map():
    g = np.full((40, 200), FREE, np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = OCCUPIED
    return g


ROBOT = (1.0, 1.0)


def started(**kw):
    c = ex.ExplorationController(ex.ExplorerParams(**kw))
    c.start()
    return c


def test_idle_until_started_and_waits_for_inputs():
    c = ex.ExplorationController()
    assert c.step(0.0, corridor_map(), INFO, ROBOT, 1, True).status == ex.IDLE
    c.start()
    assert c.step(0.0, None, None, ROBOT, None, True).status == ex.WAITING_MAP
    assert c.step(0.0, corridor_map(), INFO, None, 1, True).status == ex.WAITING_POSE
    d = c.step(0.0, corridor_map(), INFO, ROBOT, 1, False)
    assert d.status == ex.WAITING_MOVE_BASE and d.action == ex.NONE


def test_sends_goal_on_the_frontier_and_keeps_it():
    c = started()
    d = c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    assert d.action == ex.SEND and d.status == ex.EXPLORING
    assert d.goal_xy[0] > 9.5                           # at the east end
    assert c.goals_sent == 1
    # Same map, no outcome: nothing new.
    assert c.step(1.0, corridor_map(), INFO, ROBOT, 1, True).action == ex.NONE
    first = d.goal_xy
    # New map where the goal is still a frontier and the robot got closer, but an unknown
    # pocket next to the robot now scores higher: the plan's best moves, the goal is kept.
    g = corridor_map()
    g[22:39, 90:130] = UNKNOWN
    d = c.step(2.0, g, INFO, (4.0, 1.0), 2, True)
    assert d.plan is not None and d.plan.goal_xy is not None          # it did re-plan
    assert math.hypot(d.plan.goal_xy[0] - first[0], d.plan.goal_xy[1] - first[1]) > 2.0
    assert d.action == ex.NONE and d.status == ex.EXPLORING
    assert c.active_goal == first and c.goals_sent == 1


def explored_to(col):
    """corridor_map explored further east, up to column col (walls included)."""
    g = corridor_map()
    g[:, 200:col] = FREE
    g[0, :col] = OCCUPIED
    g[-1, :col] = OCCUPIED
    return g


def test_goal_that_is_no_longer_a_frontier_is_replaced_without_hysteresis():
    c = started(goal_hysteresis=-1.0)
    c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    first = c.active_goal
    d = c.step(1.0, explored_to(260), INFO, (5.0, 1.0), 2, True)
    assert d.action == ex.SEND and d.goal_xy[0] > first[0] + 2.0
    assert d.reason == "goal is no longer a frontier" and c.goals_kept == 0


def test_goal_kept_while_the_frontier_recedes_then_replaced_near_it():
    """The frontier moved 3 m east: the old goal (~9.7 m) still sees unknown space beyond
    13 m and the new candidate is not much better, so the goal is kept (no new plan for
    move_base); once the robot is within goal_near_m of it, the next goal is sent."""
    c = started()
    c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    first = c.active_goal
    d = c.step(1.0, explored_to(260), INFO, (5.0, 1.0), 2, True)
    assert d.action == ex.NONE and d.reason == "goal kept: still useful"
    assert c.active_goal == first and c.goals_kept == 1 and c.goals_sent == 1
    near = (first[0] - 0.6, first[1])
    d = c.step(2.0, explored_to(260), INFO, near, 3, True)
    assert d.action == ex.SEND and d.goal_xy[0] > first[0] + 2.0
    assert c.goals_sent == 2


def test_goal_dropped_when_nothing_is_left_to_see_from_it():
    """Explored 5 m beyond the old goal: more than the laser's range, nothing to see."""
    c = started()
    c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    first = c.active_goal
    d = c.step(1.0, explored_to(285), INFO, (5.0, 1.0), 2, True)
    assert d.action == ex.SEND and d.goal_xy[0] > first[0] + 3.0
    assert c.goals_kept == 0


def test_goal_dropped_when_a_much_better_candidate_appears():
    """An unknown pocket next to the robot scores far higher than the old goal, which is
    no longer a frontier: replaced with the default hysteresis, kept with a huge one."""
    g = explored_to(260)
    g[22:39, 90:130] = UNKNOWN
    for hysteresis, kept in ((0.5, False), (100.0, True)):
        c = started(goal_hysteresis=hysteresis)
        c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
        first = c.active_goal
        d = c.step(1.0, g, INFO, (4.0, 1.0), 2, True)
        assert (d.action == ex.NONE) == kept, hysteresis
        if not kept:
            assert d.action == ex.SEND and abs(d.goal_xy[0] - first[0]) > 3.0


def two_frontier_map():
    """5 m x 2 m known corridor (x 5..10 m), unknown to the west and to the east."""
    g = np.full((40, 300), UNKNOWN, np.int8)
    g[:, 100:200] = FREE
    g[0, 100:200] = OCCUPIED
    g[-1, 100:200] = OCCUPIED
    return g


MIDDLE = (7.5, 1.0)


def test_aborted_goal_is_blacklisted_and_not_resent():
    c = started()
    d = c.step(0.0, two_frontier_map(), INFO, MIDDLE, 1, True)
    assert d.action == ex.SEND
    c.report_outcome(ex.ABORTED)
    # Same map, same pose: without the blacklist the same goal would be the best again.
    d2 = c.step(1.0, two_frontier_map(), INFO, MIDDLE, 1, True)
    assert c.blacklist == [d.goal_xy]
    assert d2.action == ex.SEND and d2.status == ex.EXPLORING
    assert math.hypot(d2.goal_xy[0] - d.goal_xy[0], d2.goal_xy[1] - d.goal_xy[1]) > \
        c.planner.blacklist_radius_m
    assert c.goals_sent == 2


def test_no_progress_blacklists_goal():
    c = started(progress_timeout_s=10.0, done_confirmations=1)
    d = c.step(0.0, two_frontier_map(), INFO, MIDDLE, 1, True)
    # Robot does not move; the map does not change: after the timeout the goal is dropped.
    assert c.step(5.0, two_frontier_map(), INFO, MIDDLE, 1, True).action == ex.NONE
    assert c.step(9.9, two_frontier_map(), INFO, MIDDLE, 1, True).action == ex.NONE
    assert c.blacklist == []
    d2 = c.step(10.5, two_frontier_map(), INFO, MIDDLE, 1, True)
    assert c.blacklist == [d.goal_xy]
    assert d2.action == ex.SEND and "no progress" in d2.reason
    assert math.hypot(d2.goal_xy[0] - d.goal_xy[0], d2.goal_xy[1] - d.goal_xy[1]) > \
        c.planner.blacklist_radius_m


def test_no_progress_with_nothing_else_left_cancels():
    c = started(progress_timeout_s=10.0, done_confirmations=1)
    d = c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    d2 = c.step(11.0, corridor_map(), INFO, ROBOT, 1, True)
    assert c.blacklist == [d.goal_xy]
    assert d2.action == ex.CANCEL and c.active_goal is None


def test_progress_keeps_the_goal_past_the_timeout():
    c = started(progress_timeout_s=10.0)
    d = c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    # The robot gets 1 m closer on each new map: never stalled, even after 3 timeouts.
    for i, t in enumerate(range(8, 40, 8)):
        step = c.step(float(t), corridor_map(), INFO, (2.0 + i, 1.0), 2 + i, True)
        assert step.action == ex.NONE and step.status == ex.EXPLORING
    assert c.blacklist == [] and c.active_goal == d.goal_xy


def test_done_after_confirmations_and_restart():
    c = started(done_confirmations=2)
    d = c.step(0.0, closed_map(), INFO, ROBOT, 1, True)
    assert d.status == ex.EXPLORING and d.action == ex.NONE
    d = c.step(1.0, closed_map(), INFO, ROBOT, 2, True)
    assert d.status == ex.DONE and d.action == ex.CANCEL
    assert c.step(2.0, corridor_map(), INFO, ROBOT, 3, True).status == ex.DONE
    c.start()                                           # fresh exploration
    assert c.step(3.0, corridor_map(), INFO, ROBOT, 4, True).action == ex.SEND


def test_return_to_start_then_done():
    c = started(done_confirmations=1, return_to_start=True)
    c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)   # start pose remembered
    c.report_outcome(ex.SUCCEEDED)
    d = c.step(1.0, closed_map(), INFO, (8.0, 1.0), 2, True)
    assert d.action == ex.SEND and d.status == ex.RETURNING and d.goal_xy == ROBOT
    assert c.step(2.0, closed_map(), INFO, (5.0, 1.0), 3, True).status == ex.RETURNING
    c.report_outcome(ex.SUCCEEDED)
    assert c.step(3.0, closed_map(), INFO, ROBOT, 4, True).status == ex.DONE


def test_stop_and_resume():
    c = started()
    c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    assert c.stop() is True                             # the node must cancel the goal
    assert c.state == ex.IDLE
    assert c.step(1.0, corridor_map(), INFO, ROBOT, 2, True).action == ex.NONE
    c.start()
    assert c.step(2.0, corridor_map(), INFO, ROBOT, 2, True).action == ex.SEND


def test_bad_robot_pose_sends_nothing():
    c = started()
    d = c.step(0.0, corridor_map(), INFO, (-50.0, 3.0), 1, True)
    assert d.action == ex.NONE and d.status == "robot_outside_map"
    wall = corridor_map()
    wall[:, :60] = OCCUPIED
    d = c.step(1.0, wall, INFO, ROBOT, 2, True)
    assert d.action == ex.NONE and d.status == "robot_not_in_free_space"
    empty = np.full((10, 10), UNKNOWN, np.int8)
    d = c.step(2.0, empty, INFO, (0.2, 0.2), 3, True)
    assert d.action == ex.NONE and d.status == "empty_map"
    # A 0 x 0 map (an uninitialised OccupancyGrid's resolution 0 is refused earlier, by
    # GridInfo.from_msg_info), a NaN pose.
    d = c.step(3.0, np.zeros((0, 0), np.int8), GridInfo(RES, 0, 0), (0.0, 0.0), 4, True)
    assert d.action == ex.NONE and d.status == "empty_map"
    d = c.step(4.0, corridor_map(), INFO, (float("nan"), 1.0), 5, True)
    assert d.action == ex.NONE and d.status == "robot_outside_map"


def test_move_base_going_away_drops_the_goal():
    c = started()
    c.step(0.0, corridor_map(), INFO, ROBOT, 1, True)
    assert c.active_goal is not None
    assert c.step(1.0, corridor_map(), INFO, ROBOT, 1, False).status == ex.WAITING_MOVE_BASE
    assert c.active_goal is None
    assert c.step(2.0, corridor_map(), INFO, ROBOT, 1, True).action == ex.SEND


def drive(c, corners, step_m=0.1):
    """Record a path through ``corners`` in the controller (its own robot positions)."""
    for (x0, y0), (x1, y1) in zip(corners[:-1], corners[1:]):
        n = max(1, int(math.hypot(x1 - x0, y1 - y0) / step_m))
        for k in range(1, n + 1):
            c._record((x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n))


# a 20 m x 10 m loop driven from (0, 0) back to 3.5 m short of the start, where an
# explorer turns away (the corridor's seam: its scans only touch the start's there)
LOOP = [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0), (0.0, 10.0), (0.0, 3.5)]


def test_active_loop_closing_finds_where_the_loop_joins():
    c = started(loop_revisit_path_m=30.0, loop_revisit_radius_m=5.0)
    drive(c, LOOP[:2])
    assert c.loop_to_close((20.0, 0.0)) is None          # nothing far back yet
    drive(c, LOOP[1:])
    found = c.loop_to_close((0.0, 3.5))
    assert found is not None
    (x, y), back_m = found
    assert math.hypot(x, y) < 0.2                          # the start, 3.5 m away
    assert 55.0 < back_m < 57.0                            # 56.5 m of path back
    assert c.loop_to_close((0.0, 3.5)) is None             # once per place
    off = started(loop_revisit_path_m=30.0, loop_revisit_radius_m=3.0)
    drive(off, LOOP)
    assert off.loop_to_close((0.0, 3.5)) is None           # farther than the radius


def test_driving_back_along_a_corridor_is_no_loop():
    """Out 40 m and back: the places passed again lie far back along the path, but the
    recent path runs over them; nothing to revisit."""
    c = started(loop_revisit_path_m=30.0, loop_revisit_radius_m=5.0)
    drive(c, [(0.0, 0.0), (40.0, 0.0)])
    for x in np.arange(39.0, 4.0, -1.0):
        drive(c, [(x + 1.0, 0.0), (x, 0.0)])
        assert c.loop_to_close((x, 0.0)) is None, x


def test_active_loop_closing_goal_comes_first_and_is_not_blacklisted():
    c = started(loop_revisit_path_m=30.0, loop_revisit_radius_m=5.0)
    drive(c, LOOP)
    d = c.step(0.0, corridor_map(), INFO, (0.0, 3.5), 1, True)
    assert d.action == ex.SEND and d.status == ex.EXPLORING
    assert math.hypot(*d.goal_xy) < 0.2 and "closing a loop" in d.reason
    assert c.loops_revisited == 1
    # kept while it lasts, whatever the new maps
    d = c.step(1.0, corridor_map(), INFO, (0.0, 2.0), 2, True)
    assert d.action == ex.NONE and d.reason == "closing a loop"
    c.report_outcome(ex.SUCCEEDED)
    d = c.step(2.0, corridor_map(), INFO, ROBOT, 3, True)
    assert d.action == ex.SEND and d.goal_xy[0] > 9.5     # exploring on: the frontier
    assert c.blacklist == []
    # not reached within progress_timeout_s: dropped, exploring on
    t = started(loop_revisit_path_m=30.0, loop_revisit_radius_m=5.0, progress_timeout_s=10.0)
    drive(t, LOOP)
    assert t.step(0.0, corridor_map(), INFO, (0.0, 3.5), 1, True).action == ex.SEND
    assert t.step(5.0, corridor_map(), INFO, (0.0, 3.4), 2, True).action == ex.NONE
    d = t.step(11.0, corridor_map(), INFO, ROBOT, 3, True)
    assert d.action == ex.SEND and d.goal_xy[0] > 9.5 and t.blacklist == []


def test_active_loop_closing_is_off_by_default():
    c = started()
    drive(c, LOOP)
    d = c.step(0.0, corridor_map(), INFO, (0.0, 3.5), 1, True)
    assert "closing a loop" not in d.reason
