"""The page's own small protocol (no rospy, no tornado).

Page -> server: JSON text messages, one object each, at most ``max_message_bytes``:

=========  ======================================================  =========
type       fields                                                  needs
=========  ======================================================  =========
``auth``   ``token`` (str)                                         -
``ping``   ``id`` (number, echoed in ``pong``)                     -
``drive``  ``linear`` [m/s], ``angular`` [rad/s] (finite numbers)  token
``release``  (joystick let go: zero now, lease given up)           -
``estop``  ``on`` (bool): true latches e_stop; false re-arms       re-arm: token
``goal``   ``x``, ``y`` [m] in the map frame, ``yaw`` [rad]        token
``cancel``  (cancel the goal this console sent)                    token
=========  ======================================================  =========

Server -> page: JSON text (``status``, ``pong``, ``auth``, ``error``) and binary frames
``kind (1 byte) | header length (uint32, big endian) | JSON header | payload``: kind ``V``
a camera frame (payload: the camera's JPEG bytes untouched; header: ``stamp`` [s],
``age_s`` at sending), kind ``M`` the map (payload: PNG; header: width, height,
resolution, origin).
"""
from __future__ import annotations

import hmac
import json
import math
import struct
from dataclasses import dataclass
from typing import Any, Dict, Optional

VIDEO = b"V"
MAP = b"M"
TYPES = ("auth", "ping", "drive", "release", "estop", "goal", "cancel")


class ProtocolError(ValueError):
    """A message refused; ``str(err)`` is what the client is told."""


@dataclass(frozen=True)
class Message:
    """One parsed page message; numbers finite, fields present and typed."""

    type: str
    linear: float = 0.0
    angular: float = 0.0
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    on: bool = False
    token: str = ""
    id: float = 0.0


def _number(obj: Dict[str, Any], key: str, default: Optional[float] = None) -> float:
    value = obj.get(key, default)
    if value is None:
        raise ProtocolError("'%s' message without '%s'" % (obj["type"], key))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ProtocolError("'%s' of '%s' is not a number: %r" % (key, obj["type"], value))
    value = float(value)
    if not math.isfinite(value):
        raise ProtocolError("'%s' of '%s' is not finite: %r" % (key, obj["type"], value))
    return value


def parse_message(text: Any, max_bytes: int) -> Message:
    """A page message from a WebSocket text message; ProtocolError naming what is wrong
    (binary, oversized, not JSON, not an object, unknown type, missing or non-finite
    numbers). JSON's NaN/Infinity literals are refused too."""
    obj = _decode(text, max_bytes)
    kind = obj["type"]
    if kind == "drive":
        return Message(kind, linear=_number(obj, "linear"), angular=_number(obj, "angular"))
    if kind == "goal":
        return Message(kind, x=_number(obj, "x"), y=_number(obj, "y"),
                       yaw=_number(obj, "yaw", 0.0))
    if kind == "estop":
        return Message(kind, on=_typed(obj, "on", bool, "true or false"))
    if kind == "auth":
        return Message(kind, token=_typed(obj, "token", str, "a string"))
    if kind == "ping":
        return Message(kind, id=_number(obj, "id", 0.0))
    return Message(kind)


def _decode(text: Any, max_bytes: int) -> Dict[str, Any]:
    """The JSON object of a text message with a known ``type``."""
    if isinstance(text, (bytes, bytearray)):
        raise ProtocolError("binary messages are not accepted (%d bytes)" % len(text))
    if not isinstance(text, str):
        raise ProtocolError("not a text message")
    size = len(text.encode("utf-8"))
    if size > max_bytes:
        raise ProtocolError("message of %d bytes over the limit of %d" % (size, max_bytes))
    try:
        obj = json.loads(text, parse_constant=_refuse_constant)
    except ValueError as err:
        raise ProtocolError("not JSON: %s" % err) from err
    if not isinstance(obj, dict):
        raise ProtocolError("not a JSON object")
    if obj.get("type") not in TYPES:
        raise ProtocolError("unknown message type %r (known: %s)"
                            % (obj.get("type"), ", ".join(TYPES)))
    return obj


def _typed(obj: Dict[str, Any], key: str, kind: type, what: str) -> Any:
    value = obj.get(key)
    if not isinstance(value, kind):
        raise ProtocolError("'%s' of '%s' must be %s: %r" % (key, obj["type"], what, value))
    return value


def _refuse_constant(name: str) -> float:
    raise ValueError("%s is not a number" % name)


def token_ok(configured: str, given: str) -> bool:
    """Whether ``given`` may drive: any when no token is configured; else equal in
    constant time (hmac.compare_digest)."""
    if not configured:
        return True
    return hmac.compare_digest(configured.encode("utf-8"), given.encode("utf-8"))


def clamp(value: float, limit: float) -> float:
    """``value`` within [-limit, limit]."""
    return max(-limit, min(limit, value))


def goal_in_map(x: float, y: float, bounds) -> bool:
    """Whether (x, y) [m] lies inside the map's ``bounds`` (xmin, ymin, xmax, ymax)."""
    xmin, ymin, xmax, ymax = bounds
    return xmin <= x < xmax and ymin <= y < ymax


def binary_frame(kind: bytes, header: Dict[str, Any], payload: bytes) -> bytes:
    """A server -> page binary message: kind, uint32 header length, JSON header, payload
    (the payload's bytes unchanged)."""
    head = json.dumps(header, separators=(",", ":")).encode("utf-8")
    return kind + struct.pack(">I", len(head)) + head + payload


def split_frame(data: bytes):
    """(kind, header dict, payload) of a ``binary_frame`` (tests, tools)."""
    (n,) = struct.unpack(">I", data[1:5])
    return data[:1], json.loads(data[5:5 + n].decode("utf-8")), data[5 + n:]
