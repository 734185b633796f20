"""XBee API-mode frames (API mode 1, ``AP=1``: no escaped bytes), encoder and a
resynchronising decoder. Pure Python, no ROS, no I/O: the decoder takes bytes, so a serial
port, a pty or a recording can feed it.

A frame on the wire::

    0x7E | length (16 bit, big-endian) | frame data (length bytes) | checksum

The frame data begins with the API identifier; the checksum is ``0xFF - (sum of the frame
data bytes & 0xFF)``, so the frame data plus the checksum sum to 0xFF (mod 256). The
frames a receiver gets from the sensors are RX packets:

    0x81  RX, 16-bit source address: address (2) | RSSI (1, -dBm) | options (1) | RF data
    0x90  ZigBee receive packet: 64-bit address (8) | 16-bit address (2) | options (1) |
          RF data  (the source is the 16-bit address)

`FrameDecoder.feed(data)` returns the events the bytes completed, in order: `RxPacket` for
a good RX frame, `Frame` for a good frame of another type, `DecodeError` for anything
wrong. Recovery: bytes before a start byte are skipped (one ``garbage`` error per run of
them); a length of 0 or above ``max_length`` (``bad_length``) or a wrong checksum
(``bad_checksum``) drops only that start byte and the search for the next 0x7E starts right
after it, so a frame cut short by the next one (its claimed length running into the next
frame) costs only itself. ``expire()`` drops a partial frame that waited too long
(``truncated``: the link went quiet mid-frame) and rescans what followed its start byte;
``flush()`` does the same at the end of a stream.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Union

START = 0x7E
API_RX16 = 0x81
API_RX_ZIGBEE = 0x90
MAX_LENGTH = 128  # [bytes] frame data; an 802.15.4 XBee carries <= 100 bytes of RF data


def checksum(frame_data: bytes) -> int:
    """The API checksum of the frame data (API identifier onwards)."""
    return 0xFF - (sum(frame_data) & 0xFF)


def encode_frame(frame_data: bytes) -> bytes:
    """A complete API frame around ``frame_data`` (which starts with the API identifier)."""
    if not 1 <= len(frame_data) <= 0xFFFF:
        raise ValueError("frame data must be 1..65535 bytes, got %d" % len(frame_data))
    n = len(frame_data)
    return bytes((START, n >> 8, n & 0xFF)) + bytes(frame_data) + bytes((checksum(frame_data),))


def encode_rx16(source: int, payload: bytes, rssi: int = 40, options: int = 0) -> bytes:
    """An RX (16-bit address) frame, as the receiving XBee hands a sensor's packet on."""
    if not 0 <= source <= 0xFFFF:
        raise ValueError("16-bit source address out of range: %r" % (source,))
    return encode_frame(bytes((API_RX16, source >> 8, source & 0xFF, rssi & 0xFF,
                               options & 0xFF)) + bytes(payload))


@dataclass(frozen=True)
class Frame:
    """A frame with a good checksum."""

    api_id: int
    data: bytes  # the frame data after the API identifier


@dataclass(frozen=True)
class RxPacket:
    """A received packet: the sender's 16-bit address and its RF data."""

    source: int
    payload: bytes
    rssi_dbm: Optional[int]  # -dBm as a negative number; None for 0x90 frames


@dataclass(frozen=True)
class DecodeError:
    """What went wrong, for a warning: ``kind`` is garbage, bad_length, bad_checksum,
    truncated or short_rx (an RX frame too short for its header)."""

    kind: str
    detail: str
    n_bytes: int  # bytes dropped


Event = Union[Frame, RxPacket, DecodeError]


def _parse(api_id: int, body: bytes) -> Union[Frame, RxPacket, DecodeError]:
    if api_id == API_RX16:
        if len(body) < 4:
            return DecodeError("short_rx", "RX16 frame with %d header bytes (4 needed)"
                               % len(body), len(body) + 5)
        return RxPacket((body[0] << 8) | body[1], bytes(body[4:]), -body[2])
    if api_id == API_RX_ZIGBEE:
        if len(body) < 11:
            return DecodeError("short_rx", "ZigBee RX frame with %d header bytes (11 needed)"
                               % len(body), len(body) + 5)
        return RxPacket((body[8] << 8) | body[9], bytes(body[11:]), None)
    return Frame(api_id, bytes(body))


class FrameDecoder:
    """Bytes in, events out; keeps a partial frame between calls."""

    def __init__(self, max_length: int = MAX_LENGTH):
        self.max_length = max_length
        self._buf = bytearray()
        self.frames = 0   # good frames
        self.errors = 0   # DecodeErrors returned

    @property
    def pending(self) -> int:
        """Bytes of an incomplete frame (or unscanned bytes) held."""
        return len(self._buf)

    def feed(self, data: bytes) -> List[Event]:
        """The events the bytes complete, in order."""
        self._buf.extend(data)
        return self._drain()

    def expire(self) -> List[Event]:
        """The caller saw no byte for too long: the partial frame held is dropped as
        ``truncated`` up to the next start byte, and the bytes from there are scanned again
        (frames among them are returned; a partial frame among them is stale too, and
        dropped alike).
        Empty if nothing was pending."""
        events: List[Event] = []
        while self._buf:
            n = len(self._buf)
            nxt = self._buf.find(START, 1)
            dropped = n if nxt < 0 else nxt
            del self._buf[:dropped]
            self.errors += 1
            events.append(DecodeError("truncated", "frame cut short: %d bytes of it arrived, "
                                      "then the link went quiet" % n, dropped))
            events.extend(self._drain())
        return events

    def flush(self) -> List[Event]:
        """At the end of a stream: what is left, as `expire` reports it."""
        return self.expire()

    def _drain(self) -> List[Event]:
        events: List[Event] = []
        while True:
            ev = self._next()
            if ev is None:
                return events
            if isinstance(ev, DecodeError):
                self.errors += 1
            else:
                self.frames += 1
            events.append(ev)

    def _next(self) -> Optional[Event]:
        buf = self._buf
        if not buf:
            return None
        if buf[0] != START:
            i = buf.find(START)
            n = len(buf) if i < 0 else i
            del buf[:n]
            return DecodeError("garbage", "%d bytes outside any frame skipped" % n, n)
        if len(buf) < 3:
            return None
        length = (buf[1] << 8) | buf[2]
        if length == 0 or length > self.max_length:
            del buf[:1]
            return DecodeError("bad_length", "frame length %d outside 1..%d"
                               % (length, self.max_length), 1)
        if len(buf) < length + 4:
            return None
        frame_data = bytes(buf[3:3 + length])
        if checksum(frame_data) != buf[3 + length]:
            got = buf[3 + length]
            del buf[:1]
            return DecodeError("bad_checksum", "checksum 0x%02X, expected 0x%02X (frame of "
                               "%d bytes, API id 0x%02X)" % (got, checksum(frame_data),
                                                             length, frame_data[0]), 1)
        del buf[:length + 4]
        return _parse(frame_data[0], frame_data[1:])
