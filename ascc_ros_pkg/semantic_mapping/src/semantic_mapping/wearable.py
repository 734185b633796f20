"""The wearable motion sensors' packets (thesis 5.4.1) and the receiver's core: XBee RX
frames in, one sample stream per sensor out, with the warnings a node logs. Pure Python.

Packet (the RF data of an XBee frame; ours, the thesis does not give the sensor's format),
little-endian:

    kind 0x01  sample: kind (1) | seq (uint16) | acceleration x y z (float32, m/s^2) |
               angular rate x y z (float32, rad/s) | orientation x y z w (float32,
               quaternion of the sensor frame in the VN-100's world frame)      43 bytes
    kind 0x02  going to sleep (the power-aware scheme: no motion for a while)
               kind (1) | seq (uint16)                                            3 bytes

``seq`` counts the sensor's packets (mod 65536); a gap is counted as lost samples.

`ReceiverCore` keeps one stream per known sensor (16-bit XBee address -> name). `feed`
returns `SampleOut` for every good sample and `ReceiverWarning` for what went wrong: unknown sensor
ids, frames the decoder rejected (garbage, bad length, bad checksum, truncated), malformed
packets, lost samples; `check` (called on a timer) adds a sensor that fell silent without
announcing sleep and expires a partial frame the link left hanging. Each kind of warning
(per sensor where it applies) is throttled on its own (`ascc_common.throttle.Throttle`), so
a frequent one cannot hide a rare one, and a bad frame from one sensor never stops the
other's stream.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple, Union

from ascc_common.params import param
from ascc_common.throttle import Throttle

from .xbee import DecodeError, FrameDecoder, RxPacket

KIND_SAMPLE = 0x01
KIND_SLEEP = 0x02
_SAMPLE = struct.Struct("<BH10f")
_SLEEP = struct.Struct("<BH")


@dataclass
class ReceiverParams:
    """The receiver node's private parameters."""

    port: str = param("/dev/ttyUSB0", "serial port of the receiving XBee (or the "
                      "emulator's pty link)")
    baud: int = param(57600, "[baud] serial rate of the XBee", gt=0)
    sensor_ids: List[int] = param([1, 2], "16-bit XBee source addresses of the sensors",
                                  ge=0, le=0xFFFF)
    sensor_names: List[str] = param(["waist", "thigh"], "their names, in the same order: "
                                    "topics wearable/<name>/imu")
    frame_prefix: str = param("wearable_", "the Imu frame_id is this + the sensor's name")
    silence_timeout_s: float = param(1.0, "[s] a sensor silent this long without announcing "
                                     "sleep is warned about", gt=0.0)
    frame_timeout_s: float = param(0.2, "[s] a partial frame with no byte for this long is "
                                   "dropped (truncated)", gt=0.0)
    warn_period_s: float = param(10.0, "[s] each kind of warning at most once per this",
                                 gt=0.0)

    def validate(self) -> None:
        if len(self.sensor_ids) != len(self.sensor_names):
            raise ValueError("sensor_ids (%d) and sensor_names (%d) must pair up"
                             % (len(self.sensor_ids), len(self.sensor_names)))
        if len(set(self.sensor_ids)) != len(self.sensor_ids):
            raise ValueError("sensor_ids must be unique: %s" % self.sensor_ids)
        bad = [n for n in self.sensor_names if not n.isidentifier()]
        if bad or len(set(self.sensor_names)) != len(self.sensor_names):
            raise ValueError("sensor_names must be unique names (letters, digits, _): %s"
                             % self.sensor_names)


@dataclass(frozen=True)
class Sample:
    seq: int
    accel: Tuple[float, float, float]        # [m/s^2] sensor frame, gravity included
    gyro: Tuple[float, float, float]         # [rad/s]
    quat: Tuple[float, float, float, float]  # x, y, z, w


@dataclass(frozen=True)
class SleepNotice:
    seq: int


def encode_sample(s: Sample) -> bytes:
    return _SAMPLE.pack(KIND_SAMPLE, s.seq & 0xFFFF, *s.accel, *s.gyro, *s.quat)


def encode_sleep(seq: int) -> bytes:
    return _SLEEP.pack(KIND_SLEEP, seq & 0xFFFF)


def decode_packet(payload: bytes) -> Union[Sample, SleepNotice]:
    """A packet's content; ValueError naming what is wrong otherwise."""
    if not payload:
        raise ValueError("empty packet")
    kind = payload[0]
    if kind == KIND_SAMPLE:
        if len(payload) != _SAMPLE.size:
            raise ValueError("sample packet of %d bytes (%d expected)"
                             % (len(payload), _SAMPLE.size))
        v = _SAMPLE.unpack(payload)
        return Sample(v[1], tuple(v[2:5]), tuple(v[5:8]), tuple(v[8:12]))
    if kind == KIND_SLEEP:
        if len(payload) != _SLEEP.size:
            raise ValueError("sleep packet of %d bytes (%d expected)"
                             % (len(payload), _SLEEP.size))
        return SleepNotice(_SLEEP.unpack(payload)[1])
    raise ValueError("unknown packet kind 0x%02X" % kind)


@dataclass(frozen=True)
class SampleOut:
    sensor: str     # the sensor's name (its topic: wearable/<name>/imu)
    sample: Sample


@dataclass(frozen=True)
class ReceiverWarning:
    kind: str       # the throttle key, e.g. "unknown_id:0x0007", "bad_checksum"
    text: str


@dataclass
class _Stream:
    name: str
    last_rx: Optional[float] = None   # [s] time of the last packet
    last_seq: Optional[int] = None
    asleep: bool = False
    samples: int = 0
    lost: int = 0


class ReceiverCore:
    """Frames in (bytes), samples and throttled warnings out. ``now`` is in seconds (ROS
    time in the node)."""

    def __init__(self, sensors: Dict[int, str], silence_timeout_s: float = 1.0,
                 frame_timeout_s: float = 0.2, warn_period_s: float = 10.0):
        self.streams = {addr: _Stream(name) for addr, name in sensors.items()}
        self.silence_timeout_s = silence_timeout_s
        self.frame_timeout_s = frame_timeout_s
        self.decoder = FrameDecoder()
        self.throttle = Throttle(warn_period_s)
        self.unknown: Dict[int, int] = {}  # address -> packets
        self._last_byte: Optional[float] = None
        self._started: Optional[float] = None

    def _warn(self, out: List, key: str, text: str, now: float) -> None:
        if self.throttle.ready(key, now):
            out.append(ReceiverWarning(key, text))

    def feed(self, data: bytes, now: float) -> List[Union[SampleOut, ReceiverWarning]]:
        if self._started is None:
            self._started = now
        if data:
            self._last_byte = now
        out: List[Union[SampleOut, ReceiverWarning]] = []
        for ev in self.decoder.feed(data):
            self._event(ev, now, out)
        return out

    def _event(self, ev, now: float, out: List) -> None:
        if isinstance(ev, DecodeError):
            self._warn(out, ev.kind, "bad XBee frame: %s: %s (%d bad frames so far)"
                       % (ev.kind.replace("_", " "), ev.detail, self.decoder.errors), now)
            return
        if not isinstance(ev, RxPacket):
            self._warn(out, "frame_type", "XBee frame of API type 0x%02X ignored (not an RX "
                       "packet)" % ev.api_id, now)
            return
        stream = self.streams.get(ev.source)
        if stream is None:
            self.unknown[ev.source] = self.unknown.get(ev.source, 0) + 1
            self._warn(out, "unknown_id:0x%04X" % ev.source, "packets from unknown sensor id "
                       "0x%04X ignored (%d so far; known: %s)" % (
                           ev.source, self.unknown[ev.source], ", ".join(
                               "0x%04X=%s" % (a, s.name) for a, s in self.streams.items())),
                       now)
            return
        try:
            packet = decode_packet(ev.payload)
        except ValueError as exc:
            self._warn(out, "bad_packet:" + stream.name, "sensor %s (0x%04X): malformed "
                       "packet: %s" % (stream.name, ev.source, exc), now)
            return
        if stream.last_seq is not None:
            gap = (packet.seq - stream.last_seq - 1) & 0xFFFF
            if 0 < gap < 0x8000:
                stream.lost += gap
                self._warn(out, "lost:" + stream.name, "sensor %s: %d packets lost (%d so "
                           "far)" % (stream.name, gap, stream.lost), now)
        stream.last_seq = packet.seq
        stream.last_rx = now
        if isinstance(packet, SleepNotice):
            stream.asleep = True
            return
        stream.asleep = False
        stream.samples += 1
        out.append(SampleOut(stream.name, packet))

    def check(self, now: float) -> List[Union[SampleOut, ReceiverWarning]]:
        """Timer work: expire a partial frame left by a quiet link, and warn about sensors
        silent for ``silence_timeout_s`` that did not announce sleep."""
        out: List[Union[SampleOut, ReceiverWarning]] = []
        if (self.decoder.pending and self._last_byte is not None
                and now - self._last_byte > self.frame_timeout_s):
            for ev in self.decoder.expire():
                self._event(ev, now, out)
        for addr, s in self.streams.items():
            since = s.last_rx if s.last_rx is not None else self._started
            if since is None or s.asleep or now < since:
                continue
            if now - since > self.silence_timeout_s:
                what = "no packet since %.1f s" % (now - since) if s.last_rx is not None \
                    else "no packet at all in %.1f s" % (now - since)
                self._warn(out, "silent:" + s.name, "sensor %s (0x%04X) is silent: %s "
                           "(it did not announce sleep)" % (s.name, addr, what), now)
        return out
