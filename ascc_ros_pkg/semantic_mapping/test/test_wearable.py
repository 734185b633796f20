"""The sensor packets and the receiver's core: streams per sensor id, throttled warnings
for unknown ids, bad frames, malformed packets, lost packets and silent sensors."""
import pytest

from semantic_mapping.wearable import (
    ReceiverCore,
    ReceiverWarning,
    Sample,
    SampleOut,
    SleepNotice,
    decode_packet,
    encode_sample,
    encode_sleep,
)
from semantic_mapping.xbee import encode_rx16

WAIST, THIGH = 0x0001, 0x0002


def sample(seq, ax=9.75):  # values exact in float32
    return Sample(seq, (ax, 0.5, -0.25), (0.0, 0.125, 0.0), (0.0, 0.0, 0.0, 1.0))


def frame(addr, seq, **kw):
    return encode_rx16(addr, encode_sample(sample(seq, **kw)))


def core():
    return ReceiverCore({WAIST: "waist", THIGH: "thigh"}, silence_timeout_s=1.0,
                        frame_timeout_s=0.2, warn_period_s=10.0)


def kinds(out):
    return [o.kind for o in out if isinstance(o, ReceiverWarning)]


def test_packets_round_trip():
    s = sample(513)
    assert decode_packet(encode_sample(s)) == s
    assert decode_packet(encode_sleep(70000)) == SleepNotice(70000 & 0xFFFF)
    for bad, msg in ((b"", "empty"), (b"\x01abc", "sample packet of 4 bytes"),
                     (b"\x09", "unknown packet kind 0x09")):
        with pytest.raises(ValueError, match=msg):
            decode_packet(bad)


def test_one_stream_per_sensor():
    c = core()
    out = c.feed(frame(WAIST, 0) + frame(THIGH, 0, ax=1.0) + frame(WAIST, 1), 0.0)
    assert [(o.sensor, o.sample.seq) for o in out] == [("waist", 0), ("thigh", 0),
                                                       ("waist", 1)]
    assert out[1].sample.accel[0] == 1.0


def test_unknown_ids_are_warned_once_per_period_and_the_others_go_on():
    c = core()
    out = c.feed(frame(7, 0) + frame(WAIST, 0) + frame(7, 1), 0.0)
    assert kinds(out) == ["unknown_id:0x0007"]
    assert "unknown sensor id 0x0007" in out[0].text and "0x0001=waist" in out[0].text
    assert [o.sensor for o in out if isinstance(o, SampleOut)] == ["waist"]
    assert kinds(c.feed(frame(7, 2), 5.0)) == []          # throttled
    assert kinds(c.feed(frame(9, 0), 5.0)) == ["unknown_id:0x0009"]  # its own throttle
    assert kinds(c.feed(frame(7, 3), 10.5)) == ["unknown_id:0x0007"]
    assert c.unknown == {7: 4, 9: 1}


def test_bad_frames_warn_and_cost_only_themselves():
    c = core()
    bad = bytearray(frame(THIGH, 0))
    bad[-1] ^= 1
    out = c.feed(b"noise" + bytes(bad) + frame(WAIST, 0) + frame(THIGH, 1), 0.0)
    assert kinds(out) == ["garbage", "bad_checksum"]
    assert "bad checksum" in out[1].text
    assert [(o.sensor, o.sample.seq) for o in out if isinstance(o, SampleOut)] == \
        [("waist", 0), ("thigh", 1)]
    out = c.feed(encode_rx16(WAIST, b"\x01short"), 0.1)
    assert kinds(out) == ["bad_packet:waist"] and "malformed packet" in out[0].text


def test_lost_packets_are_counted():
    c = core()
    c.feed(frame(WAIST, 65534), 0.0)
    out = c.feed(frame(WAIST, 65535) + frame(WAIST, 3), 0.1)  # 0, 1, 2 lost (wraps)
    warnings = [o for o in out if isinstance(o, ReceiverWarning)]
    assert kinds(out) == ["lost:waist"] and "3 packets lost" in warnings[0].text
    assert c.streams[WAIST].lost == 3


def test_a_silent_sensor_is_warned_unless_it_announced_sleep():
    c = core()
    c.feed(frame(WAIST, 0) + frame(THIGH, 0), 0.0)
    c.feed(encode_rx16(THIGH, encode_sleep(1)), 0.05)
    assert kinds(c.check(0.5)) == []
    out = c.check(1.5)
    assert kinds(out) == ["silent:waist"]          # the thigh is asleep, not silent
    assert "no packet since 1.5 s" in out[0].text
    assert kinds(c.check(2.0)) == []               # throttled
    c.feed(frame(THIGH, 2), 20.0)                  # the thigh wakes up; the waist is still
    assert kinds(c.check(20.1)) == ["silent:waist"]


def test_a_sensor_never_heard_of_is_silent_too():
    c = core()
    c.feed(frame(WAIST, 0), 0.0)
    c.feed(frame(WAIST, 1), 1.2)
    out = c.check(1.25)
    assert kinds(out) == ["silent:thigh"] and "no packet at all" in out[0].text


def test_a_partial_frame_expires_when_the_link_goes_quiet():
    c = core()
    whole = frame(WAIST, 0)
    c.feed(whole[:10], 0.0)
    assert kinds(c.check(0.1)) == []
    out = c.check(0.3)
    assert kinds(out) == ["truncated"]
    assert [o.sensor for o in c.feed(frame(WAIST, 1), 0.35) if isinstance(o, SampleOut)] \
        == ["waist"]
