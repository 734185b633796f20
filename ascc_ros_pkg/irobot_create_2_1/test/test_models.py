"""Robot models: encoder rollover, encoder odometry, and the start-up model check (a Create 1
driven as a Create 2, garbage from a wrong baud rate, impossible OI mode bytes)."""
import math
import random

import pytest

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.driver_core import CreateDriverCore
from irobot_create_2_1.models import CREATE_1, CREATE_2, EncoderOdometry, encoder_delta, model
from irobot_create_2_1.virtual_create import VirtualCreate


@pytest.mark.parametrize("previous, current, delta", [
    (0, 100, 100), (100, 0, -100), (32767, -32768, 1), (-32768, 32767, -1),
    (32700, -32700, 136), (-32700, 32700, -136), (65535, 0, 1), (0, 65535, -1),
])
def test_encoder_delta_takes_the_short_way_round(previous, current, delta):
    assert encoder_delta(previous, current) == delta


def test_encoder_odometry_straight_and_turning():
    enc = EncoderOdometry(CREATE_2)
    assert enc.update(32000, -100) == (0.0, 0.0)           # reference only
    per_count = math.pi * 0.072 / 508.8
    d, a = enc.update(32000 + 1000 - 65536, -100 + 1000)    # left rolled over
    assert d == pytest.approx(1000 * per_count) and a == pytest.approx(0.0, abs=1e-12)
    d, a = enc.update(32000 + 900 - 65536, -100 + 1100)     # spin in place, left back
    assert d == pytest.approx(0.0, abs=1e-12)
    assert a == pytest.approx(200 * per_count / 0.235)


def test_unknown_model_is_named():
    with pytest.raises(ValueError, match="create_1, create_2"):
        model("roomba_400")
    with pytest.raises(ValueError):
        EncoderOdometry(CREATE_1)                           # no encoders in its OI


def _run(core, robot, seconds, t0=0.0, dt=0.005):
    t = t0
    for _ in range(int(round(seconds / dt))):
        robot.step(dt)
        t += dt
        core.on_bytes(robot.read_output(), t)
    return t


def test_create1_driven_as_create2_is_a_mismatch_and_no_odometry():
    robot = VirtualCreate()                                  # a Create 1
    core = CreateDriverCore(robot=CREATE_2, baud=57600)
    robot.feed(core.init_sequence())
    robot.feed(oi.drive_direct(200, 200))                    # it drives: still no odometry
    _run(core, robot, 1.0)
    assert core.model_check.pending
    _run(core, robot, 1.5, t0=1.0)
    assert core.mismatch
    msg = core.model_check.message
    assert "create_2" in msg and "likely a create_1" in msg
    assert "~robot_model:=create_1" in msg and "frames of 0 data bytes" in msg
    assert robot.pose[0] > 0.4
    assert core.odom.pose == (0.0, 0.0, 0.0) and core.values == {}
    assert core.on_bytes(oi.frame_stream_packets([100], {p: 0 for p in oi.PACKETS}), 3.0) == []


def test_garbage_at_the_wrong_baud_is_a_mismatch_naming_create_2():
    rng = random.Random(3)
    core = CreateDriverCore()                                # create_1 at 57600
    t = 0.0
    for _ in range(150):                                     # 2.25 s of garbage
        t += 0.015
        core.on_bytes(bytes(rng.randrange(256) for _ in range(40)), t)
    assert core.mismatch
    msg = core.model_check.message
    assert "no valid stream frame" in msg and "~robot_model:=create_2" in msg
    assert "115200" in msg and core.odom.pose == (0.0, 0.0, 0.0)


def test_impossible_mode_byte_is_a_mismatch():
    values = {p: 0 for p in oi.PACKETS}
    values.update({19: 100, 35: 9})                          # 9: no OI mode
    frame = oi.frame_stream_packets([6], values)
    core = CreateDriverCore()
    t = 0.0
    for _ in range(150):
        t += 0.015
        assert core.on_bytes(frame, t) == []
    assert core.mismatch and "OI mode byte (packet 35) is 9" in core.model_check.message
    assert core.odom.pose == (0.0, 0.0, 0.0)


def test_silence_is_not_a_mismatch_and_good_frames_pass_after_garbage():
    core = CreateDriverCore(robot=CREATE_2)
    for i in range(200):
        core.on_bytes(b"", 0.015 * i)
    assert core.model_check.pending
    robot = VirtualCreate(robot=CREATE_2)
    robot.feed(core.init_sequence())
    core.on_bytes(bytes(random.Random(5).randrange(256) for _ in range(64)), 3.0)
    _run(core, robot, 0.1, t0=3.0)
    assert core.model_check.state == "ok" and not core.mismatch
    assert 43 in core.values and 58 in core.values


def test_create2_stream_with_garbage_between_frames_keeps_odometry_exact():
    rng = random.Random(11)
    robot = VirtualCreate(robot=CREATE_2)
    core = CreateDriverCore(robot=CREATE_2)
    robot.feed(core.init_sequence())
    t = _run(core, robot, 0.05)
    robot.feed(oi.drive_direct(150, 250))                    # an arc to the left
    for i in range(400):
        robot.step(0.005)
        t += 0.005
        data = robot.read_output()
        if i % 7 == 3:                                       # garbage between frames
            data += bytes(rng.randrange(256) for _ in range(rng.randint(1, 30)))
        core.on_bytes(data, t)
    robot.feed(oi.drive_direct(0, 0))
    _run(core, robot, 0.1, t0=t)
    x, y, th = robot.pose
    assert core.parser.dropped_bytes > 0
    assert core.odom.x == pytest.approx(x, abs=0.003)
    assert core.odom.y == pytest.approx(y, abs=0.003)
    assert core.odom.theta == pytest.approx(th, abs=math.radians(0.5))
