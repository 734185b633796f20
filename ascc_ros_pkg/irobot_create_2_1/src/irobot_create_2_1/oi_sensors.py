"""Sensor packets of the emulated Create: the value of every packet 7..42 (Create 1) or
7..58 (Create 2) read from a :class:`irobot_create_2_1.create_state.CreateState`, the reply
bytes of Sensors/Query List and the frames of the 15 ms stream (pure Python).

Packet sizes, signedness, groups and the frame format come from
:mod:`irobot_create_2_1.protocol`; this module only decides the *values*.

Behaviour choices where the spec is silent or where we deliberately differ:

* Distance (19) and angle (20) are accumulated as floats and reported truncated toward zero;
  the sub-unit remainder is carried to the next read. The real firmware truncates and drops
  the remainder, so a host polling every 15 ms at low speed loses up to 1 mm / 1 deg per read
  (e.g. 100 mm/s at 66 Hz = 1.5 mm per read -> the robot reports 1 mm: a 33 % bias).
  Carrying keeps odometry built from many small reads unbiased, which is what the simulator
  needs; the value of each single read is still an integer, clamped to int16 as the spec says
  (the part beyond the clamp is lost, as on the robot).
* A value outside its packet's range is clamped to it.
* Sensors/Query List with an id the model does not know (Create 1: outside 0..42) sends
  nothing for that id; Stream skips such ids; a stream frame is limited to 255 data bytes
  (N-bytes is one byte), later ids are left out.
* Create 2: encoder counts (43/44) count the wheels' turning (whole counts, the remainder
  carried), rolling over at 16 bits; the light bumper bits (45) are set when a signal
  (46..51) reaches ``LIGHT_BUMP_THRESHOLD`` (the spec gives no threshold); wheel motor
  currents (54/55) follow the battery model's per-wheel current with the wheel's sign;
  the brush motors (56/57) are off; stasis (58) toggles while the body moves forward.
  Packets 15 (dirt), 52/53 (IR left/right) read 0.
"""

from typing import Callable, Dict, FrozenSet, Sequence

from irobot_create_2_1 import protocol
from irobot_create_2_1.create_state import CreateState, clamp

# Sensor signal levels (0..4095) reported for the simulated cliff sensors.
CLIFF_SIGNAL_FLOOR = 1500
CLIFF_SIGNAL_CLIFF = 20
MAX_FRAME_DATA_BYTES = 255
LIGHT_BUMP_THRESHOLD = 100       # light bumper bit set from this signal (0..4095) on


def is_valid_request(pid: int, valid: FrozenSet[int] = protocol.CREATE_1_IDS) -> bool:
    """A packet or group id the model (its id set ``valid``) answers."""
    return pid in valid


def cliff_signal(cliff: bool) -> int:
    return CLIFF_SIGNAL_CLIFF if cliff else CLIFF_SIGNAL_FLOOR


def packet_values(robot: CreateState) -> Dict[int, Callable[[], int]]:
    """Packet id 7..42 -> the robot's current value (reading 19 or 20 resets it)."""
    p, b = protocol, int
    return {
        7: lambda: (p.WHEELDROP_CASTER * b(robot.wheel_drop_caster)
                    | p.WHEELDROP_LEFT * b(robot.wheel_drop_left)
                    | p.WHEELDROP_RIGHT * b(robot.wheel_drop_right)
                    | p.BUMP_LEFT * b(robot.bump_left) | p.BUMP_RIGHT * b(robot.bump_right)),
        8: lambda: b(robot.wall),
        9: lambda: b(robot.cliff_left),
        10: lambda: b(robot.cliff_front_left),
        11: lambda: b(robot.cliff_front_right),
        12: lambda: b(robot.cliff_right),
        13: lambda: b(robot.virtual_wall),
        14: lambda: robot.overcurrent_bits,
        15: lambda: 0,
        16: lambda: 0,
        17: lambda: robot.ir_byte,
        18: lambda: (p.BUTTON_ADVANCE * b(robot.button_advance)
                     | p.BUTTON_PLAY * b(robot.button_play)),
        19: robot.read_distance,
        20: robot.read_angle,
        21: lambda: robot.battery.charging_state,
        22: lambda: round(robot.battery.voltage_mv),
        23: lambda: round(robot.battery.current_ma),
        24: lambda: round(robot.battery.temperature_c),
        25: lambda: round(robot.battery.charge_mah),
        26: lambda: round(robot.battery.capacity_mah),
        27: lambda: robot.wall_signal,
        28: lambda: cliff_signal(robot.cliff_left),
        29: lambda: cliff_signal(robot.cliff_front_left),
        30: lambda: cliff_signal(robot.cliff_front_right),
        31: lambda: cliff_signal(robot.cliff_right),
        32: lambda: robot.cargo_digital_inputs,
        33: lambda: robot.cargo_analog_input,
        34: lambda: (p.SOURCE_HOME_BASE * b(robot.home_base)
                     | p.SOURCE_INTERNAL_CHARGER * b(robot.internal_charger)),
        35: lambda: robot.oi_mode,
        36: lambda: robot.song_number,
        37: lambda: b(robot.song_playing),
        38: lambda: len(robot.stream_ids),
        39: lambda: robot.requested_velocity_mm_s,
        40: lambda: robot.requested_radius_mm,
        41: lambda: robot.requested_right_mm_s,
        42: lambda: robot.requested_left_mm_s,
        # Create 2
        43: lambda: robot.encoder_counts[0],
        44: lambda: robot.encoder_counts[1],
        45: lambda: sum(1 << i for i, s in enumerate(robot.light_bump_signals)
                        if s >= LIGHT_BUMP_THRESHOLD),
        46: lambda: robot.light_bump_signals[0],
        47: lambda: robot.light_bump_signals[1],
        48: lambda: robot.light_bump_signals[2],
        49: lambda: robot.light_bump_signals[3],
        50: lambda: robot.light_bump_signals[4],
        51: lambda: robot.light_bump_signals[5],
        52: lambda: 0,
        53: lambda: 0,
        54: lambda: round(robot.wheel_motor_currents_ma[0]),
        55: lambda: round(robot.wheel_motor_currents_ma[1]),
        56: lambda: 0,
        57: lambda: 0,
        58: lambda: p.STASIS_TOGGLING * b(robot.stasis_toggling),
    }


class SensorEncoder:
    """The bytes the robot sends for sensor requests, read from `robot` when asked."""

    def __init__(self, robot: CreateState, valid: FrozenSet[int] = protocol.CREATE_1_IDS):
        self._values = packet_values(robot)
        self.valid = valid

    def encode_request(self, pid: int) -> bytes:
        """Data bytes of packet or group `pid` (b'' for an unknown id); reads 19/20."""
        if not is_valid_request(pid, self.valid):
            return b""
        return b"".join(self._encode_single(m) for m in protocol.expand(pid, self.valid))

    def _encode_single(self, pid: int) -> bytes:
        low, high = protocol.value_limits(pid)
        value = int(clamp(int(self._values[pid]()), low, high))
        return protocol.encode_value(pid, value)

    def stream_frame(self, stream_ids: Sequence[int]) -> bytes:
        """One stream frame of the valid ids in `stream_ids` that fit in 255 data bytes."""
        body = bytearray()
        for pid in stream_ids:
            if not is_valid_request(pid, self.valid):
                continue
            if len(body) + 1 + protocol.packet_size(pid) > MAX_FRAME_DATA_BYTES:
                break
            body.append(pid)
            body.extend(self.encode_request(pid))
        return protocol.frame_stream_body(bytes(body))
