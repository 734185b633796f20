"""Open Interface conformance test of protocol.py, written from the iRobot Create OI
Specification only (the virtual Create's black-box conformance tests, written the same
way, are section 2 of test_virtual_create.py).

Every expected byte below was worked out by hand from the first-generation "iRobot Create
Open Interface (OI) Specification" (2006), not from `protocol.py` or `virtual_create.py`;
each test names the spec section its vectors come from ("Spec: <section>").  Multi-byte
values are big-endian ("high byte first"), signed ones two's complement (spec: Drive,
Sensor Packets).  A failure here is a deviation from the spec, not a test to relax.

No ROS master needed: run with `python -m pytest -q ascc_ros_pkg/irobot_create_2_1/test`.
"""

import math
import random
from typing import Dict, List

import pytest

from irobot_create_2_1 import protocol

# Spec: Sensor Packets (pp. 17-21) and the Sensor Packets Quick Reference (p. 24):
# packet id -> (data bytes, signed).
TWO_BYTE = {19, 20, 22, 23, 25, 26, 27, 28, 29, 30, 31, 33, 39, 40, 41, 42}
SIGNED = {19, 20, 23, 24, 39, 40, 41, 42}
SPEC_PACKETS = {p: (2 if p in TWO_BYTE else 1, p in SIGNED) for p in range(7, 43)}
# Spec: Sensor Packets, group table: group id -> (size in bytes, first id, last id).
SPEC_GROUPS = {0: (26, 7, 26), 1: (10, 7, 16), 2: (6, 17, 20), 3: (10, 21, 26),
               4: (14, 27, 34), 5: (12, 35, 42), 6: (52, 7, 42)}

# Spec: Bumps and Wheel Drops (packet 7), bit layout.
BUMP_RIGHT, BUMP_LEFT, DROP_RIGHT, DROP_LEFT, DROP_CASTER = 0x01, 0x02, 0x04, 0x08, 0x10


# --------------------------------------------------------------------------------------
# 1. Encoders vs spec bytes
# --------------------------------------------------------------------------------------

def test_opcodes_match_the_commands_quick_reference():
    # Spec: Commands Quick Reference (p. 22).
    expected = {"START": 128, "BAUD": 129, "CONTROL": 130, "SAFE": 131, "FULL": 132,
                "SPOT": 134, "COVER": 135, "DEMO": 136, "DRIVE": 137,
                "LOW_SIDE_DRIVERS": 138, "LEDS": 139, "SONG": 140, "PLAY": 141,
                "SENSORS": 142, "COVER_AND_DOCK": 143, "PWM_LOW_SIDE_DRIVERS": 144,
                "DRIVE_DIRECT": 145, "DIGITAL_OUTPUTS": 147, "STREAM": 148,
                "QUERY_LIST": 149, "PAUSE_RESUME_STREAM": 150, "SEND_IR": 151,
                "SCRIPT": 152, "PLAY_SCRIPT": 153, "SHOW_SCRIPT": 154, "WAIT_TIME": 155,
                "WAIT_DISTANCE": 156, "WAIT_ANGLE": 157, "WAIT_EVENT": 158}
    assert {name: getattr(protocol, name) for name in expected} == expected
    # Spec: Stream, "[19][N-bytes]..." header; Drive, special case "Straight = hex 8000".
    assert protocol.STREAM_HEADER == 19
    assert protocol.STRAIGHT_RADIUS == 0x8000


def test_fixed_data_byte_counts():
    # Spec: "Data Bytes: n" box of each command (pp. 7-16); variable-length ones absent.
    spec = {128: 0, 129: 1, 130: 0, 131: 0, 132: 0, 134: 0, 135: 0, 136: 1, 137: 4,
            138: 1, 139: 3, 141: 1, 142: 1, 143: 0, 144: 3, 145: 4, 147: 1, 150: 1,
            151: 1, 153: 0, 154: 0, 155: 1, 156: 2, 157: 2, 158: 1}
    table = protocol.FIXED_ARG_BYTES
    for must in (128, 131, 132, 136, 137, 139, 141, 142, 143, 145, 150):
        assert must in table, "opcode %d missing from FIXED_ARG_BYTES" % must
    for op, n in table.items():
        if op in spec:
            assert n == spec[op], "opcode %d: %d data bytes, spec says %d" % (op, n, spec[op])
    for variable in (140, 148, 149, 152):  # Song, Stream, Query List, Script
        assert variable not in table


COMMANDS = [  # (encoder, arguments, bytes the spec prescribes)
    ("start", (), [128]),                               # Spec: Start
    ("safe", (), [131]), ("full", (), [132]),           # Spec: Mode Commands, Safe / Full
    ("demo", (1,), [136, 1]), ("demo", (9,), [136, 9]),  # Spec: Demo [136][Which-demo]
    ("demo", (-1,), [136, 255]),                        # Spec: Demo, "-1 (255) Abort"
    ("cover_and_dock", (), [143]),                      # Spec: Cover and Dock
    ("play", (3,), [141, 3]),                           # Spec: Play Song [141][Song Number]
    ("sensors", (7,), [142, 7]), ("sensors", (0,), [142, 0]),  # Spec: Sensors [142][id]
    ("sensors", (42,), [142, 42]),
    ("stream", ([29, 13],), [148, 2, 29, 13]),          # Spec: Stream, the spec's example
    ("stream", ([7, 19],), [148, 2, 7, 19]),
    ("query_list", ([7, 19, 35],), [149, 3, 7, 19, 35]),  # Spec: Query List [149][n][ids]
    ("pause_resume_stream", (False,), [150, 0]),        # Spec: Pause/Resume Stream [150][0|1]
    ("pause_resume_stream", (True,), [150, 1]),
    # Spec: Drive, Example: -200 mm/s, radius 500 mm -> [137] [255] [56] [1] [244].
    ("drive", (-200, 500), [137, 255, 56, 1, 244]),
    # Spec: Drive, special case "Straight = 32768 = hex 8000".
    ("drive", (100, 0x8000), [137, 0, 100, 0x80, 0x00]),
    ("drive", (-100, 0x8000), [137, 0xFF, 0x9C, 0x80, 0x00]),
    # Spec: Drive, "Turn in place clockwise = hex FFFF" (-1), counter-clockwise = hex 0001.
    ("drive", (100, -1), [137, 0, 100, 0xFF, 0xFF]),
    ("drive", (100, 1), [137, 0, 100, 0x00, 0x01]),
    # Spec: Drive, limits: velocity -500..500 mm/s, radius -2000..2000 mm.
    ("drive", (500, -2000), [137, 0x01, 0xF4, 0xF8, 0x30]),
    ("drive", (-500, 2000), [137, 0xFE, 0x0C, 0x07, 0xD0]),
    ("drive", (0, 0), [137, 0, 0, 0, 0]),
    # Spec: Drive Direct, [145][Right hi][Right lo][Left hi][Left lo]; args are (left, right).
    ("drive_direct", (200, -200), [145, 0xFF, 0x38, 0x00, 0xC8]),
    ("drive_direct", (-500, 500), [145, 0x01, 0xF4, 0xFE, 0x0C]),
    ("drive_direct", (100, 300), [145, 0x01, 0x2C, 0x00, 0x64]),
    # Spec: LEDs, Example: Advance on, Power LED green at half intensity -> [139][8][0][128];
    # LED bits: Advance = bit 3, Play = bit 1; colour 0 green .. 255 red.  Args (play,
    # advance, colour, intensity).
    ("leds", (False, True, 0, 128), [139, 8, 0, 128]),
    ("leds", (True, False, 255, 255), [139, 2, 255, 255]),
    ("leds", (True, True, 128, 0), [139, 10, 128, 0]),
    # Spec: Song, [140][Song Number][Song Length][Note 1][Duration 1]... (1/64 s units).
    ("song", (0, [62, 66, 69, 74], [12, 12, 12, 36]), [140, 0, 4, 62, 12, 66, 12, 69, 12, 74, 36]),
    ("song", (15, [127], [255]), [140, 15, 1, 127, 255]),
    ("song", (2, [31] * 16, [8] * 16), [140, 2, 16] + [31, 8] * 16),  # 16 notes: the maximum
]


@pytest.mark.parametrize("name, args, expected", COMMANDS,
                         ids=["%s%r" % (n, a) for n, a, _ in COMMANDS])
def test_command_bytes(name, args, expected):
    assert getattr(protocol, name)(*args) == bytes(expected)


def test_drive_radius_7fff_is_straight_too():
    # Spec: Drive, "Straight = 32768 or 32767 = hex 8000 or 7FFF": 32767 is accepted and
    # sent as one of the two straight codes.
    assert protocol.drive(250, 32767)[3:] in (b"\x7f\xff", b"\x80\x00")


REFUSED = [
    # Spec: Drive, velocity -500..500 mm/s, radius -2000..2000 mm (bar the specials).
    ("drive", (501, 0)), ("drive", (-501, 0)), ("drive", (100, 2001)), ("drive", (100, -2001)),
    # Spec: Drive Direct, each wheel -500..500 mm/s.
    ("drive_direct", (501, 0)), ("drive_direct", (0, -501)),
    # Spec: Song, Song Number 0-15, Song Length 1-16, Note Number 31-127, Duration 0-255.
    ("song", (0, [60] * 17, [16] * 17)), ("song", (0, [], [])), ("song", (0, [128], [16])),
    ("song", (0, [60], [256])), ("song", (16, [60], [16])),
    ("play", (16,)),                                    # Spec: Play Song, Song Number 0-15
    # Spec: Sensors / Stream / Query List, Packet ID 0-42.
    ("sensors", (43,)), ("sensors", (100,)), ("stream", ([7, 43],)), ("query_list", ([100],)),
    # Spec: LEDs, Power LED Color and Intensity 0-255.
    ("leds", (False, False, 256, 0)), ("leds", (False, False, 0, -1)),
    ("demo", (10,)),  # Spec: Demo, "Which-demo (-1 - 9)": demos 0-9 exist, -1 aborts
]


@pytest.mark.parametrize("name, args", REFUSED, ids=["%s%r" % (n, a) for n, a in REFUSED])
def test_out_of_range_arguments_are_refused(name, args):
    with pytest.raises(ValueError):
        getattr(protocol, name)(*args)


# --------------------------------------------------------------------------------------
# 2. Decoders vs spec
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("pid", sorted(SPEC_PACKETS))
def test_every_packet_size_signedness_and_limits(pid):
    # Spec: Sensor Packets, "Data Bytes: n, signed/unsigned"; 2-byte values high byte
    # first, signed ones two's complement.
    size, signed = SPEC_PACKETS[pid]
    spec = protocol.PACKETS[pid]
    assert (spec.id, spec.size, bool(spec.signed)) == (pid, size, signed)
    assert (protocol.packet_size(pid), list(protocol.expand(pid))) == (size, [pid])
    if size == 1:
        vectors = {b"\x00": 0, b"\x7f": 127,
                   b"\x80": -128 if signed else 128, b"\xff": -1 if signed else 255}
    else:
        vectors = {b"\x00\x00": 0, b"\x01\x02": 258, b"\x7f\xff": 32767,
                   b"\x80\x00": -32768 if signed else 32768,
                   b"\xff\xff": -1 if signed else 65535}
    for data, value in vectors.items():
        assert protocol.decode_value(pid, data) == value, (pid, data)


@pytest.mark.parametrize("pid, value, data", [
    (19, -32768, b"\x80\x00"), (19, 32767, b"\x7f\xff"),  # Spec: Distance, -32768..32767
    (19, -200, b"\xff\x38"),                              # Spec: Drive example's -200
    (20, 90, b"\x00\x5a"),                                # Spec: Angle, degrees
    (22, 65535, b"\xff\xff"),                             # Spec: Voltage, 0..65535 mV
    (23, -1500, b"\xfa\x24"),                             # Spec: Current, signed mA
    (24, -128, b"\x80"), (24, 127, b"\x7f"),              # Spec: Battery Temperature
    (7, BUMP_LEFT | DROP_CASTER, b"\x12"),                # Spec: Bumps and Wheel Drops
])
def test_decode_spec_limits(pid, value, data):
    assert protocol.decode_value(pid, data) == value
    assert protocol.encode_value(pid, value) == data


@pytest.mark.parametrize("pid, value", [
    (19, 32768), (19, -32769), (22, -1), (22, 65536), (24, 128), (24, -129),
    (7, 256), (7, -1), (42, 40000),
])
def test_encode_value_refuses_unrepresentable_values(pid, value):
    # Spec: Sensor Packets, each packet's byte count and signedness bound its range.
    with pytest.raises(ValueError):
        protocol.encode_value(pid, value)


@pytest.mark.parametrize("gid", sorted(SPEC_GROUPS))
def test_group_sizes_and_members(gid):
    # Spec: Sensor Packets, group table (0: 26 bytes = 7-26, ..., 6: 52 bytes = 7-42).
    size, first, last = SPEC_GROUPS[gid]
    members = tuple(range(first, last + 1))
    assert tuple(protocol.GROUPS[gid]) == members
    assert tuple(protocol.expand(gid)) == members
    assert protocol.packet_size(gid) == size
    assert sum(SPEC_PACKETS[p][0] for p in members) == size  # the vectors agree with the spec


# A hand-assembled group-6 payload (Spec: Sensor Packets, packets 7-42 in id order), and the
# value of every field.  Offsets: group 1 = [0:10], 2 = [10:16], 3 = [16:26], 0 = [0:26],
# 4 = [26:40], 5 = [40:52].
GROUP6_PAYLOAD = bytes([
    0x1A,                          # 7 bump left + wheel drop left + caster (bits 1, 3, 4)
    0x01, 0x00, 0x01, 0x00, 0x01,  # 8 wall, 9-12 cliff left, front left, front right, right
    0x01, 0x18, 0x00, 0x00,        # 13 virtual wall, 14 both wheel overcurrents, 15-16 unused
    0xFF, 0x04,                    # 17 IR byte 255 (none), 18 buttons: Advance (bit 2)
    0xFF, 0x38, 0x00, 0x5A,        # 19 distance -200 mm, 20 angle +90 deg
    0x02, 0x3E, 0x80, 0xFA, 0x24,  # 21 full charging, 22 16000 mV, 23 -1500 mA
    0xFB, 0x0A, 0x28, 0x0A, 0x8C,  # 24 -5 C, 25 charge 2600 mAh, 26 capacity 2700 mAh
    0x0F, 0xFF, 0x00, 0x01,        # 27 wall signal 4095, 28 cliff left signal 1
    0x02, 0x25, 0x01, 0x00, 0x0F, 0xFE,  # 29-31 cliff signals 549, 256, 4094
    0x1F, 0x03, 0xFF, 0x03,        # 32 cargo digital 31, 33 analog 1023, 34 both chargers
    0x02, 0x0F, 0x01, 0x2B,        # 35 safe, 36 song 15, 37 playing, 38 43 stream packets
    0xFE, 0x0C, 0x80, 0x00,        # 39 requested velocity -500, 40 radius -32768
    0x01, 0xF4, 0xFF, 0xFF,        # 41 requested right 500, 42 requested left -1
])
GROUP6_VALUES = {
    7: 26, 8: 1, 9: 0, 10: 1, 11: 0, 12: 1, 13: 1, 14: 24, 15: 0, 16: 0, 17: 255, 18: 4,
    19: -200, 20: 90, 21: 2, 22: 16000, 23: -1500, 24: -5, 25: 2600, 26: 2700, 27: 4095,
    28: 1, 29: 549, 30: 256, 31: 4094, 32: 31, 33: 1023, 34: 3, 35: 2, 36: 15, 37: 1,
    38: 43, 39: -500, 40: -32768, 41: 500, 42: -1,
}
GROUP_SLICES = {0: (0, 26), 1: (0, 10), 2: (10, 16), 3: (16, 26), 4: (26, 40),
                5: (40, 52), 6: (0, 52)}


@pytest.mark.parametrize("gid", sorted(GROUP_SLICES))
def test_decode_packets_of_hand_assembled_groups(gid):
    assert len(GROUP6_PAYLOAD) == 52
    lo, hi = GROUP_SLICES[gid]
    first, last = SPEC_GROUPS[gid][1:]
    expected = {p: GROUP6_VALUES[p] for p in range(first, last + 1)}
    decoded = protocol.decode_packets([gid], GROUP6_PAYLOAD[lo:hi])
    assert decoded == expected
    assert list(decoded) == list(range(first, last + 1))  # in spec order


def test_decode_packets_query_list_order():
    # Spec: Query List, "The robot returns the packets in the order you specify", data only.
    decoded = protocol.decode_packets([19, 7, 35], b"\xff\x38\x1a\x03")
    assert decoded == {19: -200, 7: 26, 35: 3}
    assert list(decoded) == [19, 7, 35]


# --------------------------------------------------------------------------------------
# 3. Stream framing vs spec
# --------------------------------------------------------------------------------------
# Spec: Stream, format [19][N-bytes][id 1][data 1...][id 2][data 2...][Checksum]; N-bytes
# counts the bytes between itself and the checksum; the low byte of the sum of all the
# bytes, header and checksum included, is 0.

# The spec's own example ([148][2][29][13]): cliff left signal 549 = 0x0225, no virtual
# wall.  (The printed example mixes hex and decimal bytes, so the frame is recomputed here:
# 19+5+29+2+37+13+0 = 105, 256 - 105 = 151.)
SPEC_FRAME = bytes([19, 5, 29, 2, 37, 13, 0, 151])
SPEC_FRAME_VALUES = {29: 549, 13: 0}
# Bumps (7) = bump left, distance (19) = -200 mm; 19+5+7+2+19+255+56 = 363, 512-363 = 149.
# Its body holds a 19 (the distance id) followed by 255: a trap for naive resync.
FRAME = bytes([19, 5, 7, 2, 19, 0xFF, 0x38, 149])
FRAME_VALUES = {7: 2, 19: -200}
# A requested group inside a stream: id 2 then its 6 bytes (17 IR 255, 18 Play, 19 +100,
# 20 -90); N-bytes = 7; sum without checksum 805 -> 1024 - 805 = 219.
GROUP_FRAME = bytes([19, 7, 2, 255, 1, 0x00, 0x64, 0xFF, 0xA6, 219])
GROUP_FRAME_VALUES = {17: 255, 18: 1, 19: 100, 20: -90}


def test_checksum_ok():
    for frame in (SPEC_FRAME, FRAME, GROUP_FRAME):  # the hand-made vectors themselves
        assert sum(frame) % 256 == 0 and frame[1] == len(frame) - 3
    assert protocol.checksum_ok(SPEC_FRAME)
    assert protocol.checksum_ok(FRAME)
    assert not protocol.checksum_ok(FRAME[:-1] + bytes([150]))
    assert not protocol.checksum_ok(bytes([19, 5, 7, 2, 19, 0xFF, 0x39, 149]))


def test_frame_stream_builds_the_spec_format():
    assert protocol.frame_stream([(7, BUMP_LEFT), (19, -200)]) == FRAME
    assert protocol.frame_stream([(29, 549), (13, 0)]) == SPEC_FRAME


@pytest.mark.parametrize("frame, values", [
    (SPEC_FRAME, SPEC_FRAME_VALUES), (FRAME, FRAME_VALUES), (GROUP_FRAME, GROUP_FRAME_VALUES)])
def test_parser_decodes_hand_assembled_frames(frame, values):
    parser = protocol.StreamParser()
    assert parser.feed(frame) == [values]
    assert (parser.frames_ok, parser.bad_checksum) == (1, 0)


def test_parser_rejects_and_counts_a_wrong_checksum():
    parser = protocol.StreamParser()
    bad = SPEC_FRAME[:-1] + bytes([152])  # no other 19 inside: the next frame is unambiguous
    assert parser.feed(bad) == []
    assert parser.feed(FRAME) == [FRAME_VALUES]
    assert (parser.frames_ok, parser.bad_checksum) == (1, 1)


def _garbage_without_valid_false_frames(rng: random.Random, n: int) -> bytes:
    """Random bytes holding several 19s, each heading a false frame that ends inside the
    garbage and fails the checksum, so the true frames that follow are unambiguous."""
    while True:
        g = bytearray(rng.randrange(256) for _ in range(n))
        for pos in rng.sample(range(n - 4), 3):
            g[pos] = 19
        for i in range(n):  # pass 1: no header without room, every false frame closed
            if g[i] == 19:
                if i + 3 > n:
                    g[i] = 0x55
                else:
                    g[i + 1] = min(g[i + 1], n - i - 3)
        heads = [i for i in range(n) if g[i] == 19]
        # pass 2: no false frame may pass the checksum
        if heads and all(sum(g[i:i + g[i + 1] + 3]) % 256 for i in heads):
            return bytes(g)


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
def test_parser_resynchronises_after_garbage(seed):
    rng = random.Random(seed)
    garbage = _garbage_without_valid_false_frames(rng, 40 + 10 * seed)
    data = garbage + FRAME * 5 + SPEC_FRAME
    parser = protocol.StreamParser()
    out: List[Dict[int, int]] = []
    pos = 0
    while pos < len(data):  # random chunking, as a serial port delivers it
        step = rng.randint(1, 12)
        out += parser.feed(data[pos:pos + step])
        pos += step
    assert out == [FRAME_VALUES] * 5 + [SPEC_FRAME_VALUES]
    assert parser.frames_ok == 6
    assert parser.bad_checksum >= 1 and parser.dropped_bytes >= 1


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_parser_recovers_from_unconstrained_garbage(seed):
    # Garbage may hold a 19 followed by any N-bytes (up to 255): the spec bounds N only by
    # its byte, so a parser may wait up to 2 + 255 + 1 bytes before it can reject a false
    # header; frames in that window may be lost, later ones must all be found.
    rng = random.Random(seed)
    garbage = bytearray(rng.randrange(256) for _ in range(64))
    for pos in rng.sample(range(64), 4):
        garbage[pos] = 19
    n_frames = 60
    parser = protocol.StreamParser()
    out = parser.feed(bytes(garbage) + FRAME * n_frames)
    may_lose = math.ceil((2 + 255 + 1) / len(FRAME))
    assert len(out) >= n_frames - may_lose
    assert out[-(n_frames - may_lose):] == [FRAME_VALUES] * (n_frames - may_lose)


def test_parser_handles_every_split_point():
    for frame, values in ((FRAME, FRAME_VALUES), (GROUP_FRAME, GROUP_FRAME_VALUES)):
        for cut in range(1, len(frame)):
            parser = protocol.StreamParser()
            assert parser.feed(frame[:cut]) == []
            assert parser.feed(frame[cut:]) == [values], cut
    parser = protocol.StreamParser()  # byte by byte, two frames back to back
    out = []
    for b in FRAME + SPEC_FRAME:
        out += parser.feed(bytes([b]))
    assert out == [FRAME_VALUES, SPEC_FRAME_VALUES]
