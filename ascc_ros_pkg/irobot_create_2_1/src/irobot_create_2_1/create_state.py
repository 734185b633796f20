"""The emulated iRobot Create's state and physics (pure Python, no bytes): the
first-generation Create, or the Create 2 (``robot=models.CREATE_2``: wheel encoders, light
bumpers, motor currents, stasis).

:class:`CreateState` holds what the robot is: OI mode, commanded wheels and the requested
values of packets 39..42, the pose integrated from wheel travel, the odometry accumulators
of packets 19/20, the sensors the simulator sets, the battery and the actuators the host
sets (LEDs, songs, demos, outputs). Its methods are the actions a decoded command takes
(:mod:`irobot_create_2_1.oi_commands`) and the physics of one time step; the sensor bytes
are :mod:`irobot_create_2_1.oi_sensors`, the emulator tying them is
:class:`irobot_create_2_1.virtual_create.VirtualCreate`.

Behaviour choices where the spec is silent or where we deliberately differ:

* Drive: velocity is clamped to +-max_wheel_speed, radius to +-2000 mm (the special values
  0x8000/0x7FFF straight and -1/+1 spin are kept); radius 0 (unspecified) drives straight.
  If a wheel of an arc would exceed the maximum speed, both wheels are scaled down together
  so the requested radius is kept.
* Distance and angle are accumulated as floats; :meth:`CreateState.read_distance` /
  :meth:`CreateState.read_angle` return them truncated toward zero and carry the sub-unit
  remainder to the next read (see :mod:`irobot_create_2_1.oi_sensors` for why).
* Safe-mode safety follows the spec: a wheel drop (any wheel, caster too) or a powered
  charger always trips; a cliff trips while the robot moves forward, spins, or backs up on
  a radius smaller than the robot radius (backing straight away from a cliff is allowed).
  A trip stops the motors and drops to passive. Full mode never trips.
* Demos (Spot, Cover, Cover-and-Dock, Demo) switch to passive and are recorded
  (``last_demo``, ``demo_running``, ``docking_requested``), but the built-in behaviours
  are not emulated: the wheels stay still.
* When the battery charge reaches 0 the motors stop and Drive commands are ignored.
* Create 2: the encoder counts follow the wheels' travel, so they agree with the pose;
  :meth:`CreateState.set_stuck` holds the body still while the wheels keep turning (a
  robot high-centred or pushing an obstacle): encoders count, stasis stays still.
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Dict, List, Optional, Tuple

from ascc_common.pose2d import wrap_angle
from irobot_create_2_1 import protocol
from irobot_create_2_1.models import CREATE_1, ENCODER_MODULUS, RobotModel

# OI modes, values as in sensor packet 35.
OFF, PASSIVE, SAFE, FULL = 0, 1, 2, 3
MODE_NAMES = ("off", "passive", "safe", "full")

MAX_RADIUS_MM = protocol.MAX_RADIUS_MM          # Drive radius range of the spec
RADIUS_STRAIGHT = (protocol.STRAIGHT_RADIUS - 0x10000, 0x7FFF)  # 0x8000 read as int16
RADIUS_SPIN_CW = protocol.SPIN_CW_RADIUS
RADIUS_SPIN_CCW = protocol.SPIN_CCW_RADIUS
ROBOT_RADIUS_MM = 165.0          # Create body: 330 mm diameter (safe-mode cliff rule)
SONG_TICK_S = 1.0 / 64.0         # note durations are in 1/64 s
DEMO_ABORT = -1                  # Demo data byte 255
DEMO_COVER, DEMO_COVER_AND_DOCK, DEMO_SPOT_COVER = 0, 1, 2
BAUD_CODE_MAX = 11

# Sensor signal level (0..4095) reported for a simulated wall.
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

EPS = 1e-9
STASIS_MIN_SPEED_M_S = 0.01      # the stasis wheel toggles above this forward speed [m/s]
BAUD_CODES = {57600: 10, 115200: 11}

LedState = namedtuple("LedState", "play advance power_color power_intensity")
"""LEDs as last set by the LEDs command (play/advance bools, power color/intensity 0..255)."""


def clamp(value: float, low: float, high: float) -> float:
    return low if value < low else high if value > high else value


class Battery:
    """Charge bookkeeping of the Create's battery pack (SI-ish: mAh, mA, mV, degC)."""

    def __init__(self, capacity_mah: float, charge_mah: Optional[float] = None):
        if capacity_mah <= 0:
            raise ValueError("battery capacity must be > 0 mAh, got %r" % capacity_mah)
        self.capacity_mah = float(capacity_mah)
        self.charge_mah = float(capacity_mah if charge_mah is None else charge_mah)
        self.charge_mah = clamp(self.charge_mah, 0.0, self.capacity_mah)
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
        self.charge_mah = clamp(self.charge_mah, 0.0, self.capacity_mah)


class CreateState:
    """What the emulated Create is and does, without the Open Interface's bytes.

    Not thread-safe: call it from one thread (or hold a lock).
    """

    def __init__(self, wheel_base_m: Optional[float] = None,
                 battery_capacity_mah: float = 2700.0,
                 initial_charge_mah: Optional[float] = None, max_wheel_speed_mm_s: float = 500,
                 robot: RobotModel = CREATE_1):
        wheel_base_m = robot.wheel_base_m if wheel_base_m is None else wheel_base_m
        if wheel_base_m <= 0 or max_wheel_speed_mm_s <= 0:
            raise ValueError("wheel_base_m and max_wheel_speed_mm_s must be > 0")
        self.robot = robot
        self.wheel_base_m = float(wheel_base_m)
        self.max_wheel_speed_mm_s = float(max_wheel_speed_mm_s)
        self.battery = Battery(battery_capacity_mah, initial_charge_mah)
        self.time_s = 0.0

        self._mode = OFF
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
        # Create 2: wheel turning in encoder counts (floats; packets 43/44 floor them),
        # light bump signals 46..51, stasis; set_stuck holds the body while wheels turn.
        self._counts_per_m = (1.0 / robot.metres_per_count if robot.encoder_odometry
                              else 0.0)
        self._counts = [0.0, 0.0]
        self.light_bump_signals = [0] * 6
        self.stasis_toggling = False
        self.stuck = False

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
        self.baud_code = BAUD_CODES[robot.baud]  # the model's default baud
        self.low_side_drivers = 0
        self.pwm_low_side = (0, 0, 0)          # duty cycles of drivers 2, 1, 0 (0..128)
        self.digital_outputs = 0
        self.sent_ir: List[int] = []
        self.script = b""
        self.stream_ids: List[int] = []        # packets the host asked to stream (38)

        self.safety_trips = 0

    # ------------------------------------------------------------------ state
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

    # Sensor setters (simulator/test side). Each re-checks safe-mode safety (and, in the
    # emulator, wait events) through _sensors_changed.
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
        self.ir_byte = int(clamp(int(value), 0, 255))
        self._sensors_changed()

    def set_buttons(self, play: bool, advance: bool) -> None:
        self.button_play, self.button_advance = bool(play), bool(advance)
        self._sensors_changed()

    def set_charging_sources(self, home_base: bool, internal: bool = False) -> None:
        self.home_base, self.internal_charger = bool(home_base), bool(internal)
        self._sensors_changed()

    def set_cargo_inputs(self, digital_bits: int = 0, analog: int = 0) -> None:
        self.cargo_digital_inputs = int(digital_bits) & 0x1F
        self.cargo_analog_input = int(clamp(int(analog), 0, 1023))
        self._sensors_changed()

    def set_light_bumps(self, signals) -> None:
        """Create 2: the six light bump signals (left .. right, 0..4095)."""
        if len(signals) != 6:
            raise ValueError("six light bump signals needed, got %d" % len(signals))
        self.light_bump_signals = [int(clamp(int(v), 0, 4095)) for v in signals]
        self._sensors_changed()

    def set_stuck(self, stuck: bool) -> None:
        """Hold the body still while the wheels keep turning (stasis test)."""
        self.stuck = bool(stuck)

    @property
    def encoder_counts(self) -> Tuple[int, int]:
        """Packets 43/44: whole counts of each wheel, rolled over into a signed int16."""
        def wrap(c: float) -> int:
            n = math.floor(c) % ENCODER_MODULUS
            return n - ENCODER_MODULUS if n >= ENCODER_MODULUS // 2 else n
        return wrap(self._counts[0]), wrap(self._counts[1])

    def set_encoder_counts(self, left: float, right: float) -> None:
        """Place the encoder counters (e.g. just below the rollover, for tests)."""
        self._counts = [float(left), float(right)]

    @property
    def wheel_motor_currents_ma(self) -> Tuple[float, float]:
        """Packets 54/55: the battery model's per-wheel motor current, signed like the
        wheel's commanded speed [mA]."""
        left, right = self.wheel_speed_cmd_mps
        return MOTOR_CURRENT_MA_PER_MPS * left, MOTOR_CURRENT_MA_PER_MPS * right

    def _sensors_changed(self) -> None:
        self._check_safety()

    # ------------------------------------------------------------------ actions
    def enter_passive(self) -> None:
        self._mode = PASSIVE
        self._stop_motors()

    def enter_safe(self) -> None:
        self._mode = SAFE
        self.demo_running = False
        self.docking_requested = False

    def enter_full(self) -> None:
        self._mode = FULL
        self.demo_running = False
        self.docking_requested = False

    def power_off(self) -> None:
        """OI back in off mode, motors, song and demo stopped (see VirtualCreate.power_cycle)."""
        self._mode = OFF
        self._stop_motors()
        self.stream_ids = []
        self.song_playing = False
        self._song_time_left_s = 0.0
        self.demo_running = False
        self.docking_requested = False

    def set_baud(self, code: int) -> None:
        if code <= BAUD_CODE_MAX:
            self.baud_code = code

    def start_demo(self, number: int) -> None:
        self.enter_passive()
        self.last_demo = number
        self.demo_running = number != DEMO_ABORT
        self.docking_requested = number == DEMO_COVER_AND_DOCK

    def drive(self, velocity_mm_s: int, radius_mm: int) -> None:
        """Drive: `velocity_mm_s` along an arc of `radius_mm` (or a special radius)."""
        velocity = int(clamp(velocity_mm_s, -self.max_wheel_speed_mm_s,
                             self.max_wheel_speed_mm_s))
        self.requested_velocity_mm_s = velocity
        self.requested_radius_mm = radius_mm
        self._set_wheels(*self.drive_wheel_speeds(velocity, radius_mm))

    def drive_wheel_speeds(self, velocity: float, radius: int) -> Tuple[float, float]:
        """(left, right) [mm/s] for a Drive command: arc of `radius` [mm], + = left turn."""
        if radius in RADIUS_STRAIGHT or radius == 0:
            return velocity, velocity
        if radius == RADIUS_SPIN_CW:
            return velocity, -velocity
        if radius == RADIUS_SPIN_CCW:
            return -velocity, velocity
        r = clamp(radius, -MAX_RADIUS_MM, MAX_RADIUS_MM)
        half = self.wheel_base_m * 1000.0 / 2.0
        left = velocity * (r - half) / r
        right = velocity * (r + half) / r
        peak = max(abs(left), abs(right))
        if peak > self.max_wheel_speed_mm_s:   # keep the radius, slow both wheels
            scale = self.max_wheel_speed_mm_s / peak
            left, right = left * scale, right * scale
        return left, right

    def drive_direct(self, left_mm_s: int, right_mm_s: int) -> None:
        """Drive Direct: each wheel's velocity [mm/s], clamped to the maximum speed."""
        vmax = self.max_wheel_speed_mm_s
        right = int(clamp(right_mm_s, -vmax, vmax))
        left = int(clamp(left_mm_s, -vmax, vmax))
        self.requested_right_mm_s = right
        self.requested_left_mm_s = left
        self._set_wheels(left, right)

    def _set_wheels(self, left_mm_s: float, right_mm_s: float) -> None:
        if self.battery.empty:
            left_mm_s = right_mm_s = 0.0
        self._left_mm_s, self._right_mm_s = float(left_mm_s), float(right_mm_s)

    def _stop_motors(self) -> None:
        self._left_mm_s = self._right_mm_s = 0.0

    def set_low_side_drivers(self, bits: int) -> None:
        self.low_side_drivers = bits & 0x07

    def set_pwm_low_side(self, duty: Tuple[int, ...]) -> None:
        self.pwm_low_side = tuple(min(b, 128) for b in duty[:3])

    def set_digital_outputs(self, bits: int) -> None:
        self.digital_outputs = bits & 0x07

    def set_leds(self, bits: int, color: int, intensity: int) -> None:
        self.leds = LedState(bool(bits & 0x02), bool(bits & 0x08), color, intensity)

    def define_song(self, number: int, notes: List[Tuple[int, int]]) -> None:
        """Store song `number`: (MIDI note, duration [1/64 s]) pairs."""
        self.songs[number] = notes

    def play_song(self, number: int) -> None:
        if self.song_playing or number not in self.songs:
            return                               # the spec: no effect while a song plays
        self.song_number = number
        self.song_playing = True
        self.songs_played.append(number)
        self._song_time_left_s = sum(d for _n, d in self.songs[number]) * SONG_TICK_S

    def send_ir(self, byte: int) -> None:
        self.sent_ir.append(byte)

    # ------------------------------------------------------------------ odometry reads
    def read_distance(self) -> int:
        """Packet 19: whole mm travelled since the last read (the remainder is carried)."""
        whole = math.trunc(self._distance_acc_mm)
        self._distance_acc_mm -= whole             # carry the sub-millimetre remainder
        return whole

    def read_angle(self) -> int:
        """Packet 20: whole degrees turned since the last read (the remainder is carried)."""
        whole = math.trunc(self._angle_acc_deg)
        self._angle_acc_deg -= whole               # carry the sub-degree remainder
        return whole

    def reset_distance(self) -> None:
        self._distance_acc_mm = 0.0

    def reset_angle(self) -> None:
        self._angle_acc_deg = 0.0

    # ------------------------------------------------------------------ physics
    def advance_physics(self, h: float, travel: Optional[Tuple[float, float]]
                        ) -> Tuple[float, float]:
        """Move the robot, battery and song forward by h [s]; travel (left, right) [m] or
        None for the commanded speeds. Returns (distance [mm], angle [deg]) of the step."""
        self._check_safety()
        left_mps, right_mps = self.wheel_speed_cmd_mps
        if travel is None:
            travel = (left_mps * h, right_mps * h)
        self._counts[0] += travel[0] * self._counts_per_m
        self._counts[1] += travel[1] * self._counts_per_m
        if self.stuck:
            travel = (0.0, 0.0)
        moved = self._integrate(travel[0], travel[1], h)
        self.stasis_toggling = self.body_velocity[0] > STASIS_MIN_SPEED_M_S
        self.battery.update(h, left_mps, right_mps, self.charger_present())
        if self.battery.empty:
            self._stop_motors()
        if self.song_playing:
            self._song_time_left_s -= h
            if self._song_time_left_s <= EPS:
                self.song_playing = False
        self.time_s += h
        return moved

    def _integrate(self, dl: float, dr: float, h: float) -> Tuple[float, float]:
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
        self.body_velocity = (ds / h, dtheta / h) if h > 0 else (0.0, 0.0)
        return ds * 1000.0, math.degrees(dtheta)

    # ------------------------------------------------------------------ safety
    def charger_present(self) -> bool:
        return self.home_base or self.internal_charger

    def cliff_any(self) -> bool:
        return (self.cliff_left or self.cliff_front_left or self.cliff_front_right
                or self.cliff_right)

    def wheel_drop_any(self) -> bool:
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
        if (self.wheel_drop_any() or self.charger_present()
                or (self.cliff_any() and self._unsafe_motion_near_cliff())):
            self.enter_passive()
            self.safety_trips += 1
