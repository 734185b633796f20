"""The wearable sensor emulator's core: a scripted person's activity in, the XBee frames the
receiving XBee would hand to the PC out (thesis 5.4.1). Pure Python; the node
(`ros/wearable_emulator_node.py`) feeds it the simulator's ground-truth activity and writes
the bytes to a pseudo-terminal.

Every 1/20 s `step(t, activity)` renders one sample per sensor (`body_signals`) and runs
each sensor's `power.PowerManager`: an awake sensor sends a sample frame, one falling
asleep sends a sleep notice, a sleeping one sends nothing. A change of activity between
seated and upright postures plays the transition first (sit-to-stand, stand-to-sit).
Simulator activity names are mapped to the recognizer's by ``ACTIVITY_ALIASES``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

from ascc_common.params import nested, param

from .body_signals import LEAN_DEG, POSITIONS, RATE_HZ, SEATED, UPRIGHT, Person, sensor_signals
from .power import PowerManager, PowerParams
from .wearable import Sample, encode_sample, encode_sleep
from .xbee import encode_rx16

# ascc_sim's scripted activities -> ours (reading at the shelf is done standing)
ACTIVITY_ALIASES = {"lie": "lying", "sit": "sitting", "read": "standing", "walk": "walking",
                    "stand": "standing", "type": "typing", "eat": "eating",
                    "open_door": "opening_door"}


def canonical_activity(name: str) -> str:
    return ACTIVITY_ALIASES.get(name, name)


@dataclass
class EmulatorParams:
    """The emulator node's private parameters."""

    person: str = param("subject", "the person in ground_truth/people who wears the sensors")
    seed: int = param(0, "the person's way of moving (posture, gait, noise)", ge=0)
    sensor_ids: List[int] = param([1, 2], "16-bit XBee addresses of the sensors", ge=0,
                                  le=0xFFFF)
    sensor_positions: List[str] = param(["waist", "thigh"], "where each is worn (waist, "
                                        "thigh), in the same order")
    link_path: str = param("", "symlink to the pty the frames are written to (\"\": "
                           "none; the /dev/pts/N path is logged)")
    rate_hz: float = param(RATE_HZ, "[Hz] sample rate of the sensors", gt=0.0)
    power_aware: bool = param(True, "the sleep/wake scheme of 5.4.1")
    script_activities: List[str] = param([], "a fixed script instead of the ground truth: "
                                         "activities (body_signals names) ...")
    script_durations_s: List[float] = param([], "[s] ... and how long each lasts (the "
                                            "script then repeats)", gt=0.0)
    power: PowerParams = nested(PowerParams, "power/")

    def validate(self) -> None:
        if len(self.sensor_ids) != len(self.sensor_positions):
            raise ValueError("sensor_ids (%d) and sensor_positions (%d) must pair up"
                             % (len(self.sensor_ids), len(self.sensor_positions)))
        if len(set(self.sensor_ids)) != len(self.sensor_ids) or \
                len(set(self.sensor_positions)) != len(self.sensor_positions):
            raise ValueError("sensor_ids and sensor_positions must be unique")
        bad = sorted(set(self.sensor_positions) - set(POSITIONS))
        if bad:
            raise ValueError("unknown sensor_positions %s (known: %s)"
                             % (bad, ", ".join(POSITIONS)))
        if len(self.script_activities) != len(self.script_durations_s):
            raise ValueError("script_activities (%d) and script_durations_s (%d) must pair "
                             "up" % (len(self.script_activities),
                                     len(self.script_durations_s)))
        bad = sorted(set(map(canonical_activity, self.script_activities)) - set(LEAN_DEG))
        if bad:
            raise ValueError("unknown script activities %s (known: %s)"
                             % (bad, ", ".join(sorted(LEAN_DEG))))


def script_activity(activities: List[str], durations_s: List[float], t: float) -> str:
    """The activity of a repeating script at time ``t`` [s]."""
    total = sum(durations_s)
    t = t % total
    for activity, d in zip(activities, durations_s):
        if t < d:
            return activity
        t -= d
    return activities[-1]


class SampleClock:
    """The sensors' own clock: sample k is taken at k / ``rate_hz`` [s] after the start,
    whenever the PC gets round to rendering it. ``due(t)`` returns the times [s] of the
    samples due by ``t`` that were not yet rendered, oldest first: a late timer tick renders
    the samples it missed at their own times (a tick's own time would repeat or skip a
    phase of the motion, and the recognizer's difference-variance features see it). More
    than ``max_backlog_s`` behind (a jump of simulated time), the older samples are
    skipped and counted in ``skipped``."""

    def __init__(self, rate_hz: float, max_backlog_s: float = 1.0):
        self.rate_hz = rate_hz
        self.max_samples = max(1, int(round(max_backlog_s * rate_hz)))
        self.next = 0          # index of the next sample to render
        self.skipped = 0

    def reset(self) -> None:
        self.next = 0

    def due(self, t: float) -> List[float]:
        last = int(math.floor(t * self.rate_hz + 1e-9))
        if last - self.next + 1 > self.max_samples:
            first = last - self.max_samples + 1
            self.skipped += first - self.next
            self.next = first
        times = [k / self.rate_hz for k in range(self.next, last + 1)]
        self.next = max(self.next, last + 1)
        return times


@dataclass
class _Sensor:
    address: int
    position: str
    power: PowerManager
    seq: int = 0
    frames: int = 0
    sleeps: int = 0


@dataclass
class EmulatorState:
    activity: str = ""              # what the person does now (after aliases)
    segment: str = ""               # what is rendered: the activity or a transition
    segment_start: float = 0.0      # [s]
    pending: Optional[str] = None   # the activity after the transition
    transition_end: float = 0.0


class Emulator:
    """Frames for one person wearing sensors at ``addresses`` (position -> 16-bit id)."""

    def __init__(self, person: Person, addresses: Dict[str, int], rate_hz: float,
                 power: Optional[PowerParams] = None, power_aware: bool = True):
        unknown = set(addresses) - set(POSITIONS)
        if unknown:
            raise ValueError("unknown sensor positions %s (known: %s)"
                             % (sorted(unknown), ", ".join(POSITIONS)))
        self.person = person
        self.rate_hz = rate_hz
        self.power_aware = power_aware
        p = power or PowerParams()
        self.sensors = [_Sensor(addr, pos, PowerManager(rate_hz, p))
                        for pos, addr in addresses.items()]
        self.state = EmulatorState()

    def _segment(self, t: float, activity: str) -> Tuple[str, float]:
        s = self.state
        if activity != s.activity:
            prev = s.pending or s.activity
            kind = ("sit_to_stand" if prev in SEATED and activity in UPRIGHT else
                    "stand_to_sit" if prev in UPRIGHT and activity in SEATED else None)
            s.activity = activity
            if kind:
                s.segment, s.segment_start, s.pending = kind, t, activity
                s.transition_end = t + self.person.transition_s
            else:
                s.segment, s.segment_start, s.pending = activity, t, None
        if s.pending is not None and t >= s.transition_end:
            s.segment, s.segment_start, s.pending = s.pending, t, None
        return s.segment, s.segment_start

    def step(self, t: float, activity: str, heading_rad: float = 0.0) -> bytes:
        """The frames of the sample at time ``t`` [s] while the person does ``activity``
        (an ascc_sim name or ours); b"" while every sensor sleeps."""
        segment, start = self._segment(t, canonical_activity(activity))
        out = bytearray()
        for s in self.sensors:
            accel, gyro, quat = sensor_signals(segment, s.position, self.person, [t], start,
                                               heading_rad)
            awake, event = s.power.step(accel[0]) if self.power_aware else (True, "")
            if event == "sleep":
                out += encode_rx16(s.address, encode_sleep(s.seq))
                s.seq = (s.seq + 1) & 0xFFFF
                s.sleeps += 1
            if not awake:
                continue
            sample = Sample(s.seq, tuple(float(v) for v in accel[0]),
                            tuple(float(v) for v in gyro[0]), tuple(float(v) for v in quat[0]))
            out += encode_rx16(s.address, encode_sample(sample))
            s.seq = (s.seq + 1) & 0xFFFF
            s.frames += 1
        return bytes(out)

    @property
    def segment(self) -> str:
        """The activity (or transition) rendered by the last step."""
        return self.state.segment
