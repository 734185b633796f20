"""Scripted people: positions, waits, activities and loops as closed-form functions of time."""
import math

import pytest

from ascc_sim.people import ScriptedPerson
from ascc_sim.world import PersonSpec, Waypoint


def person(route, speed=0.5, loop=False, delay=0.0):
    return ScriptedPerson(PersonSpec("p", tuple(Waypoint(*w) for w in route), speed, 0.2,
                                     1.75, loop, delay, (1.0, 0.5, 0.0)))


def test_walk_wait_and_finish():
    # 0 -> (2, 0) takes 4 s, sit 10 s, -> (2, 3) takes 6 s, read 5 s, then stay.
    p = person([(0, 0, 0, ""), (2, 0, 10, "sit"), (2, 3, 5, "read")])
    s = p.state(1.0)
    assert (s.x, s.y, s.activity) == (pytest.approx(0.5), pytest.approx(0.0), "walk")
    assert s.speed_mps == 0.5 and s.yaw == pytest.approx(0.0)
    s = p.state(4.0 + 5.0)
    assert (s.x, s.y, s.activity, s.speed_mps) == (pytest.approx(2.0), 0.0, "sit", 0.0)
    s = p.state(14.0 + 3.0)
    assert (s.x, s.y) == (pytest.approx(2.0), pytest.approx(1.5))
    assert s.yaw == pytest.approx(math.pi / 2)
    assert p.state(22.0).activity == "read"
    end = p.state(1000.0)
    assert (end.x, end.y, end.activity, end.speed_mps) == (2.0, 3.0, "read", 0.0)


def test_start_delay_and_first_wait():
    p = person([(1, 1, 3, "stand_up"), (3, 1, 0, "")], delay=2.0)
    assert p.state(0.0).activity == "stand" and p.state(1.9).x == 1.0
    assert p.state(3.0).activity == "stand_up"
    assert p.state(5.0 + 2.0).x == pytest.approx(2.0)  # walking from t = 5 s
    assert p.state(-5.0).x == 1.0


def test_loop_is_periodic():
    # Square of side 2 at 1 m/s: 8 s per loop, plus a 2 s wait at the first corner.
    route = [(0, 0, 2, "wait"), (2, 0, 0, ""), (2, 2, 0, ""), (0, 2, 0, "")]
    p = person(route, speed=1.0, loop=True)
    assert p.cycle_s == pytest.approx(10.0)
    for t in (2.5, 3.7, 6.1, 9.9, 11.0):
        a, b = p.state(t), p.state(t + 3 * p.cycle_s)
        assert (a.x, a.y, a.activity) == (pytest.approx(b.x), pytest.approx(b.y), b.activity)
    s = p.state(2.0 + 7.0)  # last leg: from (0, 2) back to (0, 0)
    assert (s.x, s.y) == (pytest.approx(0.0), pytest.approx(1.0))
    assert p.state(10.5).activity == "wait"  # back at the start, waiting again


def test_single_point_person_stands():
    p = person([(4, 5, 0, "sit")])
    s = p.state(100.0)
    assert (s.x, s.y, s.activity, s.speed_mps) == (4, 5, "sit", 0.0)
