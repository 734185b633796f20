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


def _create2_core(**kwargs):
    robot = VirtualCreate(robot=CREATE_2)
    core = CreateDriverCore(robot=CREATE_2, **kwargs)
    robot.feed(core.init_sequence())
    _run(core, robot, 0.05)
    return robot, core


def test_light_bumper_slows_forward_motion_only_when_asked():
    robot, core = _create2_core(light_bump_speed_m_s=0.1)
    core.set_twist(0.3, 0.5, 0.05)
    assert core.target_wheels(0.05) == (241, 359)
    robot.set_light_bumps([0, 0, 900, 900, 0, 0])        # something ahead
    _run(core, robot, 0.05, t0=0.05)
    assert core.values[45] == 0b001100
    left, right = core.target_wheels(0.1)
    assert (left + right) / 2 == pytest.approx(100, abs=1) and right - left == 118
    core.command_bytes(0.1)
    assert core.light_bump_slowdowns == 1
    core.set_twist(-0.3, 0.0, 0.1)                       # backing away is not slowed
    assert core.target_wheels(0.1) == (-300, -300)
    _, off = _create2_core()                             # default: off
    off.values[45] = 0b111111
    off.set_twist(0.3, 0.0, 0.0)
    assert off.target_wheels(0.0) == (300, 300)


def test_stuck_when_wheels_turn_and_stasis_is_still():
    robot, core = _create2_core(stuck_after_s=1.0)
    t = 0.05
    core.set_twist(0.2, 0.0, t)
    robot.feed(core.command_bytes(t))
    for _ in range(3):                                   # driving free: never stuck
        core.set_twist(0.2, 0.0, t)
        t = _run(core, robot, 0.5, t0=t)
        assert not core.update_stuck(t)
    assert core.values[58] & oi.STASIS_TOGGLING
    robot.set_stuck(True)                                # wheels turn, body held
    t = _run(core, robot, 0.1, t0=t)
    assert not core.update_stuck(t)                      # not yet stuck_after_s
    core.set_twist(0.2, 0.0, t)
    t = _run(core, robot, 1.1, t0=t)
    assert core.update_stuck(t) and core.stuck_now
    assert core.values[43] != 0                          # the encoders kept counting
    core.stop(t)
    core.command_bytes(t)
    assert not core.update_stuck(t)                      # wheels stopped: not stuck


@pytest.mark.parametrize("robot", [CREATE_1, CREATE_2], ids=lambda m: m.name)
def test_watchdog_stops_within_two_stream_periods_after_the_timeout(robot):
    # Emulated time, the host reading every 5 ms (a 200 Hz reader): the driver's
    # cadence-driven watchdog (watchdog_bytes after each read, as the node does) must
    # stop the wheels within 2 stream periods (30 ms) after cmd_timeout_s.
    create = VirtualCreate(robot=robot)
    core = CreateDriverCore(robot=robot, cmd_timeout_s=0.5)
    create.feed(core.init_sequence())
    t = _run(core, create, 0.1)
    worst = 0.0
    for _ in range(5):
        t_cmd = t
        core.set_twist(0.2, 0.0, t_cmd)
        create.feed(core.command_bytes(t_cmd))
        while create.wheel_speed_cmd_mps != (0.0, 0.0):
            create.step(0.005)
            t += 0.005
            if core.on_bytes(create.read_output(), t):   # as the node: on frames only
                stop = core.watchdog_bytes(t)
                if stop is not None:
                    create.feed(stop)
            assert t < t_cmd + 1.0, "never stopped"
        late = t - (t_cmd + 0.5)
        assert late >= -1e-9                      # not before the timeout
        worst = max(worst, late)
        t = _run(core, create, 0.037, t0=t)       # vary the phase against the stream
    assert worst <= 2 * oi.STREAM_PERIOD_S + 1e-9, worst


def test_demo_and_clear_per_model():
    c1, c2 = CreateDriverCore(), CreateDriverCore(robot=CREATE_2, mode="full")
    assert c1.demo_bytes(3) == bytes([136, 3])
    with pytest.raises(ValueError, match="no demos"):
        c2.demo_bytes(3)
    assert c1.clear_bytes() == bytes([136, 255, 131])
    assert c2.clear_bytes() == bytes([132])
    # on the virtual Create 2, Seek Dock then the clear: back in full mode, wheels obey
    robot = VirtualCreate(robot=CREATE_2)
    robot.feed(c2.init_sequence() + bytes([143]))
    assert robot.mode == "passive" and robot.docking_requested
    robot.feed(c2.clear_bytes() + oi.drive_direct(100, 100))
    assert robot.mode == "full" and robot.wheel_speed_cmd_mps == (0.1, 0.1)
