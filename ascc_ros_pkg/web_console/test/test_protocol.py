"""The page protocol: parsing, bad messages, the token check, binary frames."""
import json
import math

import pytest

from web_console.protocol import (
    MAP,
    VIDEO,
    ProtocolError,
    binary_frame,
    clamp,
    goal_in_map,
    parse_message,
    split_frame,
    token_ok,
)

LIMIT = 4096


def test_drive_goal_estop_auth_ping_parse():
    m = parse_message(json.dumps({"type": "drive", "linear": 0.2, "angular": -1}), LIMIT)
    assert (m.type, m.linear, m.angular) == ("drive", 0.2, -1.0)
    m = parse_message('{"type": "goal", "x": 1.5, "y": -2, "yaw": 0.5}', LIMIT)
    assert (m.x, m.y, m.yaw) == (1.5, -2.0, 0.5)
    assert parse_message('{"type": "goal", "x": 1, "y": 2}', LIMIT).yaw == 0.0
    assert parse_message('{"type": "estop", "on": true}', LIMIT).on is True
    assert parse_message('{"type": "estop", "on": false}', LIMIT).on is False
    assert parse_message('{"type": "auth", "token": "abc"}', LIMIT).token == "abc"
    assert parse_message('{"type": "ping", "id": 12.5}', LIMIT).id == 12.5
    assert parse_message('{"type": "release"}', LIMIT).type == "release"
    assert parse_message('{"type": "cancel"}', LIMIT).type == "cancel"


@pytest.mark.parametrize("text, says", [
    ("{not json", "not JSON"),
    ("[1, 2]", "not a JSON object"),
    ('{"type": "fly"}', "unknown message type"),
    ('{"linear": 1}', "unknown message type"),
    ('{"type": "drive", "linear": 0.1}', "without 'angular'"),
    ('{"type": "drive", "linear": NaN, "angular": 0}', "not JSON"),
    ('{"type": "drive", "linear": Infinity, "angular": 0}', "not JSON"),
    ('{"type": "drive", "linear": 1e999, "angular": 0}', "not finite"),
    ('{"type": "drive", "linear": "fast", "angular": 0}', "not a number"),
    ('{"type": "drive", "linear": true, "angular": 0}', "not a number"),
    ('{"type": "goal", "x": null, "y": 0}', "without 'x'"),
    ('{"type": "estop", "on": 1}', "true or false"),
    ('{"type": "auth", "token": 5}', "must be a string"),
])
def test_bad_messages_are_refused_with_a_reason(text, says):
    with pytest.raises(ProtocolError, match=says):
        parse_message(text, LIMIT)


def test_oversized_and_binary_messages_are_refused():
    big = json.dumps({"type": "ping", "id": 1, "pad": "x" * LIMIT})
    with pytest.raises(ProtocolError, match="over the limit"):
        parse_message(big, LIMIT)
    with pytest.raises(ProtocolError, match="binary"):
        parse_message(b'{"type": "ping"}', LIMIT)
    # the limit counts UTF-8 bytes, not characters
    wide = json.dumps({"type": "ping", "pad": "\u00e9" * 2100}, ensure_ascii=False)
    assert len(wide) < LIMIT < len(wide.encode("utf-8"))
    with pytest.raises(ProtocolError, match="over the limit"):
        parse_message(wide, LIMIT)


def test_token_check():
    assert token_ok("", "")  # no token configured: anyone drives
    assert token_ok("", "whatever")
    assert token_ok("s3cret", "s3cret")
    assert not token_ok("s3cret", "")
    assert not token_ok("s3cret", "s3cre")
    assert not token_ok("s3cret", "S3CRET")
    assert token_ok("p\u00e4ss", "p\u00e4ss")


def test_clamp_and_goal_bounds():
    assert clamp(0.9, 0.3) == 0.3 and clamp(-0.9, 0.3) == -0.3 and clamp(0.1, 0.3) == 0.1
    bounds = (-1.0, 2.0, 15.0, 13.0)
    assert goal_in_map(0.0, 5.0, bounds)
    assert not goal_in_map(-1.5, 5.0, bounds)
    assert not goal_in_map(0.0, 13.0, bounds)
    assert not goal_in_map(20.0, 5.0, bounds)


def test_binary_frame_keeps_the_payload_bytes():
    jpeg = bytes(range(256)) * 10
    data = binary_frame(VIDEO, {"stamp": 12.25, "age_s": 0.031}, jpeg)
    kind, header, payload = split_frame(data)
    assert kind == VIDEO and payload == jpeg
    assert header == {"stamp": 12.25, "age_s": 0.031}
    kind, header, payload = split_frame(binary_frame(MAP, {"width": 3}, b"\x89PNG"))
    assert kind == MAP and header["width"] == 3 and payload == b"\x89PNG"
    assert not math.isnan(header["width"])
