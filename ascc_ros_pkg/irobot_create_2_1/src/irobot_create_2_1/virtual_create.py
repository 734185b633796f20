"""Byte-exact emulator of the iRobot Create Open Interface (pure Python).

The emulator speaks the Create OI (iRobot Create Open Interface specification, the 2006-2007
Create) or, with ``robot=models.CREATE_2``, the Create 2 OI (Roomba 600 based: packets up
to 58 and groups 100/101/106/107, 115200 baud): bytes from the host go into
:meth:`VirtualCreate.feed`, bytes for the host come out of :meth:`VirtualCreate.read_output`,
and :meth:`VirtualCreate.step`
advances emulated time (wheels, odometry, battery, songs, wait commands and the 15 ms sensor
stream). It has no I/O of its own: :class:`irobot_create_2_1.pty_link.PtyLink` puts it behind
a pseudo-terminal, the simulator embeds it directly.

It ties three modules: :mod:`irobot_create_2_1.oi_commands` (host bytes -> commands ->
actions), :mod:`irobot_create_2_1.create_state` (the robot's state and physics, which
:class:`VirtualCreate` extends) and :mod:`irobot_create_2_1.oi_sensors` (sensor values ->
reply and stream bytes). What stays here is the Open Interface's timing: the input and
output queues, the stream clock, scripts and wait commands.

Behaviour choices where the spec is silent or where we deliberately differ (the others are
in the three modules' docstrings; see also the package README):

* Wait Time/Distance/Angle/Event hold the input queue (bytes are buffered, up to
  ``RX_BUFFER_LIMIT``) until the condition is met; the sensor stream keeps running.
* Robot->host bytes nobody reads are kept up to ``TX_BUFFER_LIMIT``; older ones are dropped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

from ascc_common.params import param
from irobot_create_2_1 import oi_commands, protocol
from irobot_create_2_1.create_state import EPS, CreateState
from irobot_create_2_1.models import CREATE_1, RobotModel
from irobot_create_2_1.oi_sensors import SensorEncoder

STREAM_PERIOD_S = protocol.STREAM_PERIOD_S      # the Create streams every 15 ms
RX_BUFFER_LIMIT = 4096           # bytes held while a wait command blocks the input [bytes]
TX_BUFFER_LIMIT = 65536          # robot->host bytes kept when nobody reads [bytes]
MAX_COMMANDS_PER_CALL = 1024     # bounds work per feed/step (a looping script never hangs)


@dataclass
class VirtualCreateParams:
    """Everything the virtual_create node reads (private parameters)."""

    link_path: str = param("", "symlink to the pty (\"\": none, the /dev/pts/N path is "
                               "printed)")
    robot_model: str = param("create_1", "create_1 or create_2: the OI emulated",
                             choices=("create_1", "create_2"))
    rate_hz: float = param(200.0, "[Hz] emulation step rate, ROS time", gt=0.0)
    publish_rate_hz: float = param(50.0, "[Hz] rate of ~ground_truth / ~wheel_speeds",
                                   gt=0.0)
    reopen_delay_s: float = param(1.0, "[s] ~close_link: time before the pty comes back",
                                  ge=0.0)
    wheel_base_m: float = param(0.0, "[m] wheel base; 0: the model's (0.258 / 0.235)",
                                ge=0.0)
    battery_capacity_mah: float = param(2700.0, "[mAh] battery capacity (starts full)")
    max_wheel_speed_mm_s: float = param(500.0, "[mm/s] per-wheel clamp")
    world_frame: str = param("virtual_world", "frame of ~ground_truth")
    base_frame: str = param("base_link", "child frame of ~ground_truth")


class _Wait:
    """A running Wait Time/Distance/Angle/Event command."""

    __slots__ = ("kind", "target", "progress")

    def __init__(self, kind: str, target: float):
        self.kind = kind          # 'time' [s] | 'distance' [mm] | 'angle' [deg] | 'event' [id]
        self.target = target
        self.progress = 0.0


class VirtualCreate(CreateState):
    """An iRobot Create (``robot``: models.CREATE_1 or CREATE_2) speaking its Open
    Interface, in emulated time.

    Not thread-safe: call it from one thread (or hold a lock).
    """

    def __init__(self, wheel_base_m: Optional[float] = None,
                 battery_capacity_mah: float = 2700.0,
                 initial_charge_mah: Optional[float] = None, max_wheel_speed_mm_s: float = 500,
                 robot: RobotModel = CREATE_1):
        super().__init__(wheel_base_m or None, battery_capacity_mah, initial_charge_mah,
                         max_wheel_speed_mm_s, robot)
        self._rx = bytearray()
        self._tx = bytearray()

        # Stream.
        self.streaming = False
        self._stream_phase_s = 0.0

        self._wait: Optional[_Wait] = None

        # Counters (diagnostics for tests).
        self.commands_executed = 0
        self.commands_ignored = 0
        self.unknown_bytes = 0
        self.rx_dropped_bytes = 0
        self.tx_dropped_bytes = 0
        self.frames_sent = 0

        self._sensors = SensorEncoder(self, robot.packet_ids)
        self._events = oi_commands.wait_events(self)

    # ------------------------------------------------------------------ public interface
    def power_cycle(self) -> None:
        """The robot switched off and on again (power button, a brown-out): the OI is back
        in off mode, listening only for Start; the motors stop; the sensor stream, a
        pending wait, a playing song and half-received commands are gone. Pose, battery and
        the sensors set by the simulator are kept, and so are stored songs and the script
        (the spec does not say; nothing here depends on it)."""
        self.power_off()
        self._rx.clear()
        self._wait = None
        self.streaming = False
        self._stream_phase_s = 0.0

    @property
    def waiting(self) -> bool:
        """True while a wait command holds the input queue."""
        return self._wait is not None

    def feed(self, data: bytes) -> None:
        """Host -> robot bytes; a command may be split over several calls."""
        if not data:
            return
        room = RX_BUFFER_LIMIT - len(self._rx)
        if len(data) > room and self._wait is not None:
            self.rx_dropped_bytes += len(data) - max(room, 0)
            data = data[:max(room, 0)]
        self._rx.extend(data)
        self._process_input()

    def read_output(self) -> bytes:
        """Robot -> host bytes produced since the last call (the buffer is cleared)."""
        out = bytes(self._tx)
        self._tx.clear()
        return out

    def step(self, dt_s: float, wheel_travel_m: Optional[Sequence[float]] = None) -> None:
        """Advance emulated time by dt_s [s].

        wheel_travel_m None: each wheel travels its commanded speed * dt (ideal). Otherwise
        (left_m, right_m): what the wheels really travelled during dt (the simulator's truth,
        e.g. 0, 0 against a wall); it is spread evenly over the step.
        """
        if dt_s < 0 or not math.isfinite(dt_s):
            raise ValueError("dt_s must be finite and >= 0, got %r" % dt_s)
        travel = None
        if wheel_travel_m is not None:
            travel = (float(wheel_travel_m[0]), float(wheel_travel_m[1]))
        remaining = dt_s
        while remaining > EPS:
            if self.streaming and STREAM_PERIOD_S - self._stream_phase_s <= EPS:
                self._send_stream_frame()
                self._stream_phase_s = 0.0
            h = remaining
            if self.streaming:
                h = min(h, STREAM_PERIOD_S - self._stream_phase_s)
            if self._wait is not None and self._wait.kind == "time":
                h = min(h, max(self._wait.target - self._wait.progress, EPS))
            part = None if travel is None else (travel[0] * h / dt_s, travel[1] * h / dt_s)
            self._advance(h, part)
            remaining -= h
            if self.streaming:
                self._stream_phase_s += h
        if self.streaming and STREAM_PERIOD_S - self._stream_phase_s <= EPS:
            self._send_stream_frame()
            self._stream_phase_s = 0.0
        self._process_input()

    # ------------------------------------------------------------------ command input
    def _process_input(self) -> None:
        done = 0
        while self._rx and self._wait is None and done < MAX_COMMANDS_PER_CALL:
            command = oi_commands.take_command(self._rx, self._mode, self.robot.name)
            if command is None:
                return                           # wait for the rest of the command
            if command is oi_commands.SKIPPED:
                self.unknown_bytes += 1
                continue
            done += 1
            if oi_commands.execute(self, *command, model=self.robot.name):
                self.commands_executed += 1
            else:
                self.commands_ignored += 1
            self._check_safety()

    # ------------------------------------------------------------------ OI actions
    # (called by oi_commands' handlers; the robot's own actions are CreateState's)
    def send_sensors(self, packet_ids: bytes) -> None:
        """Sensors / Query List: the data of each id, back to back."""
        self._tx_extend(b"".join(self._sensors.encode_request(pid) for pid in packet_ids))

    def start_stream(self, packet_ids: Sequence[int]) -> None:
        self.stream_ids = list(packet_ids)
        self.streaming = bool(self.stream_ids)
        self._stream_phase_s = 0.0

    def pause_resume_stream(self, resume: bool) -> None:
        if not resume:
            self.streaming = False
        elif self.stream_ids:
            self.streaming = True
            self._stream_phase_s = 0.0

    def play_script(self) -> None:
        self._rx[0:0] = self.script              # into the input queue, ahead of the rest

    def show_script(self) -> None:
        self.streaming = False                   # the spec: Show Script halts the stream
        self._tx_extend(bytes([len(self.script)]) + self.script)

    def start_wait(self, kind: str, target: float) -> None:
        self._wait = _Wait(kind, float(target))
        self._check_wait()

    # ------------------------------------------------------------------ time
    def _advance(self, h: float, travel: Optional[Tuple[float, float]]) -> None:
        """Move time forward by h [s] with no stream frame or wait deadline inside."""
        distance_mm, angle_deg = self.advance_physics(h, travel)
        if self._wait is not None:
            if self._wait.kind == "distance":
                self._wait.progress += distance_mm
            elif self._wait.kind == "angle":
                self._wait.progress += angle_deg
            elif self._wait.kind == "time":
                self._wait.progress += h
            self._check_wait()
            if self._wait is None:
                self._process_input()            # the held commands run from now on

    def _check_wait(self) -> None:
        wait = self._wait
        if wait is None:
            return
        if wait.kind == "event":
            test = self._events.get(abs(int(wait.target)))
            done = test is None or test() == (wait.target > 0)
        elif wait.kind == "time":
            done = wait.progress >= wait.target - EPS
        else:  # distance / angle: reached in the direction of the target's sign
            done = (wait.progress >= wait.target if wait.target >= 0
                    else wait.progress <= wait.target)
        if done:
            self._wait = None

    def _sensors_changed(self) -> None:
        self._check_safety()
        if self._wait is not None:
            self._check_wait()
            if self._wait is None:
                self._process_input()            # the held commands run from now on

    # ------------------------------------------------------------------ output
    def _send_stream_frame(self) -> None:
        self._tx_extend(self._sensors.stream_frame(self.stream_ids))
        self.frames_sent += 1

    def _tx_extend(self, data: bytes) -> None:
        self._tx.extend(data)
        excess = len(self._tx) - TX_BUFFER_LIMIT
        if excess > 0:                             # nobody reads: the oldest bytes are gone
            del self._tx[:excess]
            self.tx_dropped_bytes += excess
