"""Byte-exact emulator of the first-generation iRobot Create Open Interface (pure Python).

The emulator speaks the Create OI (iRobot Create Open Interface specification, the 2006-2007
Create, not the Roomba 500 / Create 2 one): bytes from the host go into :meth:`VirtualCreate.feed`,
bytes for the host come out of :meth:`VirtualCreate.read_output`, and :meth:`VirtualCreate.step`
advances emulated time (wheels, odometry, battery, songs, wait commands and the 15 ms sensor
stream). It has no I/O of its own: :class:`irobot_create_2_1.pty_link.PtyLink` puts it behind
a pseudo-terminal, the simulator embeds it directly.

Packet sizes, signedness and encodings come from :mod:`irobot_create_2_1.protocol`; this module
only decides *values* and *behaviour*.

Behaviour choices where the spec is silent or where we deliberately differ (see also the
package README):

* Distance (19) and angle (20) are accumulated as floats and reported truncated toward zero;
  the sub-unit remainder is carried to the next read. The real firmware truncates and drops
  the remainder, so a host polling every 15 ms at low speed loses up to 1 mm / 1 deg per read
  (e.g. 100 mm/s at 66 Hz = 1.5 mm per read -> the robot reports 1 mm: a 33 % bias).
  Carrying keeps odometry built from many small reads unbiased, which is what the simulator
  needs; the value of each single read is still an integer, clamped to int16 as the spec says
  (the part beyond the clamp is lost, as on the robot).
* Drive: velocity is clamped to +-max_wheel_speed, radius to +-2000 mm (the special values
  0x8000/0x7FFF straight and -1/+1 spin are kept); radius 0 (unspecified) drives straight.
  If a wheel of an arc would exceed the maximum speed, both wheels are scaled down together
  so the requested radius is kept.
* Off mode listens only for Start (128): every other byte is discarded one by one, like the
  robot's OI that is not started yet. In passive/safe/full, commands are framed by their
  lengths; commands not allowed in the current mode are consumed and ignored; unknown
  opcodes are skipped one byte at a time.
* Safe-mode safety follows the spec: a wheel drop (any wheel, caster too) or a powered
  charger always trips; a cliff trips while the robot moves forward, spins, or backs up on
  a radius smaller than the robot radius (backing straight away from a cliff is allowed).
  A trip stops the motors and drops to passive. Full mode never trips.
* Sensors/Query List with an id outside 0..42 sends nothing for that id; Stream skips such
  ids; a stream frame is limited to 255 data bytes (N-bytes is one byte), later ids are
  left out. Stream with 0 packets stops the stream.
* Wait Time/Distance/Angle/Event hold the input queue (bytes are buffered, up to
  ``RX_BUFFER_LIMIT``) until the condition is met; the sensor stream keeps running. An
  unknown event id ends the wait at once.
* Demos (Spot, Cover, Cover-and-Dock, Demo) switch to passive and are recorded
  (``last_demo``, ``demo_running``, ``docking_requested``), but the built-in behaviours
  are not emulated: the wheels stay still.
* When the battery charge reaches 0 the motors stop and Drive commands are ignored.
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from ascc_common.pose2d import wrap_angle
from irobot_create_2_1 import protocol

# OI modes, values as in sensor packet 35.
OFF, PASSIVE, SAFE, FULL = 0, 1, 2, 3
MODE_NAMES = ("off", "passive", "safe", "full")

STREAM_PERIOD_S = protocol.STREAM_PERIOD_S      # the Create streams every 15 ms
MAX_RADIUS_MM = protocol.MAX_RADIUS_MM          # Drive radius range of the spec
RADIUS_STRAIGHT = (protocol.STRAIGHT_RADIUS - 0x10000, 0x7FFF)  # 0x8000 read as int16
RADIUS_SPIN_CW = protocol.SPIN_CW_RADIUS
RADIUS_SPIN_CCW = protocol.SPIN_CCW_RADIUS
ROBOT_RADIUS_MM = 165.0          # Create body: 330 mm diameter (safe-mode cliff rule)
SCRIPT_MAX_BYTES = 100
SONG_SLOTS = 16                  # songs 0..15
SONG_MAX_NOTES = 16
SONG_TICK_S = 1.0 / 64.0         # note durations are in 1/64 s
WAIT_TIME_TICK_S = 0.1           # Wait Time argument is in 0.1 s
DEMO_ABORT = -1                  # Demo data byte 255
DEMO_COVER, DEMO_COVER_AND_DOCK, DEMO_SPOT_COVER = 0, 1, 2
BAUD_CODE_MAX = 11
RX_BUFFER_LIMIT = 4096           # bytes held while a wait command blocks the input [bytes]
TX_BUFFER_LIMIT = 65536          # robot->host bytes kept when nobody reads [bytes]
MAX_COMMANDS_PER_CALL = 1024     # bounds work per feed/step (a looping script never hangs)
MAX_FRAME_DATA_BYTES = 255

# Sensor signal levels (0..4095) reported for the simulated analog sensors.
CLIFF_SIGNAL_FLOOR = 1500
CLIFF_SIGNAL_CLIFF = 20
WALL_SIGNAL_WALL = 800

# Battery model (a NiMH pack: linear voltage over state of charge is a simplification).
BATTERY_EMPTY_MV = 12000.0
BATTERY_FULL_MV = 16500.0
IDLE_CURRENT_MA = 150.0          # electronics, motors still [mA]
MOTOR_CURRENT_MA_PER_MPS = 1000.0  # per wheel, per m/s of wheel speed [mA/(m/s)]
CHARGE_CURRENT_MA = 1500.0       # full charging [mA]
TRICKLE_CURRENT_MA = 100.0       # trickle charging at full charge [mA]
BATTERY_TEMPERATURE_C = 25
CHARGING_NOT, CHARGING_FULL, CHARGING_TRICKLE = 0, 2, 3

_EPS = 1e-9

LedState = namedtuple("LedState", "play advance power_color power_intensity")
"""LEDs as last set by the LEDs command (play/advance bools, power color/intensity 0..255)."""


def _int16(data: bytes) -> int:
    return int.from_bytes(data, "big", signed=True)


def _int8(value: int) -> int:
    return value - 256 if value > 127 else value


def _clamp(value: float, low: float, high: float) -> float:
    return low if value < low else high if value > high else value


class Battery:
    """Charge bookkeeping of the Create's battery pack (SI-ish: mAh, mA, mV, degC)."""

    def __init__(self, capacity_mah: float, charge_mah: Optional[float] = None):
        if capacity_mah <= 0:
            raise ValueError("battery capacity must be > 0 mAh, got %r" % capacity_mah)
        self.capacity_mah = float(capacity_mah)
        self.charge_mah = float(capacity_mah if charge_mah is None else charge_mah)
        self.charge_mah = _clamp(self.charge_mah, 0.0, self.capacity_mah)
        self.current_ma = -IDLE_CURRENT_MA
        self.temperature_c = BATTERY_TEMPERATURE_C
        self.charging_state = CHARGING_NOT

    @property
    def state_of_charge(self) -> float:
        return self.charge_mah / self.capacity_mah

    @property
    def voltage_mv(self) -> float:
        return BATTERY_EMPTY_MV + (BATTERY_FULL_MV - BATTERY_EMPTY_MV) * self.state_of_charge

    @property
    def empty(self) -> bool:
        return self.charge_mah <= 0.0

    def update(self, dt_s: float, left_mps: float, right_mps: float, charger: bool) -> None:
        """Advance by dt_s with the given wheel speeds; charger = a powered source present."""
        if charger:
            full = self.charge_mah >= self.capacity_mah
            self.charging_state = CHARGING_TRICKLE if full else CHARGING_FULL
            self.current_ma = TRICKLE_CURRENT_MA if full else CHARGE_CURRENT_MA
        else:
            self.charging_state = CHARGING_NOT
            self.current_ma = -(IDLE_CURRENT_MA
                                + MOTOR_CURRENT_MA_PER_MPS * (abs(left_mps) + abs(right_mps)))
        self.charge_mah += self.current_ma * dt_s / 3600.0
        self.charge_mah = _clamp(self.charge_mah, 0.0, self.capacity_mah)


class _Wait:
    """A running Wait Time/Distance/Angle/Event command."""

    __slots__ = ("kind", "target", "progress")

    def __init__(self, kind: str, target: float):
        self.kind = kind          # 'time' [s] | 'distance' [mm] | 'angle' [deg] | 'event' [id]
        self.target = target
        self.progress = 0.0


class VirtualCreate:
    """First-generation iRobot Create speaking the Open Interface, in emulated time.

    Not thread-safe: call it from one thread (or hold a lock).
    """

    def __init__(self, wheel_base_m: float = 0.258, battery_capacity_mah: float = 2700.0,
                 initial_charge_mah: Optional[float] = None, max_wheel_speed_mm_s: float = 500):
        if wheel_base_m <= 0 or max_wheel_speed_mm_s <= 0:
            raise ValueError("wheel_base_m and max_wheel_speed_mm_s must be > 0")
        self.wheel_base_m = float(wheel_base_m)
        self.max_wheel_speed_mm_s = float(max_wheel_speed_mm_s)
        self.battery = Battery(battery_capacity_mah, initial_charge_mah)
        self.time_s = 0.0

        self._mode = OFF
        self._rx = bytearray()
        self._tx = bytearray()
        # Commanded wheel speeds [mm/s] and the requested-value packets 39..42.
        self._left_mm_s = 0.0
        self._right_mm_s = 0.0
        self.requested_velocity_mm_s = 0
        self.requested_radius_mm = 0
        self.requested_right_mm_s = 0
        self.requested_left_mm_s = 0
        # Ground truth pose [m, m, rad] and the last step's body velocity [m/s, rad/s].
        self._x = self._y = self._theta = 0.0
        self.body_velocity = (0.0, 0.0)
        # Odometry accumulators read (and reset) by packets 19/20.
        self._distance_acc_mm = 0.0
        self._angle_acc_deg = 0.0

        # Sensors the simulator or a test sets.
        self.bump_left = self.bump_right = False
        self.wheel_drop_left = self.wheel_drop_right = self.wheel_drop_caster = False
        self.cliff_left = self.cliff_front_left = False
        self.cliff_front_right = self.cliff_right = False
        self.wall = False
        self.wall_signal = 0
        self.virtual_wall = False
        self.ir_byte = 255                     # 255 = no IR byte received
        self.button_play = self.button_advance = False
        self.home_base = self.internal_charger = False
        self.cargo_digital_inputs = 0
        self.cargo_analog_input = 0
        self.overcurrent_bits = 0

        # Actuator state the host sets (inspectable).
        self.leds = LedState(False, False, 0, 0)
        self.songs: Dict[int, List[Tuple[int, int]]] = {}
        self.song_number = 0
        self.song_playing = False
        self.songs_played: List[int] = []
        self._song_time_left_s = 0.0
        self.last_demo: Optional[int] = None
        self.demo_running = False
        self.docking_requested = False
        self.baud_code = 10                    # 57600 baud, the Create's default
        self.low_side_drivers = 0
        self.pwm_low_side = (0, 0, 0)          # duty cycles of drivers 2, 1, 0 (0..128)
        self.digital_outputs = 0
        self.sent_ir: List[int] = []
        self.script = b""

        # Stream.
        self.stream_ids: List[int] = []
        self.streaming = False
        self._stream_phase_s = 0.0

        self._wait: Optional[_Wait] = None

        # Counters (diagnostics for tests).
        self.commands_executed = 0
        self.commands_ignored = 0
        self.unknown_bytes = 0
        self.rx_dropped_bytes = 0
        self.tx_dropped_bytes = 0
        self.safety_trips = 0
        self.frames_sent = 0

        self._commands = self._command_table()
        self._lengths = self._fixed_lengths()
        self._packet_values = self._packet_value_table()
        self._events = self._event_table()

    # ------------------------------------------------------------------ public interface
    @property
    def mode(self) -> str:
        return MODE_NAMES[self._mode]

    @property
    def oi_mode(self) -> int:
        return self._mode

    @property
    def wheel_speed_cmd_mps(self) -> Tuple[float, float]:
        """(left, right) wheel speeds the motors are commanded now [m/s]."""
        return self._left_mm_s / 1000.0, self._right_mm_s / 1000.0

    @property
    def pose(self) -> Tuple[float, float, float]:
        """(x [m], y [m], theta [rad]) integrated from wheel travel (emulator ground truth)."""
        return self._x, self._y, self._theta

    def set_pose(self, x_m: float, y_m: float, theta_rad: float) -> None:
        """Place the robot (does not touch the odometry accumulators)."""
        self._x, self._y, self._theta = float(x_m), float(y_m), wrap_angle(theta_rad)

    def power_cycle(self) -> None:
        """The robot switched off and on again (power button, a brown-out): the OI is back
        in off mode, listening only for Start; the motors stop; the sensor stream, a
        pending wait, a playing song and half-received commands are gone. Pose, battery and
        the sensors set by the simulator are kept, and so are stored songs and the script
        (the spec does not say; nothing here depends on it)."""
        self._mode = OFF
        self._stop_motors()
        self._rx.clear()
        self._wait = None
        self.stream_ids = []
        self.streaming = False
        self._stream_phase_s = 0.0
        self.song_playing = False
        self._song_time_left_s = 0.0
        self.demo_running = False
        self.docking_requested = False

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
        while remaining > _EPS:
            if self.streaming and STREAM_PERIOD_S - self._stream_phase_s <= _EPS:
                self._send_stream_frame()
                self._stream_phase_s = 0.0
            h = remaining
            if self.streaming:
                h = min(h, STREAM_PERIOD_S - self._stream_phase_s)
            if self._wait is not None and self._wait.kind == "time":
                h = min(h, max(self._wait.target - self._wait.progress, _EPS))
            part = None if travel is None else (travel[0] * h / dt_s, travel[1] * h / dt_s)
            self._advance(h, part)
            remaining -= h
            if self.streaming:
                self._stream_phase_s += h
        if self.streaming and STREAM_PERIOD_S - self._stream_phase_s <= _EPS:
            self._send_stream_frame()
            self._stream_phase_s = 0.0
        self._process_input()

    # Sensor setters (simulator/test side). Each re-checks safe-mode safety and wait events.
    def set_bumpers(self, left: bool, right: bool) -> None:
        self.bump_left, self.bump_right = bool(left), bool(right)
        self._sensors_changed()

    def set_cliffs(self, left: bool = False, front_left: bool = False,
                   front_right: bool = False, right: bool = False) -> None:
        self.cliff_left, self.cliff_front_left = bool(left), bool(front_left)
        self.cliff_front_right, self.cliff_right = bool(front_right), bool(right)
        self._sensors_changed()

    def set_wheel_drops(self, left: bool = False, right: bool = False,
                        caster: bool = False) -> None:
        self.wheel_drop_left, self.wheel_drop_right = bool(left), bool(right)
        self.wheel_drop_caster = bool(caster)
        self._sensors_changed()

    def set_wall(self, wall: bool, signal: Optional[int] = None) -> None:
        self.wall = bool(wall)
        self.wall_signal = int(signal) if signal is not None else (
            WALL_SIGNAL_WALL if wall else 0)
        self._sensors_changed()

    def set_virtual_wall(self, seen: bool) -> None:
        self.virtual_wall = bool(seen)
        self._sensors_changed()

    def set_ir_byte(self, value: int) -> None:
        self.ir_byte = int(_clamp(int(value), 0, 255))
        self._sensors_changed()

    def set_buttons(self, play: bool, advance: bool) -> None:
        self.button_play, self.button_advance = bool(play), bool(advance)
        self._sensors_changed()

    def set_charging_sources(self, home_base: bool, internal: bool = False) -> None:
        self.home_base, self.internal_charger = bool(home_base), bool(internal)
        self._sensors_changed()

    def set_cargo_inputs(self, digital_bits: int = 0, analog: int = 0) -> None:
        self.cargo_digital_inputs = int(digital_bits) & 0x1F
        self.cargo_analog_input = int(_clamp(int(analog), 0, 1023))
        self._sensors_changed()

    # ------------------------------------------------------------------ command parsing
    def _command_table(self) -> Dict[int, Tuple[Callable[[bytes], None], Tuple[int, ...]]]:
        p = protocol
        anymode = (OFF, PASSIVE, SAFE, FULL)
        on = (PASSIVE, SAFE, FULL)
        act = (SAFE, FULL)
        return {
            p.START: (self._cmd_start, anymode),
            p.BAUD: (self._cmd_baud, on),
            p.CONTROL: (self._cmd_safe, on),    # Control is the old SCI name of Safe
            p.SAFE: (self._cmd_safe, on),
            p.FULL: (self._cmd_full, on),
            p.SPOT: (lambda a: self._start_demo(DEMO_SPOT_COVER), on),
            p.COVER: (lambda a: self._start_demo(DEMO_COVER), on),
            p.COVER_AND_DOCK: (lambda a: self._start_demo(DEMO_COVER_AND_DOCK), on),
            p.DEMO: (lambda a: self._start_demo(_int8(a[0])), on),
            p.DRIVE: (self._cmd_drive, act),
            p.DRIVE_DIRECT: (self._cmd_drive_direct, act),
            p.LOW_SIDE_DRIVERS: (self._cmd_low_side_drivers, act),
            p.PWM_LOW_SIDE_DRIVERS: (self._cmd_pwm_low_side, act),
            p.DIGITAL_OUTPUTS: (self._cmd_digital_outputs, act),
            p.SEND_IR: (lambda a: self.sent_ir.append(a[0]), act),
            p.LEDS: (self._cmd_leds, act),
            p.SONG: (self._cmd_song, on),
            p.PLAY: (self._cmd_play, act),
            p.SENSORS: (lambda a: self._tx_extend(self._encode_request(a[0])), on),
            p.QUERY_LIST: (self._cmd_query_list, on),
            p.STREAM: (self._cmd_stream, on),
            p.PAUSE_RESUME_STREAM: (self._cmd_pause_resume, on),
            p.SCRIPT: (self._cmd_script, on),
            p.PLAY_SCRIPT: (self._cmd_play_script, on),
            p.SHOW_SCRIPT: (self._cmd_show_script, on),
            p.WAIT_TIME: (lambda a: self._start_wait("time", a[0] * WAIT_TIME_TICK_S), on),
            p.WAIT_DISTANCE: (self._cmd_wait_distance, on),
            p.WAIT_ANGLE: (self._cmd_wait_angle, on),
            p.WAIT_EVENT: (lambda a: self._start_wait("event", _int8(a[0])), on),
        }

    def _fixed_lengths(self) -> Dict[int, int]:
        """Total length (opcode + data) of every fixed-length command, from protocol.py."""
        variable = (protocol.SONG, protocol.STREAM, protocol.QUERY_LIST, protocol.SCRIPT)
        lengths = {}
        for op in self._commands:
            if op in variable:
                continue
            if op not in protocol.FIXED_ARG_BYTES:
                raise KeyError("protocol.FIXED_ARG_BYTES lacks opcode %d" % op)
            lengths[op] = 1 + protocol.FIXED_ARG_BYTES[op]
        return lengths

    def _command_length(self, op: int) -> Optional[int]:
        """Bytes the command at the head of the queue needs, None if not known yet."""
        fixed = self._lengths.get(op)
        if fixed is not None:
            return fixed
        if op == protocol.SONG:              # [140][song][n][note, duration] * n
            return 3 + 2 * self._rx[2] if len(self._rx) >= 3 else None
        return 2 + self._rx[1] if len(self._rx) >= 2 else None   # [op][n][n bytes]

    def _process_input(self) -> None:
        done = 0
        while self._rx and self._wait is None and done < MAX_COMMANDS_PER_CALL:
            op = self._rx[0]
            if self._mode == OFF and op != protocol.START:
                del self._rx[0]                  # the OI only listens for Start when off
                self.unknown_bytes += 1
                continue
            entry = self._commands.get(op)
            if entry is None:
                del self._rx[0]
                self.unknown_bytes += 1
                continue
            need = self._command_length(op)
            if need is None or len(self._rx) < need:
                return                           # wait for the rest of the command
            args = bytes(self._rx[1:need])
            del self._rx[:need]
            done += 1
            handler, modes = entry
            if self._mode in modes:
                handler(args)
                self.commands_executed += 1
            else:
                self.commands_ignored += 1
            self._check_safety()

    # ------------------------------------------------------------------ commands
    def _cmd_start(self, _args: bytes) -> None:
        self._enter_passive()

    def _cmd_baud(self, args: bytes) -> None:
        if args[0] <= BAUD_CODE_MAX:
            self.baud_code = args[0]

    def _cmd_safe(self, _args: bytes) -> None:
        self._mode = SAFE
        self.demo_running = False
        self.docking_requested = False

    def _cmd_full(self, _args: bytes) -> None:
        self._mode = FULL
        self.demo_running = False
        self.docking_requested = False

    def _enter_passive(self) -> None:
        self._mode = PASSIVE
        self._stop_motors()

    def _start_demo(self, number: int) -> None:
        self._enter_passive()
        self.last_demo = number
        self.demo_running = number != DEMO_ABORT
        self.docking_requested = number == DEMO_COVER_AND_DOCK

    def _cmd_drive(self, args: bytes) -> None:
        velocity = int(_clamp(_int16(args[0:2]), -self.max_wheel_speed_mm_s,
                              self.max_wheel_speed_mm_s))
        radius = _int16(args[2:4])
        self.requested_velocity_mm_s = velocity
        self.requested_radius_mm = radius
        self._set_wheels(*self._drive_wheel_speeds(velocity, radius))

    def _drive_wheel_speeds(self, velocity: float, radius: int) -> Tuple[float, float]:
        """(left, right) [mm/s] for a Drive command: arc of `radius` [mm], + = left turn."""
        if radius in RADIUS_STRAIGHT or radius == 0:
            return velocity, velocity
        if radius == RADIUS_SPIN_CW:
            return velocity, -velocity
        if radius == RADIUS_SPIN_CCW:
            return -velocity, velocity
        r = _clamp(radius, -MAX_RADIUS_MM, MAX_RADIUS_MM)
        half = self.wheel_base_m * 1000.0 / 2.0
        left = velocity * (r - half) / r
        right = velocity * (r + half) / r
        peak = max(abs(left), abs(right))
        if peak > self.max_wheel_speed_mm_s:   # keep the radius, slow both wheels
            scale = self.max_wheel_speed_mm_s / peak
            left, right = left * scale, right * scale
        return left, right

    def _cmd_drive_direct(self, args: bytes) -> None:
        vmax = self.max_wheel_speed_mm_s
        right = int(_clamp(_int16(args[0:2]), -vmax, vmax))   # right wheel first on the wire
        left = int(_clamp(_int16(args[2:4]), -vmax, vmax))
        self.requested_right_mm_s = right
        self.requested_left_mm_s = left
        self._set_wheels(left, right)

    def _set_wheels(self, left_mm_s: float, right_mm_s: float) -> None:
        if self.battery.empty:
            left_mm_s = right_mm_s = 0.0
        self._left_mm_s, self._right_mm_s = float(left_mm_s), float(right_mm_s)

    def _stop_motors(self) -> None:
        self._left_mm_s = self._right_mm_s = 0.0

    def _cmd_low_side_drivers(self, args: bytes) -> None:
        self.low_side_drivers = args[0] & 0x07

    def _cmd_pwm_low_side(self, args: bytes) -> None:
        self.pwm_low_side = tuple(min(b, 128) for b in args[:3])

    def _cmd_digital_outputs(self, args: bytes) -> None:
        self.digital_outputs = args[0] & 0x07

    def _cmd_leds(self, args: bytes) -> None:
        bits = args[0]
        self.leds = LedState(bool(bits & 0x02), bool(bits & 0x08), args[1], args[2])

    def _cmd_song(self, args: bytes) -> None:
        number, length = args[0], args[1]
        if number >= SONG_SLOTS or not 1 <= length <= SONG_MAX_NOTES:
            return                               # out of spec: consumed, ignored
        notes = args[2:2 + 2 * length]
        self.songs[number] = [(notes[i], notes[i + 1]) for i in range(0, len(notes), 2)]

    def _cmd_play(self, args: bytes) -> None:
        number = args[0]
        if self.song_playing or number not in self.songs:
            return                               # the spec: no effect while a song plays
        self.song_number = number
        self.song_playing = True
        self.songs_played.append(number)
        self._song_time_left_s = sum(d for _n, d in self.songs[number]) * SONG_TICK_S

    def _cmd_query_list(self, args: bytes) -> None:
        self._tx_extend(b"".join(self._encode_request(pid) for pid in args[1:]))

    def _cmd_stream(self, args: bytes) -> None:
        self.stream_ids = list(args[1:])
        self.streaming = bool(self.stream_ids)
        self._stream_phase_s = 0.0

    def _cmd_pause_resume(self, args: bytes) -> None:
        if args[0] == 0:
            self.streaming = False
        elif args[0] == 1 and self.stream_ids:
            self.streaming = True
            self._stream_phase_s = 0.0

    def _cmd_script(self, args: bytes) -> None:
        length = args[0]
        if length <= SCRIPT_MAX_BYTES:
            self.script = bytes(args[1:1 + length])

    def _cmd_play_script(self, _args: bytes) -> None:
        self._rx[0:0] = self.script              # into the input queue, ahead of the rest

    def _cmd_show_script(self, _args: bytes) -> None:
        self.streaming = False                   # the spec: Show Script halts the stream
        self._tx_extend(bytes([len(self.script)]) + self.script)

    def _cmd_wait_distance(self, args: bytes) -> None:
        self._distance_acc_mm = 0.0              # the spec: resets the distance variable
        self._start_wait("distance", _int16(args))

    def _cmd_wait_angle(self, args: bytes) -> None:
        self._angle_acc_deg = 0.0
        self._start_wait("angle", _int16(args))

    def _start_wait(self, kind: str, target: float) -> None:
        self._wait = _Wait(kind, float(target))
        self._check_wait()

    # ------------------------------------------------------------------ time
    def _advance(self, h: float, travel: Optional[Tuple[float, float]]) -> None:
        """Move time forward by h [s] with no stream frame or wait deadline inside."""
        self._check_safety()
        left_mps, right_mps = self.wheel_speed_cmd_mps
        if travel is None:
            travel = (left_mps * h, right_mps * h)
        self._integrate(travel[0], travel[1], h)
        self.battery.update(h, left_mps, right_mps, self._charger_present())
        if self.battery.empty:
            self._stop_motors()
        if self.song_playing:
            self._song_time_left_s -= h
            if self._song_time_left_s <= _EPS:
                self.song_playing = False
        self.time_s += h
        if self._wait is not None:
            if self._wait.kind == "time":
                self._wait.progress += h
            self._check_wait()
            if self._wait is None:
                self._process_input()            # the held commands run from now on

    def _integrate(self, dl: float, dr: float, h: float) -> None:
        """Dead-reckon wheel travel (left dl, right dr [m]) over h [s]: exact arc."""
        ds = 0.5 * (dl + dr)
        dtheta = (dr - dl) / self.wheel_base_m
        if abs(dtheta) < 1e-12:
            self._x += ds * math.cos(self._theta)
            self._y += ds * math.sin(self._theta)
        else:
            radius = ds / dtheta
            self._x += radius * (math.sin(self._theta + dtheta) - math.sin(self._theta))
            self._y -= radius * (math.cos(self._theta + dtheta) - math.cos(self._theta))
        self._theta = wrap_angle(self._theta + dtheta)
        self._distance_acc_mm += ds * 1000.0
        self._angle_acc_deg += math.degrees(dtheta)
        if self._wait is not None and self._wait.kind == "distance":
            self._wait.progress += ds * 1000.0
        elif self._wait is not None and self._wait.kind == "angle":
            self._wait.progress += math.degrees(dtheta)
        self.body_velocity = (ds / h, dtheta / h) if h > 0 else (0.0, 0.0)

    def _check_wait(self) -> None:
        wait = self._wait
        if wait is None:
            return
        if wait.kind == "event":
            test = self._events.get(abs(int(wait.target)))
            done = test is None or test() == (wait.target > 0)
        elif wait.kind == "time":
            done = wait.progress >= wait.target - _EPS
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

    # ------------------------------------------------------------------ safety
    def _charger_present(self) -> bool:
        return self.home_base or self.internal_charger

    def _cliff_any(self) -> bool:
        return (self.cliff_left or self.cliff_front_left or self.cliff_front_right
                or self.cliff_right)

    def _wheel_drop_any(self) -> bool:
        return self.wheel_drop_left or self.wheel_drop_right or self.wheel_drop_caster

    def _unsafe_motion_near_cliff(self) -> bool:
        """Moving forward, spinning, or backing up on a radius below the robot radius."""
        left, right = self._left_mm_s, self._right_mm_s
        if left == 0.0 and right == 0.0:
            return False
        velocity = 0.5 * (left + right)
        if velocity >= 0.0:
            return True
        omega = (right - left) / (self.wheel_base_m * 1000.0)    # [rad/s], mm-based
        return omega != 0.0 and abs(velocity / omega) < ROBOT_RADIUS_MM

    def _check_safety(self) -> None:
        if self._mode != SAFE:
            return
        if (self._wheel_drop_any() or self._charger_present()
                or (self._cliff_any() and self._unsafe_motion_near_cliff())):
            self._enter_passive()
            self.safety_trips += 1

    # ------------------------------------------------------------------ sensor packets
    def _packet_value_table(self) -> Dict[int, Callable[[], int]]:
        p, b = protocol, int
        return {
            7: lambda: (p.WHEELDROP_CASTER * b(self.wheel_drop_caster)
                        | p.WHEELDROP_LEFT * b(self.wheel_drop_left)
                        | p.WHEELDROP_RIGHT * b(self.wheel_drop_right)
                        | p.BUMP_LEFT * b(self.bump_left) | p.BUMP_RIGHT * b(self.bump_right)),
            8: lambda: b(self.wall),
            9: lambda: b(self.cliff_left),
            10: lambda: b(self.cliff_front_left),
            11: lambda: b(self.cliff_front_right),
            12: lambda: b(self.cliff_right),
            13: lambda: b(self.virtual_wall),
            14: lambda: self.overcurrent_bits,
            15: lambda: 0,
            16: lambda: 0,
            17: lambda: self.ir_byte,
            18: lambda: (p.BUTTON_ADVANCE * b(self.button_advance)
                         | p.BUTTON_PLAY * b(self.button_play)),
            19: self._read_distance,
            20: self._read_angle,
            21: lambda: self.battery.charging_state,
            22: lambda: round(self.battery.voltage_mv),
            23: lambda: round(self.battery.current_ma),
            24: lambda: round(self.battery.temperature_c),
            25: lambda: round(self.battery.charge_mah),
            26: lambda: round(self.battery.capacity_mah),
            27: lambda: self.wall_signal,
            28: lambda: self._cliff_signal(self.cliff_left),
            29: lambda: self._cliff_signal(self.cliff_front_left),
            30: lambda: self._cliff_signal(self.cliff_front_right),
            31: lambda: self._cliff_signal(self.cliff_right),
            32: lambda: self.cargo_digital_inputs,
            33: lambda: self.cargo_analog_input,
            34: lambda: (p.SOURCE_HOME_BASE * b(self.home_base)
                         | p.SOURCE_INTERNAL_CHARGER * b(self.internal_charger)),
            35: lambda: self._mode,
            36: lambda: self.song_number,
            37: lambda: b(self.song_playing),
            38: lambda: len(self.stream_ids),
            39: lambda: self.requested_velocity_mm_s,
            40: lambda: self.requested_radius_mm,
            41: lambda: self.requested_right_mm_s,
            42: lambda: self.requested_left_mm_s,
        }

    def _event_table(self) -> Dict[int, Callable[[], bool]]:
        """Wait Event ids of the Create OI -> condition."""
        table = {
            1: self._wheel_drop_any,
            2: lambda: self.wheel_drop_caster,
            3: lambda: self.wheel_drop_left,
            4: lambda: self.wheel_drop_right,
            5: lambda: self.bump_left or self.bump_right,
            6: lambda: self.bump_left,
            7: lambda: self.bump_right,
            8: lambda: self.virtual_wall,
            9: lambda: self.wall,
            10: self._cliff_any,
            11: lambda: self.cliff_left,
            12: lambda: self.cliff_front_left,
            13: lambda: self.cliff_front_right,
            14: lambda: self.cliff_right,
            15: lambda: self.home_base,
            16: lambda: self.button_advance,
            17: lambda: self.button_play,
            22: lambda: self._mode == PASSIVE,
        }
        for bit in range(4):                       # 18..21: cargo bay digital inputs 0..3
            table[18 + bit] = (lambda k: lambda: bool(self.cargo_digital_inputs >> k & 1))(bit)
        return table

    @staticmethod
    def _cliff_signal(cliff: bool) -> int:
        return CLIFF_SIGNAL_CLIFF if cliff else CLIFF_SIGNAL_FLOOR

    def _read_distance(self) -> int:
        whole = math.trunc(self._distance_acc_mm)
        self._distance_acc_mm -= whole             # carry the sub-millimetre remainder
        return whole

    def _read_angle(self) -> int:
        whole = math.trunc(self._angle_acc_deg)
        self._angle_acc_deg -= whole               # carry the sub-degree remainder
        return whole

    @staticmethod
    def _is_valid_request(pid: int) -> bool:
        return pid in protocol.PACKETS or pid in protocol.GROUPS

    def _encode_request(self, pid: int) -> bytes:
        """Data bytes of packet or group `pid` (b'' for an unknown id); reads 19/20."""
        if not self._is_valid_request(pid):
            return b""
        return b"".join(self._encode_single(m) for m in protocol.expand(pid))

    def _encode_single(self, pid: int) -> bytes:
        spec = protocol.PACKETS[pid]
        bits = 8 * spec.size
        low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if spec.signed else (
            0, (1 << bits) - 1)
        value = int(_clamp(int(self._packet_values[pid]()), low, high))
        return protocol.encode_value(pid, value)

    def _send_stream_frame(self) -> None:
        body = bytearray()
        for pid in self.stream_ids:
            if not self._is_valid_request(pid):
                continue
            if len(body) + 1 + protocol.packet_size(pid) > MAX_FRAME_DATA_BYTES:
                break
            body.append(pid)
            body.extend(self._encode_request(pid))
        header = bytes([protocol.STREAM_HEADER, len(body)])
        checksum = (-(sum(header) + sum(body))) & 0xFF
        self._tx_extend(header + bytes(body) + bytes([checksum]))
        self.frames_sent += 1

    def _tx_extend(self, data: bytes) -> None:
        self._tx.extend(data)
        excess = len(self._tx) - TX_BUFFER_LIMIT
        if excess > 0:                             # nobody reads: the oldest bytes are gone
            del self._tx[:excess]
            self.tx_dropped_bytes += excess
