"""iRobot Create Open Interface: command encoders, sensor packet table, decoders and stream
framing. Pure Python, no ROS: feed it bytes, get values.

The first-generation Create knows packets 7..42 and groups 0..6; the Create 2 (Roomba 600
OI) adds packets 43..58 and groups 100, 101, 106, 107 with the same sizes for 7..42. The
functions that validate ids take ``valid``, the ids a model answers
(:data:`CREATE_1_IDS`, the default, or :data:`CREATE_2_IDS`; :mod:`.models`).

Values here are the Open Interface's raw integers (mm, mm/s, degrees, mV, mA, mAh, degC);
conversion to SI happens at the ROS boundary (``units.py`` / the driver).
All multi-byte values are big-endian; signed ones are two's complement.
"""
import functools
import struct
from collections import namedtuple
from typing import Dict, FrozenSet, Iterable, List, Mapping, Optional, Sequence, Tuple

# --- opcodes (OI spec, "Open Interface Command Reference") -----------------------------
START = 128
BAUD = 129
CONTROL = 130
SAFE = 131
FULL = 132
SPOT = 134
COVER = 135
DEMO = 136
DRIVE = 137
LOW_SIDE_DRIVERS = 138
LEDS = 139
SONG = 140
PLAY = 141
SENSORS = 142
COVER_AND_DOCK = 143
PWM_LOW_SIDE_DRIVERS = 144
DRIVE_DIRECT = 145
DIGITAL_OUTPUTS = 147
STREAM = 148
QUERY_LIST = 149
PAUSE_RESUME_STREAM = 150
SEND_IR = 151
SCRIPT = 152
PLAY_SCRIPT = 153
SHOW_SCRIPT = 154
WAIT_TIME = 155
WAIT_DISTANCE = 156
WAIT_ANGLE = 157
WAIT_EVENT = 158

#: Data bytes that follow each fixed-length opcode. SONG (2 + 2n), STREAM and QUERY_LIST
#: (1 + n) and SCRIPT (1 + n) are variable-length and not listed.
FIXED_ARG_BYTES: Dict[int, int] = {
    START: 0, BAUD: 1, CONTROL: 0, SAFE: 0, FULL: 0, SPOT: 0, COVER: 0, DEMO: 1,
    DRIVE: 4, LOW_SIDE_DRIVERS: 1, LEDS: 3, PLAY: 1, SENSORS: 1, COVER_AND_DOCK: 0,
    PWM_LOW_SIDE_DRIVERS: 3, DRIVE_DIRECT: 4, DIGITAL_OUTPUTS: 1, PAUSE_RESUME_STREAM: 1,
    SEND_IR: 1, PLAY_SCRIPT: 0, SHOW_SCRIPT: 0, WAIT_TIME: 1, WAIT_DISTANCE: 2,
    WAIT_ANGLE: 2, WAIT_EVENT: 1,
}

# Create 2 OI (Roomba 600) opcodes that the Create 1 does not have, and the Create 2's data
# byte counts where they differ: 136 is Max (clean, no data byte), not Demo; 147 and
# 151..158 (digital outputs, send IR, scripts, waits) do not exist on the Create 2.
RESET, POWER, DRIVE_PWM, STOP = 7, 133, 146, 173
MAX, SEEK_DOCK = DEMO, COVER_AND_DOCK          # the Create 2's names of 136 and 143
SCHEDULING_LEDS, DIGIT_LEDS_RAW, DIGIT_LEDS_ASCII, BUTTONS = 162, 163, 164, 165
SCHEDULE, SET_DAY_TIME = 167, 168
CREATE_2_FIXED_ARG_BYTES: Dict[int, int] = {
    **{op: n for op, n in FIXED_ARG_BYTES.items()
       if op not in (DIGITAL_OUTPUTS, SEND_IR, PLAY_SCRIPT, SHOW_SCRIPT, WAIT_TIME,
                     WAIT_DISTANCE, WAIT_ANGLE, WAIT_EVENT)},
    RESET: 0, POWER: 0, MAX: 0, DRIVE_PWM: 4, SCHEDULING_LEDS: 2, DIGIT_LEDS_RAW: 4,
    DIGIT_LEDS_ASCII: 4, BUTTONS: 1, SCHEDULE: 15, SET_DAY_TIME: 3, STOP: 0}

STREAM_HEADER = 19
STRAIGHT_RADIUS = 0x8000  # special radius: drive straight (also 0x7FFF)
SPIN_CW_RADIUS = -1
SPIN_CCW_RADIUS = 1
MAX_WHEEL_SPEED_MM_S = 500
MAX_RADIUS_MM = 2000
MAX_SONG_NOTES = 16
STREAM_PERIOD_S = 0.015  # the Create sends a stream frame every 15 ms

# --- sensor packets 7..58 ----------------------------------------------------------------
PacketSpec = namedtuple("PacketSpec", "id name size signed")

_PACKET_TABLE: Tuple[Tuple[int, str, int, bool], ...] = (
    (7, "bumps_wheeldrops", 1, False),
    (8, "wall", 1, False),
    (9, "cliff_left", 1, False),
    (10, "cliff_front_left", 1, False),
    (11, "cliff_front_right", 1, False),
    (12, "cliff_right", 1, False),
    (13, "virtual_wall", 1, False),
    (14, "overcurrents", 1, False),
    (15, "unused_15", 1, False),
    (16, "unused_16", 1, False),
    (17, "infrared_byte", 1, False),
    (18, "buttons", 1, False),
    (19, "distance", 2, True),
    (20, "angle", 2, True),
    (21, "charging_state", 1, False),
    (22, "voltage", 2, False),
    (23, "current", 2, True),
    (24, "battery_temperature", 1, True),
    (25, "battery_charge", 2, False),
    (26, "battery_capacity", 2, False),
    (27, "wall_signal", 2, False),
    (28, "cliff_left_signal", 2, False),
    (29, "cliff_front_left_signal", 2, False),
    (30, "cliff_front_right_signal", 2, False),
    (31, "cliff_right_signal", 2, False),
    (32, "cargo_bay_digital_inputs", 1, False),
    (33, "cargo_bay_analog_signal", 2, False),
    (34, "charging_sources_available", 1, False),
    (35, "oi_mode", 1, False),
    (36, "song_number", 1, False),
    (37, "song_playing", 1, False),
    (38, "number_of_stream_packets", 1, False),
    (39, "requested_velocity", 2, True),
    (40, "requested_radius", 2, True),
    (41, "requested_right_velocity", 2, True),
    (42, "requested_left_velocity", 2, True),
    # Create 2 only (Create 2 OI spec, packets 43-58). 15 is "dirt detect" and 32/33 are
    # unused on the Create 2; their sizes are the Create 1's.
    (43, "left_encoder_counts", 2, True),
    (44, "right_encoder_counts", 2, True),
    (45, "light_bumper", 1, False),
    (46, "light_bump_left_signal", 2, False),
    (47, "light_bump_front_left_signal", 2, False),
    (48, "light_bump_center_left_signal", 2, False),
    (49, "light_bump_center_right_signal", 2, False),
    (50, "light_bump_front_right_signal", 2, False),
    (51, "light_bump_right_signal", 2, False),
    (52, "ir_opcode_left", 1, False),
    (53, "ir_opcode_right", 1, False),
    (54, "left_motor_current", 2, True),
    (55, "right_motor_current", 2, True),
    (56, "main_brush_motor_current", 2, True),
    (57, "side_brush_motor_current", 2, True),
    (58, "stasis", 1, False),
)
PACKETS: Dict[int, PacketSpec] = {row[0]: PacketSpec(*row) for row in _PACKET_TABLE}
PACKET_IDS: Dict[str, int] = {spec.name: pid for pid, spec in PACKETS.items()}

GROUPS: Dict[int, Tuple[int, ...]] = {
    0: tuple(range(7, 27)),
    1: tuple(range(7, 17)),
    2: tuple(range(17, 21)),
    3: tuple(range(21, 27)),
    4: tuple(range(27, 35)),
    5: tuple(range(35, 43)),
    6: tuple(range(7, 43)),
    # Create 2 only
    100: tuple(range(7, 59)),
    101: tuple(range(43, 59)),
    106: tuple(range(46, 52)),
    107: tuple(range(54, 59)),
}

#: Packet and group ids each model answers.
CREATE_1_IDS = frozenset(range(0, 43))
CREATE_2_IDS = frozenset(range(0, 59)) | frozenset((100, 101, 106, 107))

# Bits of packet 7 (bumps and wheel drops).
BUMP_RIGHT = 0x01
BUMP_LEFT = 0x02
WHEELDROP_RIGHT = 0x04
WHEELDROP_LEFT = 0x08
WHEELDROP_CASTER = 0x10
# Bits of packet 18 (buttons) and 34 (charging sources).
BUTTON_PLAY = 0x01
BUTTON_ADVANCE = 0x04
SOURCE_INTERNAL_CHARGER = 0x01
SOURCE_HOME_BASE = 0x02
# Packet 35: OI mode.
OI_MODES = {0: "off", 1: "passive", 2: "safe", 3: "full"}
# Create 2: bits of packet 45 (light bumper), in the order of the signals 46..51.
LIGHT_BUMPERS = ("left", "front_left", "center_left", "center_right", "front_right", "right")
# Create 2: bits of packet 58 (stasis).
STASIS_TOGGLING = 0x01   # the caster's stasis wheel turns: the robot makes forward progress
STASIS_DISABLED = 0x02   # the stasis sensor cannot tell (e.g. dirty)


def expand(packet_id: int, valid: FrozenSet[int] = CREATE_1_IDS) -> Tuple[int, ...]:
    """Member packet ids of a group id, or ``(packet_id,)`` for a single packet; ``valid``
    is the model's id set (ValueError outside it)."""
    if packet_id in valid:
        if packet_id in GROUPS:
            return GROUPS[packet_id]
        if packet_id in PACKETS:
            return (packet_id,)
    raise ValueError("unknown sensor packet id %r (valid: 0..%d%s)"
                     % (packet_id, max(i for i in valid if i in PACKETS),
                        ", 100, 101, 106, 107" if 100 in valid else ""))


def packet_size(packet_id: int) -> int:
    """Bytes the Create sends for a packet or group id (of either model)."""
    return sum(PACKETS[pid].size for pid in expand(packet_id, CREATE_2_IDS))


def value_limits(packet_id: int) -> Tuple[int, int]:
    """(lowest, highest) value a single sensor packet can carry."""
    spec = PACKETS[packet_id]
    bits = 8 * spec.size
    if spec.signed:
        return -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    return 0, (1 << bits) - 1


def encode_value(packet_id: int, value: int) -> bytes:
    """Wire bytes of one sensor value; ValueError when it does not fit the packet."""
    spec = PACKETS[packet_id]
    lo, hi = value_limits(packet_id)
    value = int(value)
    if not lo <= value <= hi:
        raise ValueError("packet %d (%s) value %d outside %d..%d"
                         % (packet_id, spec.name, value, lo, hi))
    return value.to_bytes(spec.size, "big", signed=spec.signed)


def decode_value(packet_id: int, data: bytes) -> int:
    spec = PACKETS[packet_id]
    if len(data) != spec.size:
        raise ValueError("packet %d (%s) needs %d bytes, got %d"
                         % (packet_id, spec.name, spec.size, len(data)))
    return int.from_bytes(bytes(data), "big", signed=spec.signed)


_STRUCT_CODES = {(1, False): "B", (1, True): "b", (2, False): "H", (2, True): "h"}


@functools.lru_cache(maxsize=64)
def _layout(packet_ids: Tuple[int, ...]) -> Tuple[Tuple[int, ...], struct.Struct]:
    ids = tuple(pid for requested in packet_ids for pid in expand(requested, CREATE_2_IDS))
    fmt = ">" + "".join(_STRUCT_CODES[PACKETS[pid].size, PACKETS[pid].signed] for pid in ids)
    return ids, struct.Struct(fmt)


def decode_packets(packet_ids: Iterable[int], data: bytes) -> Dict[int, int]:
    """Decode the reply to Sensors/Query List: the packets' data back to back, no ids."""
    ids, layout = _layout(tuple(packet_ids))
    if len(data) != layout.size:
        raise ValueError("reply for packets %s needs %d bytes, got %d"
                         % (list(ids), layout.size, len(data)))
    return dict(zip(ids, layout.unpack(bytes(data))))


# --- stream framing -------------------------------------------------------------------
def checksum_ok(frame: bytes) -> bool:
    """A stream frame is valid when all its bytes (header .. checksum) sum to 0 mod 256."""
    return sum(frame) & 0xFF == 0


def frame_stream(items: Sequence[Tuple[int, int]]) -> bytes:
    """Build a stream frame ``[19, n, id1, data1.., id2, data2.., checksum]`` from
    (single packet id, value) pairs."""
    return frame_stream_packets([pid for pid, _ in items], dict(items))


def encode_packets(packet_ids: Iterable[int], values: Mapping[int, int]) -> bytes:
    """Data of the requested packets/groups back to back (a Sensors/Query List reply).
    ValueError when a value does not fit its packet."""
    ids, layout = _layout(tuple(packet_ids))
    try:
        return layout.pack(*[values[pid] for pid in ids])
    except struct.error:
        # find the offending packet for a useful message
        for pid in ids:
            encode_value(pid, values[pid])
        raise


def frame_stream_packets(packet_ids: Sequence[int], values: Mapping[int, int]) -> bytes:
    """A stream frame for the requested ids: each id (a group id too) then its data."""
    body = bytearray()
    for pid in packet_ids:
        body.append(pid)
        body += encode_packets((pid,), values)
    return frame_stream_body(body)


def frame_stream_body(body: bytes) -> bytes:
    """The stream frame ``[19, n, body.., checksum]`` around ``id, data, ...`` bytes."""
    if len(body) > 255:
        raise ValueError("stream frame body of %d bytes exceeds 255" % len(body))
    frame = bytearray((STREAM_HEADER, len(body))) + body
    frame.append((-sum(frame)) & 0xFF)
    return bytes(frame)


def parse_stream_body(body: bytes, valid: FrozenSet[int] = CREATE_1_IDS) -> Dict[int, int]:
    """Decode ``id, data, id, data, ...`` (group ids carry all their members' data).

    ValueError on an id outside ``valid`` or a truncated body.
    """
    out: Dict[int, int] = {}
    pos = 0
    while pos < len(body):
        pid = body[pos]
        if pid not in valid:
            raise ValueError("unknown packet id %d in stream frame" % pid)
        size = packet_size(pid)
        if pos + 1 + size > len(body):
            raise ValueError("stream frame truncated in packet %d" % pid)
        out.update(decode_packets((pid,), body[pos + 1:pos + 1 + size]))
        pos += 1 + size
    return out


class StreamParser:
    """Incremental parser of the Create's stream (opcode 148) output.

    ``feed`` accepts any chunking of the byte stream and returns the frames completed by
    it. A frame with a bad checksum or an undecodable body is dropped and counted, and the
    search for the next header restarts one byte after the bad frame's header.

    ``packet_ids``: the ids requested with Stream (148). When given, a header whose length
    byte does not match that request is rejected at once, so a stray 19 in garbage (or a
    packet id 19 inside a frame) cannot make the parser wait for up to 255 bytes. Such a
    header still counts in ``foreign_lengths`` (length byte -> times) when the bytes that
    follow it make a frame of that length with a good checksum: a robot answering another
    request than ours (another model) shows up there, garbage hardly ever does.
    ``valid``: the packet ids of the model (:data:`CREATE_1_IDS` by default).
    """

    def __init__(self, packet_ids: Optional[Sequence[int]] = None,
                 valid: FrozenSet[int] = CREATE_1_IDS) -> None:
        self._buf = bytearray()
        self.valid = valid
        self.body_len: Optional[int] = None
        if packet_ids is not None:
            for pid in packet_ids:
                expand(pid, valid)  # validates
            self.body_len = sum(1 + packet_size(pid) for pid in packet_ids)
        self.frames_ok = 0
        self.bad_checksum = 0
        self.bad_body = 0
        self.dropped_bytes = 0
        self.foreign_lengths: Dict[int, int] = {}

    def feed(self, data: bytes) -> List[Dict[int, int]]:
        self._buf += data
        frames: List[Dict[int, int]] = []
        buf = self._buf
        while True:
            start = buf.find(STREAM_HEADER)
            if start < 0:
                self.dropped_bytes += len(buf)
                buf.clear()
                break
            if start:
                self.dropped_bytes += start
                del buf[:start]
            if len(buf) < 2:
                break
            if self.body_len is not None and buf[1] != self.body_len:
                if len(buf) < buf[1] + 3 and len(buf) < self.body_len + 3:
                    break  # might still be a frame of another length: wait for it
                if len(buf) >= buf[1] + 3 and checksum_ok(bytes(buf[:buf[1] + 3])):
                    self.foreign_lengths[buf[1]] = self.foreign_lengths.get(buf[1], 0) + 1
                self.bad_body += 1
                self.dropped_bytes += 1
                del buf[:1]
                continue
            total = buf[1] + 3
            if len(buf) < total:
                break
            frame = bytes(buf[:total])
            if not checksum_ok(frame):
                self.bad_checksum += 1
                self.dropped_bytes += 1
                del buf[:1]
                continue
            try:
                values = parse_stream_body(frame[2:-1], self.valid)
            except ValueError:
                self.bad_body += 1
                self.dropped_bytes += 1
                del buf[:1]
                continue
            del buf[:total]
            self.frames_ok += 1
            frames.append(values)
        return frames


# --- command encoders -----------------------------------------------------------------
def _check(name: str, value: int, lo: int, hi: int) -> int:
    value = int(value)
    if not lo <= value <= hi:
        raise ValueError("%s=%d outside %d..%d" % (name, value, lo, hi))
    return value


def _i16(value: int) -> bytes:
    return int(value).to_bytes(2, "big", signed=True)


def start() -> bytes:
    return bytes((START,))


def safe() -> bytes:
    return bytes((SAFE,))


def full() -> bytes:
    return bytes((FULL,))


def demo(number: int) -> bytes:
    """Run built-in demo 0..9; -1 (sent as 255) stops the running demo."""
    number = 255 if number in (-1, 255) else _check("demo", number, 0, 9)
    return bytes((DEMO, number))


def drive(velocity_mm_s: int, radius_mm: int) -> bytes:
    """Drive at ``velocity_mm_s`` along ``radius_mm`` (or a special radius)."""
    v = _check("velocity_mm_s", velocity_mm_s, -MAX_WHEEL_SPEED_MM_S, MAX_WHEEL_SPEED_MM_S)
    r = int(radius_mm)
    if r in (STRAIGHT_RADIUS, 0x7FFF):
        r_bytes = r.to_bytes(2, "big")
    else:
        r_bytes = _i16(_check("radius_mm", r, -MAX_RADIUS_MM, MAX_RADIUS_MM))
    return bytes((DRIVE,)) + _i16(v) + r_bytes


def drive_direct(left_mm_s: int, right_mm_s: int) -> bytes:
    """Per-wheel velocities; on the wire the right wheel comes first."""
    left = _check("left_mm_s", left_mm_s, -MAX_WHEEL_SPEED_MM_S, MAX_WHEEL_SPEED_MM_S)
    right = _check("right_mm_s", right_mm_s, -MAX_WHEEL_SPEED_MM_S, MAX_WHEEL_SPEED_MM_S)
    return bytes((DRIVE_DIRECT,)) + _i16(right) + _i16(left)


def leds(play: bool, advance: bool, color: int, intensity: int) -> bytes:
    bits = (0x02 if play else 0) | (0x08 if advance else 0)
    return bytes((LEDS, bits, _check("color", color, 0, 255),
                  _check("intensity", intensity, 0, 255)))


def song(number: int, notes: Sequence[int], durations: Sequence[int]) -> bytes:
    """Define song ``number`` (0..15): MIDI notes 31..127, durations in 1/64 s."""
    number = _check("song number", number, 0, 15)
    if len(notes) != len(durations):
        raise ValueError("song needs as many durations (%d) as notes (%d)"
                         % (len(durations), len(notes)))
    if not 1 <= len(notes) <= MAX_SONG_NOTES:
        raise ValueError("song needs 1..%d notes, got %d" % (MAX_SONG_NOTES, len(notes)))
    out = bytearray((SONG, number, len(notes)))
    for note, duration in zip(notes, durations):
        out.append(_check("note", note, 31, 127))
        out.append(_check("duration", duration, 0, 255))
    return bytes(out)


def play(number: int) -> bytes:
    return bytes((PLAY, _check("song number", number, 0, 15)))


def _packet_list(opcode: int, packet_ids: Sequence[int], valid: FrozenSet[int]) -> bytes:
    ids = [int(pid) for pid in packet_ids]
    if not ids:
        raise ValueError("need at least one packet id")
    for pid in ids:
        expand(pid, valid)  # validates
    if len(ids) > 255:
        raise ValueError("at most 255 packet ids")
    return bytes((opcode, len(ids))) + bytes(ids)


def sensors(packet_id: int, valid: FrozenSet[int] = CREATE_1_IDS) -> bytes:
    expand(packet_id, valid)
    return bytes((SENSORS, packet_id))


def stream(packet_ids: Sequence[int], valid: FrozenSet[int] = CREATE_1_IDS) -> bytes:
    return _packet_list(STREAM, packet_ids, valid)


def query_list(packet_ids: Sequence[int], valid: FrozenSet[int] = CREATE_1_IDS) -> bytes:
    return _packet_list(QUERY_LIST, packet_ids, valid)


def pause_resume_stream(resume: bool) -> bytes:
    return bytes((PAUSE_RESUME_STREAM, 1 if resume else 0))


def cover_and_dock() -> bytes:
    return bytes((COVER_AND_DOCK,))
