"""Velocity priority mux: the rules of twist_mux, without ROS.

Configuration: twist_mux's own format (its ``~topics`` and ``~locks`` parameters), each a
list of ``{name, topic, timeout, priority}``; ``timeout`` in seconds (0: never stale),
``priority`` an integer in [0, 255], higher wins.

Rules (``VelocityMux.select``), as twist_mux decides them:

* An input is **stale** when its timeout is > 0 and its newest command is older than the
  timeout. An input that has never sent a command is stale too (twist_mux's starts "stale"
  by a zero stamp; here an input with timeout 0 also needs one command first).
* A lock is **engaged** when its newest std_msgs/Bool was true, or when its timeout is > 0
  and it is stale (a heartbeat that stopped: a dead emergency-stop button stops the
  robot, and a lock with a timeout is engaged until its first ``false``).
* The lock priority is the highest priority of the engaged locks (0 if none). An input
  whose priority is *below* the lock priority is masked (equal is not: a lock with the
  teleop's priority stops everything below the teleop).
* The active input is the unmasked, fresh input of the highest priority; among equal
  priorities the first one in the list.

What the node does with them (``VelocityMux.on_command`` and ``tick``): a command is
forwarded at once when its input is the active one; when the active input goes stale or
is masked, the input that takes over has its newest command sent at once; if none does,
one zero command is sent (the robot stops) and then nothing, so that an idle mux does not
hold the base. twist_mux itself does neither (it only forwards); this is the project's
"stop on stale commands" rule.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple

from ascc_common.params import param

IDLE = "idle"  # the active input's name when no input is active
STOP = "stop"  # what ``tick`` returns when the robot is to be stopped (one zero command)
PRIORITY_MAX = 255


@dataclass(frozen=True)
class MuxInput:
    """One entry of ``topics`` or ``locks``."""

    name: str
    topic: str
    timeout_s: float  # [s]; 0: never stale
    priority: int  # [0, 255]


@dataclass
class VelocityMuxParams:
    """The node's own parameters (``~topics`` and ``~locks`` are twist_mux's lists, read
    with ``parse_config``)."""

    check_rate_hz: float = param(20.0, "rate of the staleness check that stops the robot "
                                 "[Hz]", gt=0.0, le=1000.0)


def parse_entries(entries: Any, kind: str) -> List[MuxInput]:
    """twist_mux's list ``entries`` of ``kind`` ("topics" or "locks") as MuxInputs;
    ValueError naming the entry and what is wrong with it. None (parameter not set) is an
    empty list. A dict of dicts (twist_mux's ROS 2 layout, name -> entry) is accepted."""
    if entries is None:
        return []
    if isinstance(entries, dict):
        entries = [dict(v, name=k) if isinstance(v, dict) else v for k, v in entries.items()]
    if not isinstance(entries, (list, tuple)):
        raise ValueError("~%s must be a list of {name, topic, timeout, priority}, got %r"
                         % (kind, entries))
    out = []
    for i, e in enumerate(entries):
        where = "~%s[%d]" % (kind, i)
        if not isinstance(e, dict):
            raise ValueError("%s must be a dict {name, topic, timeout, priority}, got %r"
                             % (where, e))
        missing = [k for k in ("name", "topic", "timeout", "priority") if k not in e]
        if missing:
            raise ValueError("%s (%r) lacks %s" % (where, e, ", ".join(missing)))
        name, topic = e["name"], e["topic"]
        if not isinstance(name, str) or not name or not isinstance(topic, str) or not topic:
            raise ValueError("%s: name and topic must be non-empty strings, got %r, %r"
                             % (where, name, topic))
        timeout, priority = e["timeout"], e["priority"]
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) \
                or not math.isfinite(timeout) or timeout < 0.0:
            raise ValueError("%s '%s': timeout must be a number of seconds >= 0, got %r"
                             % (where, name, timeout))
        if isinstance(priority, bool) or not isinstance(priority, int) \
                or not 0 <= priority <= PRIORITY_MAX:
            raise ValueError("%s '%s': priority must be an integer in [0, %d], got %r"
                             % (where, name, PRIORITY_MAX, priority))
        out.append(MuxInput(name, topic, float(timeout), priority))
    names = [m.name for m in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError("~%s: names must be unique, repeated: %s" % (kind, ", ".join(dup)))
    return out


def parse_config(topics: Any, locks: Any) -> Tuple[List[MuxInput], List[MuxInput]]:
    """(inputs, locks) from twist_mux's ``topics`` and ``locks`` parameters; ValueError
    on a bad entry or no input at all."""
    inputs = parse_entries(topics, "topics")
    if not inputs:
        raise ValueError("~topics is empty: the mux has no velocity input")
    return inputs, parse_entries(locks, "locks")


class VelocityMux:
    """The state of the mux: newest command and time of each input and lock. Times are
    seconds of one clock (the node's ROS time)."""

    def __init__(self, inputs: Sequence[MuxInput], locks: Sequence[MuxInput] = ()):
        self.inputs = list(inputs)
        self.locks = list(locks)
        self._cmd: Dict[str, Tuple[float, Any]] = {}  # input name -> (t [s], command)
        self._lock: Dict[str, Tuple[float, bool]] = {}  # lock name -> (t [s], data)
        self.active = IDLE  # the input whose commands went out last (or IDLE)
        self._by_name = {m.name: m for m in self.inputs}
        self._locks_by_name = {m.name: m for m in self.locks}

    @staticmethod
    def _stale(entry: MuxInput, received: Optional[float], t: float) -> bool:
        if received is None:
            return True
        return entry.timeout_s > 0.0 and t - received > entry.timeout_s

    def engaged(self, lock: MuxInput, t: float) -> bool:
        """Whether ``lock`` is engaged at ``t`` (true, or a heartbeat gone stale)."""
        got = self._lock.get(lock.name)
        if lock.timeout_s > 0.0 and self._stale(lock, got and got[0], t):
            return True
        return got is not None and got[1]

    def lock_priority(self, t: float) -> int:
        """The highest priority of the locks engaged at ``t`` (0 if none)."""
        return max((m.priority for m in self.locks if self.engaged(m, t)), default=0)

    def engaged_locks(self, t: float) -> List[str]:
        return [m.name for m in self.locks if self.engaged(m, t)]

    def select(self, t: float) -> str:
        """The name of the input that has the base at ``t``, IDLE if none."""
        floor = self.lock_priority(t)
        best, best_priority = IDLE, -1
        for m in self.inputs:
            got = self._cmd.get(m.name)
            if m.priority < floor or self._stale(m, got and got[0], t):
                continue
            if m.priority > best_priority:
                best, best_priority = m.name, m.priority
        return best

    def on_lock(self, name: str, t: float, data: bool) -> Any:
        """Store lock ``name``'s message received at ``t``; what to send (see ``tick``)."""
        if name not in self._locks_by_name:
            raise KeyError("no lock named %r" % name)
        self._lock[name] = (t, bool(data))
        return self.tick(t)

    def on_command(self, name: str, t: float, cmd: Any) -> bool:
        """Store input ``name``'s command received at ``t``; True when it is to be
        forwarded (its input is the active one)."""
        if name not in self._by_name:
            raise KeyError("no input named %r" % name)
        self._cmd[name] = (t, cmd)
        if self.select(t) == name:
            self.active = name
            return True
        return False

    def tick(self, t: float) -> Any:
        """Check staleness and locks at ``t``; what to send: ``STOP`` when the active
        input lost the base (stale or masked) and no input takes over (one zero command),
        the newest command of the input that takes over, or None (nothing changed)."""
        now = self.select(t)
        if now == self.active:
            return None
        self.active = now
        if now == IDLE:
            return STOP
        return self._cmd[now][1]

    def reset(self) -> None:
        """Forget every command and lock message (time went back)."""
        self._cmd.clear()
        self._lock.clear()
        self.active = IDLE

    def last_command(self, name: str) -> Optional[Tuple[float, Any]]:
        """(t [s], command) newest of input ``name``, None before its first."""
        return self._cmd.get(name)
