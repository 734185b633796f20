"""The trail: the follower steers along the target's path, not straight at it."""
import math

import pytest

from target_follower.follower import Aim
from target_follower.trail import Trail, TrailParams


def walked(points, step=0.05):
    """Positions along a polyline every ``step`` metres."""
    out = []
    for (x0, y0), (x1, y1) in zip(points[:-1], points[1:]):
        n = max(1, int(math.hypot(x1 - x0, y1 - y0) / step))
        out += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(n)]
    return out + [points[-1]]


def direct_aim(pose, target):
    dx, dy = target[0] - pose[0], target[1] - pose[1]
    return Aim(math.atan2(dy, dx) - pose[2], math.hypot(dx, dy))


def test_points_are_spaced_and_non_finite_ones_dropped():
    tr = Trail(TrailParams(trail_spacing_m=0.1))
    for p in walked([(0.0, 0.0), (1.0, 0.0)], step=0.01):
        tr.add(p)
    tr.add((math.nan, 0.0))
    assert 10 <= len(tr.points) <= 11
    gaps = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(tr.points, tr.points[1:])]
    assert min(gaps) >= 0.1 - 1e-9


def test_around_a_corner_the_robot_steers_along_the_path_not_at_the_target():
    # the person walked east to (2, 0), turned north (a door) and is at (2, 1.5) now;
    # the robot is still at the origin heading east
    tr = Trail(TrailParams())
    for p in walked([(0.5, 0.0), (2.0, 0.0), (2.0, 1.5)]):
        tr.add(p)
    pose = (0.0, 0.0, 0.0)
    target = (2.0, 1.5)
    aim = tr.aim(pose, target, direct_aim(pose, target), distance_m=1.3)
    assert abs(aim.bearing_rad) < math.radians(5)  # along the corridor, east
    assert direct_aim(pose, target).bearing_rad > math.radians(30)  # what a cut would do
    assert aim.range_m == pytest.approx(3.5, abs=0.06)  # the path, not the 2.5 m line


def test_passed_points_are_dropped_and_the_aim_turns_at_the_corner():
    tr = Trail(TrailParams())
    for p in walked([(0.5, 0.0), (2.0, 0.0), (2.0, 1.5)]):
        tr.add(p)
    pose = (1.9, 0.0, 0.0)  # the robot reached the corner
    target = (2.0, 1.5)
    aim = tr.aim(pose, target, direct_aim(pose, target), distance_m=1.0)
    assert all(x >= 1.9 - 0.3 for x, _ in tr.points)
    assert aim.bearing_rad > math.radians(60)  # now north, through the door


def test_inside_the_set_distance_it_faces_the_target():
    tr = Trail(TrailParams())
    for p in walked([(0.0, 0.0), (1.0, 0.0), (1.0, 0.5)]):
        tr.add(p)
    pose = (0.2, 0.0, 0.0)
    target = (1.0, 0.5)
    direct = direct_aim(pose, target)
    aim = tr.aim(pose, target, direct, distance_m=1.3)
    assert aim is direct


def test_switched_off_or_without_a_range_the_aim_is_direct():
    tr = Trail(TrailParams(follow_trail=False))
    for p in walked([(0.5, 0.0), (2.0, 0.0), (2.0, 1.5)]):
        tr.add(p)
    pose = (0.0, 0.0, 0.0)
    direct = direct_aim(pose, (2.0, 1.5))
    assert tr.aim(pose, (2.0, 1.5), direct, 1.0) is direct
    tr = Trail(TrailParams())
    bearing_only = Aim(0.3)
    assert tr.aim(pose, (2.0, 1.5), bearing_only, 1.0) is bearing_only


def test_the_trail_is_bounded():
    tr = Trail(TrailParams(trail_max_points=5, trail_spacing_m=0.1))
    for k in range(20):
        tr.add((0.2 * k, 0.0))
    assert len(tr.points) == 5 and tr.points[-1] == pytest.approx((3.8, 0.0))


def test_lost_from_view_the_robot_drives_to_where_the_target_was_last_seen():
    tr = Trail(TrailParams())
    for p in walked([(1.0, 0.0), (2.0, 0.0), (2.0, 1.0)]):  # seen last at (2, 1)
        tr.add(p)
    pose = (0.0, 0.0, 0.0)
    aim = tr.search_aim(pose, distance_m=1.2)
    assert aim.searching and abs(aim.bearing_rad) < math.radians(5)
    assert aim.range_m == pytest.approx(1.2 + 3.0, abs=0.06)  # drives the whole path
    aim = tr.search_aim((2.0, 0.9, math.pi / 2), distance_m=1.2)  # at the trail's end
    assert aim is None and tr.points == []


def test_a_target_found_again_near_the_trail_end_continues_the_trail():
    tr = Trail(TrailParams(trail_join_m=2.0))
    for p in walked([(0.0, 0.0), (2.0, 0.0)]):
        tr.add(p)
    n = len(tr.points)
    tr.restart((2.0, 1.5))
    assert len(tr.points) == n + 1
    tr.restart((8.0, 8.0))  # far away: someone else, or a jump: a new trail
    assert tr.points == [(8.0, 8.0)]


def test_a_person_just_round_a_corner_is_followed_by_the_path_not_the_straight_line():
    """Half-way through a right-angle turn the straight range (1.41 m) is below the set
    distance (1.6 m here) but the path (2.0 m) is not all travelled: the robot keeps
    driving along the trail; nearer than direct_within_m in a straight line it faces the
    person."""
    tr = Trail(TrailParams())
    for p in walked([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]):
        tr.add(p)
    pose = (0.0, 0.0, 0.0)
    target = (1.0, 1.0)
    direct = direct_aim(pose, target)
    assert direct.range_m == pytest.approx(1.41, abs=0.01)
    aim = tr.aim(pose, target, direct, distance_m=1.6)
    assert aim is not direct and aim.range_m == pytest.approx(2.0, abs=0.05)
    assert abs(aim.bearing_rad) < math.radians(5)  # along the first leg
    close = Trail(TrailParams(direct_within_m=0.9))
    for p in walked([(0.0, 0.0), (0.5, 0.0), (0.5, 0.3)]):
        close.add(p)
    near = direct_aim(pose, (0.5, 0.3))
    assert close.aim(pose, (0.5, 0.3), near, distance_m=0.7) is near


def test_a_position_far_from_the_prediction_is_not_a_trail_point():
    tr = Trail(TrailParams(trail_max_innovation_m=0.25))
    tr.add((0.0, 0.0), 0.02)
    tr.add((0.5, 0.0), 0.3)  # a laser range off the target: 0.3 m from the prediction
    tr.add((0.2, 0.0), 0.04)
    tr.add((0.4, 0.0))  # innovation unknown (a new track): kept
    assert tr.points == [(0.0, 0.0), (0.2, 0.0), (0.4, 0.0)]


def test_held_by_the_safety_stop_on_the_trail_it_is_dropped():
    p = TrailParams(trail_blocked_s=2.0)
    tr = Trail(p)
    for q in walked([(0.5, 0.0), (2.0, 0.0), (2.0, 1.5)]):
        tr.add(q)
    pose, target = (0.0, 0.0, 0.0), (2.0, 1.5)
    tr.aim(pose, target, direct_aim(pose, target), 1.3)
    assert tr.steering
    assert not tr.note_blocked(10.0, True)
    assert not tr.note_blocked(11.0, False)  # free again: the clock restarts
    assert not tr.note_blocked(11.5, True)
    assert not tr.note_blocked(13.4, True) and tr.points
    assert tr.note_blocked(13.6, True) and not tr.points
    # facing the target (no trail, not steering), a blocked robot keeps no clock
    aim = tr.aim(pose, target, direct_aim(pose, target), 1.3)
    assert not tr.steering and aim.bearing_rad == pytest.approx(math.atan2(1.5, 2.0))
    assert not tr.note_blocked(20.0, True) and not tr.note_blocked(30.0, True)


def test_a_target_that_walks_back_restarts_the_trail():
    """It walked 3 m away and back to 1.25 m straight ahead: the trail (out to 3 m and
    back) is a 3.5 m detour; the robot faces it and the trail starts again at it."""
    tr = Trail(TrailParams(trail_max_detour_m=1.0))
    pose = (0.0, 0.0, 0.0)
    for q in walked([(3.0, 0.0), (1.4, 0.0)]):
        tr.add(q)
    target = (1.25, 0.0)
    aim = tr.aim(pose, target, direct_aim(pose, target), 1.3)
    assert aim.range_m == pytest.approx(1.25) and not tr.steering
    assert tr.points == [target]
    # also when it stops just outside the set distance (1.35 m: the band's edge)
    tr = Trail(TrailParams(trail_max_detour_m=1.0))
    for q in walked([(3.0, 0.0), (1.4, 0.0)]):
        tr.add(q)
    aim = tr.aim(pose, (1.35, 0.0), direct_aim(pose, (1.35, 0.0)), 1.3)
    assert not tr.steering and tr.points == [(1.35, 0.0)]
    # a person 1.5 m past a right-angle corner, the robot 1.5 m before it: kept
    tr = Trail(TrailParams(trail_max_detour_m=1.0))
    for q in walked([(0.3, 0.0), (1.5, 0.0), (1.5, 1.5)]):
        tr.add(q)
    tr.aim(pose, (1.5, 1.5), direct_aim(pose, (1.5, 1.5)), 1.3)
    assert tr.steering and len(tr.points) > 20
    # round a corner the detour is small: the trail is kept
    tr = Trail(TrailParams(trail_max_detour_m=1.0))
    for q in walked([(0.3, 0.0), (0.9, 0.0), (0.9, 0.6)]):
        tr.add(q)
    target = (0.9, 0.65)
    n = len(tr.points)
    tr.aim(pose, target, direct_aim(pose, target), 1.3)
    assert len(tr.points) >= n - 3


def test_a_target_nearer_than_its_trail_start_restarts_it():
    """It walked back 0.35 m past the start of its (restarted) trail: the trail is behind
    it, the robot faces it (follower.test: 1.6 m -> 1.25 m, the trail 0.7 m longer)."""
    tr = Trail(TrailParams())
    pose = (0.0, 0.0, 0.0)
    for q in walked([(1.6, 0.0), (1.3, 0.0)]):
        tr.add(q)
    aim = tr.aim(pose, (1.25, 0.0), direct_aim(pose, (1.25, 0.0)), 1.3)
    assert not tr.steering and aim.range_m == pytest.approx(1.25)
    assert tr.points == [(1.25, 0.0)]
