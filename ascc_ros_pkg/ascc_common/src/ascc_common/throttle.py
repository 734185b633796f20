"""Throttled warnings per kind (no rospy): one clock-free rule for every node."""
from __future__ import annotations

from typing import Dict


class Throttle:
    """At most one ``ready`` per ``period_s`` for each key. One key per kind of warning, so
    a frequent warning (a controller saturating the wheels all the time, corrupt camera
    frames) cannot hide a rare one (a NaN twist, a 404). Time going back (a restarted
    simulator) restarts the period. The caller passes the time: ROS time, or
    ``time.monotonic()``."""

    def __init__(self, period_s: float):
        self.period_s = period_s
        self._last: Dict[str, float] = {}

    def ready(self, key: str, now: float) -> bool:
        last = self._last.get(key)
        if last is None or now - last >= self.period_s or now < last:
            self._last[key] = now
            return True
        return False
