"""Scripted people: a person walks a polyline route at constant speed and waits at
waypoints doing a scripted activity (``sit``, ``lie``, ``read``, ...).

The state is a closed-form function of time, so it is deterministic and independent of
the simulation step: ``ScriptedPerson(spec).state(t)``.
"""
from __future__ import annotations

import bisect
import math
from typing import List, NamedTuple

from .world import PersonSpec


class PersonState(NamedTuple):
    x: float  # [m]
    y: float  # [m]
    yaw: float  # heading [rad]
    speed_mps: float  # 0 while waiting
    activity: str  # scripted activity while waiting at a waypoint, 'walk' or 'stand'


class _Phase(NamedTuple):
    t0: float  # start time [s] within one cycle
    duration: float  # [s]
    x0: float
    y0: float
    x1: float
    y1: float
    yaw: float
    activity: str  # '' while walking


class ScriptedPerson:
    """The timeline of one person: start delay, then (walk, wait) per waypoint."""

    def __init__(self, spec: PersonSpec):
        self.spec = spec
        route = spec.route
        phases: List[_Phase] = []
        t = 0.0
        first = route[0]
        yaw = 0.0
        if len(route) > 1:
            yaw = math.atan2(route[1].y - first.y, route[1].x - first.x)
        if spec.start_delay_s > 0:
            phases.append(_Phase(t, spec.start_delay_s, first.x, first.y, first.x, first.y,
                                 yaw, "stand"))
            t += spec.start_delay_s
        if first.wait_s > 0:
            phases.append(_Phase(t, first.wait_s, first.x, first.y, first.x, first.y, yaw,
                                 first.activity or "stand"))
            t += first.wait_s
        self._prefix_s = t  # not repeated when looping
        legs = list(zip(route[:-1], route[1:]))
        if spec.loop and len(route) > 1:
            legs.append((route[-1], route[0]))
        for a, b in legs:
            dist = math.hypot(b.x - a.x, b.y - a.y)
            if dist > 1e-9:
                yaw = math.atan2(b.y - a.y, b.x - a.x)
                phases.append(_Phase(t, dist / spec.speed_mps, a.x, a.y, b.x, b.y, yaw, ""))
                t += dist / spec.speed_mps
            if b.wait_s > 0:
                phases.append(_Phase(t, b.wait_s, b.x, b.y, b.x, b.y, yaw,
                                     b.activity or "stand"))
                t += b.wait_s
        self._phases = phases
        self._starts = [p.t0 for p in phases]
        self._end_s = t
        self._cycle_s = t - self._prefix_s
        self._final = PersonState(route[-1].x, route[-1].y, yaw, 0.0,
                                  route[-1].activity or "stand")
        if spec.loop and len(route) > 1:
            self._final = PersonState(first.x, first.y, yaw, 0.0, first.activity or "stand")

    @property
    def end_s(self) -> float:
        """Simulation time [s] at which the route (its first loop) is done."""
        return self._end_s

    @property
    def cycle_s(self) -> float:
        """Duration of one loop of the route [s] (0 when it does not move)."""
        return self._cycle_s

    def state(self, t_s: float) -> PersonState:
        """Where the person is and what they do at simulation time ``t_s`` [s]."""
        if not self._phases:
            return self._final
        t = max(0.0, t_s)
        if t >= self._end_s:
            if not (self.spec.loop and self._cycle_s > 0):
                return self._final
            t = self._prefix_s + math.fmod(t - self._prefix_s, self._cycle_s)
        k = max(0, bisect.bisect_right(self._starts, t) - 1)
        p = self._phases[k]
        if p.activity:
            return PersonState(p.x0, p.y0, p.yaw, 0.0, p.activity)
        f = min(1.0, max(0.0, (t - p.t0) / p.duration))
        return PersonState(p.x0 + f * (p.x1 - p.x0), p.y0 + f * (p.y1 - p.y0), p.yaw,
                           self.spec.speed_mps, "walk")
