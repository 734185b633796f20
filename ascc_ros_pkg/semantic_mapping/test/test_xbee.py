"""The XBee API frame codec: known frames, resynchronisation after garbage, bad lengths,
bad checksums, truncation."""
import pytest

from semantic_mapping.xbee import (
    DecodeError,
    Frame,
    FrameDecoder,
    RxPacket,
    checksum,
    encode_frame,
    encode_rx16,
)


def test_checksum_of_a_documented_frame():
    # Digi's example: AT command "NJ" (API 0x08, frame id 0x52) -> 7E 00 04 08 52 4E 4A 0D
    frame = encode_frame(bytes([0x08, 0x52, 0x4E, 0x4A]))
    assert frame == bytes([0x7E, 0x00, 0x04, 0x08, 0x52, 0x4E, 0x4A, 0x0D])
    assert (sum(frame[3:]) & 0xFF) == 0xFF
    assert checksum(b"\x81\x00\x01") == 0xFF - 0x82


def test_rx16_round_trip_and_split_feeds():
    frame = encode_rx16(0x1234, b"\x01hello", rssi=45)
    assert frame[:3] == b"\x7e\x00\x0b" and frame[3] == 0x81
    dec = FrameDecoder()
    events = []
    for byte in frame:                  # one byte at a time
        events += dec.feed(bytes([byte]))
    assert events == [RxPacket(0x1234, b"\x01hello", -45)]
    assert dec.pending == 0 and dec.frames == 1 and dec.errors == 0


def test_zigbee_rx_and_other_frame_types():
    body = bytes(range(8)) + b"\x00\x07" + b"\x01" + b"data"
    dec = FrameDecoder()
    assert dec.feed(encode_frame(b"\x90" + body)) == [RxPacket(7, b"data", None)]
    assert dec.feed(encode_frame(b"\x89\x01\x00")) == [Frame(0x89, b"\x01\x00")]  # TX status


def test_garbage_before_and_between_frames():
    a, b = encode_rx16(1, b"\x01a"), encode_rx16(2, b"\x01b")
    events = FrameDecoder().feed(b"\x00\xff\x13" + a + b"junk" + b)
    kinds = [e.kind if isinstance(e, DecodeError) else e.source for e in events]
    assert kinds == ["garbage", 1, "garbage", 2]
    assert events[0].n_bytes == 3 and events[2].n_bytes == 4


def test_bad_checksum_costs_only_that_frame():
    a, b = bytearray(encode_rx16(1, b"\x01a")), encode_rx16(2, b"\x01b")
    a[-1] ^= 0x55
    dec = FrameDecoder()
    events = dec.feed(bytes(a) + b)
    assert isinstance(events[0], DecodeError) and events[0].kind == "bad_checksum"
    assert "expected 0x" in events[0].detail
    assert [e for e in events if isinstance(e, RxPacket)] == [RxPacket(2, b"\x01b", -40)]


def test_a_frame_cut_short_by_the_next_one():
    # the first frame loses its last 4 bytes; its length then runs into the next frame,
    # whose bytes fail the checksum; the decoder rescans from the byte after the start
    a, b, c = (encode_rx16(i, b"\x01" + bytes(20)) for i in (1, 2, 3))
    events = FrameDecoder().feed(a[:-4] + b + c)
    assert [e.source for e in events if isinstance(e, RxPacket)] == [2, 3]
    assert any(isinstance(e, DecodeError) and e.kind == "bad_checksum" for e in events)


def test_a_start_byte_inside_data_does_not_lose_frames():
    payload = b"\x01\x7e\x00\x05\x7e"
    frames = encode_rx16(1, payload) + encode_rx16(2, payload)
    events = FrameDecoder().feed(frames)
    assert events == [RxPacket(1, payload, -40), RxPacket(2, payload, -40)]


def test_bad_length_and_truncation_at_a_quiet_link():
    dec = FrameDecoder(max_length=64)
    events = dec.feed(b"\x7e\x01\x00" + encode_rx16(5, b"\x01x"))
    assert isinstance(events[0], DecodeError) and events[0].kind == "bad_length"
    assert events[-1] == RxPacket(5, b"\x01x", -40)
    whole = encode_rx16(6, b"\x01" + bytes(10))
    assert dec.feed(whole[:9]) == []    # waits for the rest
    assert dec.pending == 9
    expired = dec.expire()              # the link went quiet
    assert isinstance(expired[0], DecodeError) and expired[0].kind == "truncated"
    assert dec.pending == 0
    assert dec.feed(whole) == [RxPacket(6, b"\x01" + bytes(10), -40)]
    assert dec.flush() == []


def test_expire_keeps_a_whole_frame_behind_a_truncated_one():
    dec = FrameDecoder()
    whole = encode_rx16(9, b"\x01z")
    # a frame claiming 30 bytes, then a complete short frame: the claim hides it until the
    # link goes quiet
    events = dec.feed(b"\x7e\x00\x1e\x81\x00" + whole)
    assert events == []
    events = dec.expire()
    assert events[0].kind == "truncated"
    assert RxPacket(9, b"\x01z", -40) in events


@pytest.mark.parametrize("n", [0, 0x10000])
def test_encode_rejects_bad_sizes(n):
    with pytest.raises(ValueError):
        encode_frame(bytes(n))
