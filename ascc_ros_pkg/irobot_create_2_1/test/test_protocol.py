"""Unit tests of the Open Interface protocol module: every encoder, every packet decoder
with its signed/unsigned limits, groups, checksums and stream resynchronisation."""
import random

import pytest

from irobot_create_2_1 import protocol as oi

# (encoder call, expected bytes) — values worked out by hand from the OI spec.
ENCODINGS = [
    (lambda: oi.start(), [128]),
    (lambda: oi.safe(), [131]),
    (lambda: oi.full(), [132]),
    (lambda: oi.demo(5), [136, 5]),
    (lambda: oi.demo(255), [136, 255]),
    (lambda: oi.demo(-1), [136, 255]),
    (lambda: oi.drive(-200, 500), [137, 0xFF, 0x38, 0x01, 0xF4]),
    (lambda: oi.drive(500, oi.STRAIGHT_RADIUS), [137, 0x01, 0xF4, 0x80, 0x00]),
    (lambda: oi.drive(100, -1), [137, 0x00, 0x64, 0xFF, 0xFF]),
    (lambda: oi.drive(100, 1), [137, 0x00, 0x64, 0x00, 0x01]),
    (lambda: oi.drive(-500, -2000), [137, 0xFE, 0x0C, 0xF8, 0x30]),
    (lambda: oi.drive_direct(100, -100), [145, 0xFF, 0x9C, 0x00, 0x64]),
    (lambda: oi.drive_direct(-500, 500), [145, 0x01, 0xF4, 0xFE, 0x0C]),
    (lambda: oi.leds(True, False, 0, 128), [139, 0x02, 0, 128]),
    (lambda: oi.leds(False, True, 255, 255), [139, 0x08, 255, 255]),
    (lambda: oi.leds(True, True, 10, 0), [139, 0x0A, 10, 0]),
    (lambda: oi.song(0, [60, 62], [32, 16]), [140, 0, 2, 60, 32, 62, 16]),
    (lambda: oi.play(3), [141, 3]),
    (lambda: oi.sensors(6), [142, 6]),
    (lambda: oi.sensors(19), [142, 19]),
    (lambda: oi.stream([6]), [148, 1, 6]),
    (lambda: oi.stream([7, 19, 20]), [148, 3, 7, 19, 20]),
    (lambda: oi.query_list([19, 20]), [149, 2, 19, 20]),
    (lambda: oi.pause_resume_stream(False), [150, 0]),
    (lambda: oi.pause_resume_stream(True), [150, 1]),
    (lambda: oi.cover_and_dock(), [143]),
]


@pytest.mark.parametrize("call,expected", ENCODINGS)
def test_encoders(call, expected):
    assert list(call()) == expected


@pytest.mark.parametrize("call", [
    lambda: oi.drive(501, 0), lambda: oi.drive(0, 2001), lambda: oi.drive(-501, 100),
    lambda: oi.drive_direct(0, 501), lambda: oi.drive_direct(-501, 0),
    lambda: oi.leds(True, True, 256, 0), lambda: oi.leds(True, True, 0, -1),
    lambda: oi.song(16, [60], [8]), lambda: oi.song(0, [30], [8]),
    lambda: oi.song(0, [128], [8]), lambda: oi.song(0, [60] * 17, [8] * 17),
    lambda: oi.song(0, [60, 61], [8]), lambda: oi.song(0, [], []),
    lambda: oi.play(16), lambda: oi.sensors(43), lambda: oi.sensors(100),
    lambda: oi.stream([]), lambda: oi.query_list([7, 99]), lambda: oi.demo(256),
    lambda: oi.demo(10),
])
def test_encoders_refuse_out_of_range(call):
    with pytest.raises(ValueError):
        call()


def test_fixed_arg_bytes_match_encoders():
    for _call, expected in ENCODINGS:
        op = expected[0]
        if op in oi.FIXED_ARG_BYTES:
            assert len(expected) == 1 + oi.FIXED_ARG_BYTES[op], expected


SIGNED_2 = (19, 20, 23, 39, 40, 41, 42)
UNSIGNED_2 = (22, 25, 26, 27, 28, 29, 30, 31, 33)


def test_packet_table_sizes_and_signs():
    # 7..42 of both models (43..58, Create 2 only: test_oi_conformance_create2.py)
    assert sorted(oi.PACKETS) == list(range(7, 59))
    assert sorted(oi.CREATE_1_IDS) == list(range(0, 43))
    for pid, spec in oi.PACKETS.items():
        if pid > 42:
            continue
        assert spec.size == (2 if pid in SIGNED_2 + UNSIGNED_2 else 1), pid
        assert spec.signed == (pid in SIGNED_2 + (24,)), pid


@pytest.mark.parametrize("pid", sorted(oi.PACKETS))
def test_every_packet_decodes_its_limits(pid):
    spec = oi.PACKETS[pid]
    bits = 8 * spec.size
    lo, hi = ((-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if spec.signed
              else (0, (1 << bits) - 1))
    for value in (lo, hi, 0, 1, lo + 1, hi - 1):
        raw = oi.encode_value(pid, value)
        assert len(raw) == spec.size
        assert oi.decode_value(pid, raw) == value
    with pytest.raises(ValueError):
        oi.encode_value(pid, hi + 1)
    with pytest.raises(ValueError):
        oi.encode_value(pid, lo - 1)
    with pytest.raises(ValueError):
        oi.decode_value(pid, bytes(spec.size + 1))


def test_known_raw_values():
    assert oi.decode_value(19, b"\x80\x00") == -32768
    assert oi.decode_value(19, b"\x7f\xff") == 32767
    assert oi.decode_value(20, b"\xff\xff") == -1
    assert oi.decode_value(22, b"\xff\xff") == 65535
    assert oi.decode_value(23, b"\xfc\x18") == -1000
    assert oi.decode_value(24, b"\x80") == -128
    assert oi.decode_value(24, b"\x7f") == 127
    assert oi.decode_value(21, b"\xff") == 255


def test_groups():
    assert [oi.packet_size(g) for g in range(7)] == [26, 10, 6, 10, 14, 12, 52]
    assert oi.GROUPS[6] == tuple(range(7, 43))
    assert oi.expand(3) == (21, 22, 23, 24, 25, 26)
    with pytest.raises(ValueError):
        oi.expand(43)


def test_decode_group_reply():
    rng = random.Random(1)
    values = {}
    for pid, spec in oi.PACKETS.items():
        lo = -(1 << (8 * spec.size - 1)) if spec.signed else 0
        hi = (1 << (8 * spec.size - 1)) - 1 if spec.signed else (1 << (8 * spec.size)) - 1
        values[pid] = rng.randint(lo, hi)
    for group, members in oi.GROUPS.items():
        raw = oi.encode_packets([group], values)
        assert len(raw) == oi.packet_size(group)
        assert oi.decode_packets([group], raw) == {pid: values[pid] for pid in members}
    raw = oi.encode_packets([19, 7, 22], values)
    assert oi.decode_packets([19, 7, 22], raw) == {19: values[19], 7: values[7], 22: values[22]}
    with pytest.raises(ValueError):
        oi.decode_packets([6], raw)


def test_stream_frame_checksum():
    frame = oi.frame_stream([(7, 3), (19, -1)])
    assert list(frame) == [19, 5, 7, 3, 19, 0xFF, 0xFF, (-(19 + 5 + 7 + 3 + 19 + 255 + 255)) & 0xFF]
    assert oi.checksum_ok(frame)
    bad = bytearray(frame)
    bad[3] ^= 0x01
    assert not oi.checksum_ok(bytes(bad))
    parser = oi.StreamParser([7, 19])
    assert parser.feed(bytes(bad)) == []
    assert parser.bad_checksum == 1
    assert parser.feed(frame) == [{7: 3, 19: -1}]


def _full_values(seed):
    rng = random.Random(seed)
    values = {pid: 0 for pid in oi.PACKETS}
    values[19], values[20], values[22] = rng.randint(-300, 300), rng.randint(-30, 30), 15000
    return values


@pytest.mark.parametrize("seed", range(20))
def test_resync_after_random_garbage(seed):
    rng = random.Random(seed)
    values = _full_values(seed)
    frame = oi.frame_stream_packets([6], values)
    garbage = bytes(rng.randrange(256) for _ in range(rng.randint(1, 300)))
    garbage += bytes([19, rng.randrange(256)])  # a false header right before the frame
    # Knowing the requested packets, every frame after the garbage is recovered at once.
    parser = oi.StreamParser([6])
    frames = parser.feed(garbage + frame + frame)
    assert len(frames) == 2
    assert frames[-1][19] == values[19] and frames[-1][20] == values[20]
    assert parser.dropped_bytes >= len(garbage) - 2
    # Without that knowledge a false header may hold back up to 258 bytes (5 frames).
    parser = oi.StreamParser()
    frames = parser.feed(garbage + frame * 6)
    assert frames and frames[-1][19] == values[19]


def test_frames_split_at_every_boundary():
    values = _full_values(7)
    frame = oi.frame_stream_packets([6], values)
    for cut in range(1, len(frame)):
        parser = oi.StreamParser()
        got = parser.feed(frame[:cut]) + parser.feed(frame[cut:])
        assert len(got) == 1 and got[0][22] == 15000


def test_unknown_id_in_body_is_rejected():
    body = bytes([19, 2, 99, 0])
    frame = body + bytes([(-sum(body)) & 0xFF])
    parser = oi.StreamParser()
    assert parser.feed(frame) == []
    assert parser.bad_body == 1


def test_value_limits_and_frame_stream_body():
    assert oi.value_limits(7) == (0, 255)
    assert oi.value_limits(19) == (-32768, 32767)
    assert oi.value_limits(24) == (-128, 127)
    assert oi.frame_stream_body(bytes([7, 3])) == oi.frame_stream([(7, 3)])
    with pytest.raises(ValueError):
        oi.frame_stream_body(bytes(256))
