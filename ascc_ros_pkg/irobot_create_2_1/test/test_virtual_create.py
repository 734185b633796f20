"""Tests of the emulator (irobot_create_2_1.virtual_create): the stream clock, power cycle,
scripts, wait commands, and (section 2) the whole emulator as a black box against the
spec.

Expected values come from the iRobot Create Open Interface specification (sizes, bits,
special radii, 15 ms stream period, group layout) and from kinematics worked out here, not
from the emulator's own tables. No ROS master needed; `started`, `query`, `run` and
`collect_frames` are fixtures of conftest.py.
"""

import math
import random
from typing import List

import pytest

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.virtual_create import VirtualCreate

# Spec constants of section 2, written from the spec only (see test_oi_conformance.py).
# Spec: Sensor Packets (pp. 17-21): packet id -> data bytes, and the group table.
SPEC_PACKETS = {p: 2 if p in (19, 20, 22, 23, 25, 26, 27, 28, 29, 30, 31, 33, 39, 40, 41,
                              42) else 1 for p in range(7, 43)}
SPEC_GROUPS = {0: 26, 1: 10, 2: 6, 3: 10, 4: 14, 5: 12, 6: 52}
# Spec: Bumps and Wheel Drops (packet 7), bit layout; OI Mode (packet 35).
BUMP_RIGHT, BUMP_LEFT, DROP_RIGHT, DROP_LEFT, DROP_CASTER = 0x01, 0x02, 0x04, 0x08, 0x10
MODE_PASSIVE, MODE_SAFE, MODE_FULL = 1, 2, 3


def raw16(value):
    """Two bytes, big-endian two's complement (to send out-of-range values on purpose)."""
    return (value & 0xFFFF).to_bytes(2, "big")


def test_random_bytes_never_raise(started):
    rng = random.Random(7)
    create = started(oi.full)
    for _ in range(300):
        create.feed(bytes(rng.randrange(256) for _ in range(rng.randint(1, 40))))
        create.step(rng.choice([0.0, 0.001, 0.015, 0.1]))
        create.read_output()
    assert create.mode in ("off", "passive", "safe", "full")


@pytest.mark.parametrize("dt", [0.001, 0.005, 0.015, 0.05, 0.1])
def test_stream_sends_a_frame_every_15_ms(dt, started, collect_frames):
    create = started()
    create.feed(oi.stream([7, 19, 35]))
    frames, parser = collect_frames(create, 3.0, dt)
    assert len(frames) == 200                      # 3 s / 15 ms
    assert parser.bad_checksum == 0 and parser.dropped_bytes == 0
    assert all(set(f) == {7, 19, 35} for f in frames)


def test_pause_resume_and_empty_stream(started, query, collect_frames):
    create = started()
    create.feed(oi.stream([7]))
    assert len(collect_frames(create, 0.3, 0.005)[0]) == 20
    create.feed(oi.pause_resume_stream(False))
    assert collect_frames(create, 0.3, 0.005)[0] == []
    create.feed(oi.pause_resume_stream(True))
    assert len(collect_frames(create, 0.3, 0.005)[0]) == 20
    assert query(create, 38)[38] == 1
    create.feed(bytes([oi.STREAM, 0]))             # zero packets: the stream stops
    assert collect_frames(create, 0.3, 0.005)[0] == []


def test_power_cycle_stops_everything_until_start_and_stream_again(started, collect_frames):
    create = started()
    create.feed(oi.stream([7]) + oi.drive_direct(200, 200))
    assert len(collect_frames(create, 0.3, 0.005)[0]) == 20
    create.power_cycle()
    assert create.mode == "off"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert collect_frames(create, 0.3, 0.005)[0] == []
    create.feed(oi.safe() + oi.stream([7]) + oi.drive_direct(100, 100))  # no Start: unheard
    assert create.mode == "off" and create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert collect_frames(create, 0.3, 0.005)[0] == []
    create.feed(oi.start() + oi.safe() + oi.stream([7]))
    assert create.mode == "safe"
    assert len(collect_frames(create, 0.3, 0.005)[0]) == 20


def test_spec_example_script_drive_40_cm_and_stop(started, run):
    create = started()
    # Spec, Script: "Drive 40 cm and stop": 152 13 137 1 44 128 0 156 1 144 137 0 0 0 0
    create.feed(bytes([152, 13, 137, 1, 44, 128, 0, 156, 1, 144, 137, 0, 0, 0, 0]))
    create.feed(bytes([oi.SHOW_SCRIPT]))
    assert create.read_output() == bytes([13, 137, 1, 44, 128, 0, 156, 1, 144, 137, 0, 0,
                                          0, 0])
    create.feed(bytes([oi.PLAY_SCRIPT]) + oi.sensors(35))
    assert create.waiting and create.read_output() == b""   # input held by the wait
    run(create, 2.0)
    assert not create.waiting and create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert create.read_output() == bytes([2])               # the held Sensors ran after
    assert create.pose[0] == pytest.approx(0.4, abs=0.0015)  # one 5 ms step at 0.3 m/s


def test_wait_time_and_wait_event(started, run):
    create = started()
    create.feed(bytes([oi.WAIT_TIME, 10]) + oi.drive_direct(100, 100))
    run(create, 0.995)
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    run(create, 0.01)
    assert create.wheel_speed_cmd_mps == (0.1, 0.1)
    create.feed(bytes([oi.WAIT_EVENT, 5]) + oi.drive_direct(0, 0))   # wait for a bump
    run(create, 1.0)
    assert create.wheel_speed_cmd_mps == (0.1, 0.1)
    create.set_bumpers(False, True)
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)


def test_wait_angle(started, run):
    create = started()
    create.feed(oi.drive(100, 1) + bytes([oi.WAIT_ANGLE]) + raw16(90) + oi.drive(0, 0))
    run(create, 10.0, dt=0.001)
    assert create.pose[2] == pytest.approx(math.pi / 2, abs=math.radians(0.1))


# --------------------------------------------------------------------------------------
# 2. The virtual Create against the spec, as a black box: bytes in (feed), bytes out (read_output),
#    emulated time (step), commanded wheel speeds, mode and the bumper/cliff inputs.
# --------------------------------------------------------------------------------------

@pytest.fixture
def vc():
    return VirtualCreate()


def _send(robot, *data: int) -> bytes:
    robot.feed(bytes(data))  # one command in, the robot's answer out
    return robot.read_output()


def _s16(data: bytes) -> int:
    assert len(data) == 2
    return int.from_bytes(data, "big", signed=True)


def _run(robot, seconds: float, dt_s: float = 0.005) -> bytes:
    out = b""  # emulated time in small steps; everything the robot sent meanwhile
    for _ in range(int(round(seconds / dt_s))):
        robot.step(dt_s)
        out += robot.read_output()
    return out


def _split_frames(data: bytes) -> List[bytes]:
    """Cut a clean stream (no garbage) into frames, strictly per the spec's format."""
    frames, i = [], 0
    while i < len(data):
        assert data[i] == 19, "byte %d of the stream is %d, not the header 19" % (i, data[i])
        end = i + data[i + 1] + 3
        assert end <= len(data), "truncated frame at byte %d" % i
        frames.append(data[i:end])
        i = end
    return frames


def test_vc_modes(vc):
    # Spec: Getting Started / Mode Commands; OI Mode packet 35 (1 passive, 2 safe, 3 full).
    _send(vc, 128)
    assert (_send(vc, 142, 35), vc.mode) == (bytes([MODE_PASSIVE]), "passive")
    _send(vc, 131)
    assert (_send(vc, 142, 35), vc.mode) == (bytes([MODE_SAFE]), "safe")
    _send(vc, 132)
    assert (_send(vc, 142, 35), vc.mode) == (bytes([MODE_FULL]), "full")
    _send(vc, 128)  # Spec: Start, "Changes mode to: Passive"
    assert _send(vc, 142, 35) == bytes([MODE_PASSIVE])


def test_vc_drive_direct_right_wheel_first(vc):
    # Spec: Drive Direct [145][right hi][right lo][left hi][left lo]: left +200, right -200.
    _send(vc, 128, 131)
    _send(vc, 145, 0xFF, 0x38, 0x00, 0xC8)
    left, right = vc.wheel_speed_cmd_mps
    assert left == pytest.approx(0.200) and right == pytest.approx(-0.200)
    # Spec: packets 41/42, requested right/left velocity.
    assert _s16(_send(vc, 142, 41)) == -200 and _s16(_send(vc, 142, 42)) == 200
    _send(vc, 142, 20)
    _run(vc, 0.5)
    assert _s16(_send(vc, 142, 20)) < 0  # left forward, right back: a clockwise spin


def test_vc_drive_requested_velocity_and_radius(vc):
    # Spec: Drive example [137][255][56][1][244]; packets 39/40 return what was requested.
    _send(vc, 128, 131)
    _send(vc, 137, 255, 56, 1, 244)
    assert _s16(_send(vc, 142, 39)) == -200 and _s16(_send(vc, 142, 40)) == 500
    left, right = vc.wheel_speed_cmd_mps
    assert left < 0 and right < 0 and abs(right) > abs(left)  # backward, turning left


def test_vc_drive_is_ignored_in_passive_mode(vc):
    # Spec: Passive Mode, "you cannot change the current command parameters for the
    # actuators"; Drive: "Available in modes: Safe or Full".
    _send(vc, 128)
    _send(vc, 137, 0, 200, 0x80, 0x00)
    assert tuple(vc.wheel_speed_cmd_mps) == (0.0, 0.0)
    _send(vc, 145, 0, 200, 0, 200)
    assert tuple(vc.wheel_speed_cmd_mps) == (0.0, 0.0)
    _run(vc, 0.5)
    assert _send(vc, 142, 19) == b"\x00\x00"


def test_vc_bump_and_wheel_drop_bits(vc):
    # Spec: Bumps and Wheel Drops (packet 7): bump right bit 0, left bit 1, wheel drop
    # right bit 2, left bit 3, caster bit 4.  (Passive mode: no safety reaction.)
    _send(vc, 128)
    vc.set_bumpers(True, False)
    assert _send(vc, 142, 7) == bytes([BUMP_LEFT])
    vc.set_bumpers(False, True)
    assert _send(vc, 142, 7) == bytes([BUMP_RIGHT])
    vc.set_bumpers(False, False)
    for kwargs, bit in (({"right": True}, DROP_RIGHT), ({"left": True}, DROP_LEFT),
                        ({"caster": True}, DROP_CASTER)):
        vc.set_wheel_drops(**kwargs)
        assert _send(vc, 142, 7) == bytes([bit]), kwargs


def test_vc_reply_sizes(vc):
    # Spec: Sensors [142][id] returns the packet's data bytes only; group sizes per table.
    _send(vc, 128, 131)
    for gid, size in SPEC_GROUPS.items():
        assert len(_send(vc, 142, gid)) == size, gid
    for pid, size in SPEC_PACKETS.items():
        assert len(_send(vc, 142, pid)) == size, pid
    # Spec: Query List returns the data of the listed packets, in order, once.
    assert len(_send(vc, 149, 3, 7, 19, 35)) == 1 + 2 + 1
    vc.set_bumpers(True, False)
    everything = _send(vc, 142, 6)
    assert everything[0] == BUMP_LEFT      # packet 7 first
    assert everything[8:10] == b"\x00\x00"  # Spec: Unused Bytes 15-16 "always 0"
    assert everything[40] == MODE_SAFE      # packet 35 after groups 0 (26) and 4 (14)


def test_vc_distance_straight(vc):
    # Spec: Drive special case straight (hex 8000); Distance (19) = mm since last request,
    # mean of both wheels, then reset.
    _send(vc, 128, 131)
    _send(vc, 142, 19)
    _send(vc, 142, 20)
    _send(vc, 137, 0, 100, 0x80, 0x00)
    _run(vc, 1.0)
    assert 98 <= _s16(_send(vc, 142, 19)) <= 102
    assert _send(vc, 142, 19) == b"\x00\x00"
    assert abs(_s16(_send(vc, 142, 20))) <= 1


def test_vc_angle_sign(vc):
    # Spec: Drive radius hex 0001 = turn in place counter-clockwise, hex FFFF = clockwise;
    # Angle (20): "Counter-clockwise angles are positive and clockwise angles are negative".
    _send(vc, 128, 131)
    _send(vc, 142, 20)
    _send(vc, 137, 0, 100, 0x00, 0x01)
    _run(vc, 1.0)
    assert _s16(_send(vc, 142, 20)) > 0
    assert abs(_s16(_send(vc, 142, 19))) <= 2  # in place: no net forward travel
    _send(vc, 137, 0, 100, 0xFF, 0xFF)
    _run(vc, 1.0)
    assert _s16(_send(vc, 142, 20)) < 0


def test_vc_stream_timing_and_format(vc):
    # Spec: Stream [148][2][7][19]: a frame every 15 ms, [19][5][7][d][19][hi][lo][sum].
    _send(vc, 128, 131)
    _send(vc, 137, 0, 100, 0x80, 0x00)
    _send(vc, 142, 19)
    out = _send(vc, 148, 2, 7, 19) + _run(vc, 1.5)
    frames = _split_frames(out)
    assert abs(len(frames) - 100) <= 2
    for f in frames:
        assert len(f) == 8 and f[1] == 5 and f[2] == 7 and f[4] == 19
        assert sum(f) % 256 == 0
    # Distance is "since it was last requested": the frames add up to the 150 mm driven.
    assert abs(sum(_s16(f[5:7]) for f in frames) - 150) <= 3


def test_vc_stream_pause_and_resume(vc):
    # Spec: Pause/Resume Stream [150][0] stops the stream, [150][1] restarts it.
    _send(vc, 128)
    _send(vc, 148, 2, 7, 19)
    assert len(_split_frames(_run(vc, 0.3))) >= 18
    _send(vc, 150, 0)
    vc.read_output()
    assert _run(vc, 0.3) == b""
    _send(vc, 150, 1)
    assert len(_split_frames(_run(vc, 0.3))) >= 18


@pytest.mark.parametrize("trip", [
    lambda robot: robot.set_cliffs(front_left=True),
    lambda robot: robot.set_wheel_drops(caster=True)], ids=["cliff", "wheel-drop"])
def test_vc_safety_trip_in_safe_mode(vc, trip):
    # Spec: Safe Mode: a cliff while moving forward or a wheel drop -> "Create stops all
    # motors and reverts to the Passive mode".
    _send(vc, 128, 131)
    _send(vc, 137, 0, 200, 0x80, 0x00)
    _run(vc, 0.1)
    trip(vc)
    _run(vc, 0.05)
    assert tuple(vc.wheel_speed_cmd_mps) == (0.0, 0.0)
    assert (_send(vc, 142, 35), vc.mode) == (bytes([MODE_PASSIVE]), "passive")
    _send(vc, 137, 0, 200, 0x80, 0x00)  # now in Passive: drive is ignored
    assert tuple(vc.wheel_speed_cmd_mps) == (0.0, 0.0)


def test_vc_cliff_in_full_mode_keeps_driving(vc):
    # Spec: Full Mode turns off the cliff, wheel-drop and charger safety features.
    _send(vc, 128, 132)
    _send(vc, 137, 0, 200, 0x80, 0x00)
    vc.set_cliffs(left=True, right=True)
    _run(vc, 0.05)
    assert vc.wheel_speed_cmd_mps[0] == pytest.approx(0.2)
    assert _send(vc, 142, 35) == bytes([MODE_FULL])
