"""Tests of the Open Interface command decoding (irobot_create_2_1.oi_commands): modes,
framing, and what each command does to the robot.

Expected values come from the iRobot Create Open Interface specification (sizes, bits,
special radii, 15 ms stream period, group layout) and from kinematics worked out here, not
from the emulator's own tables. No ROS master needed; `started`, `query`, `run` and
`collect_frames` are fixtures of conftest.py.
"""

import pytest

from irobot_create_2_1 import oi_commands
from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.virtual_create import VirtualCreate


def raw16(value):
    """Two bytes, big-endian two's complement (to send out-of-range values on purpose)."""
    return (value & 0xFFFF).to_bytes(2, "big")


def test_power_on_is_off_and_only_start_is_heard():
    create = VirtualCreate()
    assert create.mode == "off"
    create.feed(oi.safe() + oi.drive_direct(200, 200) + oi.sensors(35))
    assert create.mode == "off"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert create.read_output() == b""            # no sensor reply while off
    create.feed(oi.start())
    assert create.mode == "passive"
    create.feed(oi.sensors(35))
    assert create.read_output() == bytes([1])


@pytest.mark.parametrize("command, mode", [
    (oi.safe, "safe"), (oi.full, "full"), (lambda: bytes([oi.CONTROL]), "safe")])
def test_mode_commands(command, mode, query):
    create = VirtualCreate()
    create.feed(oi.start() + command())
    assert create.mode == mode
    assert query(create, 35)[35] == {"passive": 1, "safe": 2, "full": 3}[mode]


def test_start_from_full_returns_to_passive_and_stops(started):
    create = started(oi.full)
    create.feed(oi.drive_direct(100, 100))
    assert create.wheel_speed_cmd_mps == (0.1, 0.1)
    create.feed(oi.start())
    assert create.mode == "passive"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)


def test_actuator_commands_are_ignored_in_passive(started, run):
    create = started(oi.start)
    create.feed(oi.drive(200, oi.STRAIGHT_RADIUS) + oi.drive_direct(100, 100)
                + oi.leds(True, True, 255, 255) + oi.song(0, [60], [8]) + oi.play(0))
    assert create.mode == "passive"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert create.leds == (False, False, 0, 0)
    assert 0 in create.songs                     # Song is allowed in passive
    assert not create.song_playing               # Play is not
    assert create.commands_ignored == 4
    run(create, 0.2)
    assert create.pose == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("radius", [oi.STRAIGHT_RADIUS, 0x7FFF])
def test_drive_straight_special_radii(radius, started):
    create = started()
    create.feed(bytes([oi.DRIVE]) + raw16(-150) + raw16(radius))
    assert create.wheel_speed_cmd_mps == (-0.15, -0.15)


def test_drive_direct_right_wheel_first_on_the_wire(started, query):
    create = started()
    create.feed(bytes([oi.DRIVE_DIRECT]) + raw16(300) + raw16(-100))
    assert create.wheel_speed_cmd_mps == (-0.1, 0.3)
    assert query(create, 41, 42) == {41: 300, 42: -100}


def test_command_split_across_feeds(started):
    create = started()
    data = oi.drive_direct(120, 80)
    for byte in data[:-1]:
        create.feed(bytes([byte]))
        assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    create.feed(data[-1:])
    assert create.wheel_speed_cmd_mps == (0.12, 0.08)


def test_unknown_opcodes_are_skipped(started):
    create = started()
    create.feed(bytes([0, 17, 133, 146, 159, 255]) + oi.sensors(35))
    assert create.read_output() == bytes([2])
    assert create.unknown_bytes == 6


def test_leds(started):
    create = started()
    create.feed(oi.leds(True, False, 200, 17))
    assert create.leds == (True, False, 200, 17)
    create.feed(oi.leds(False, True, 0, 255))
    assert (create.leds.play, create.leds.advance) == (False, True)


def test_song_and_play(started, query, run):
    create = started()
    create.feed(oi.song(3, [60, 62, 64], [32, 32, 64]))   # 2 s in 1/64 s units
    assert create.songs[3] == [(60, 32), (62, 32), (64, 64)]
    create.feed(oi.play(5))                               # undefined song: nothing
    assert not create.song_playing
    create.feed(oi.play(3))
    assert create.song_playing and query(create, 36, 37) == {36: 3, 37: 1}
    create.feed(oi.song(4, [70], [8]) + oi.play(4))       # busy: Play does nothing
    assert create.song_number == 3 and create.songs_played == [3]
    run(create, 1.9)
    assert create.song_playing
    run(create, 0.2)
    assert not create.song_playing and query(create, 37)[37] == 0
    create.feed(oi.play(4))
    assert create.songs_played == [3, 4]


def test_demo_and_abort(started):
    create = started(oi.full)
    create.feed(oi.drive_direct(100, 100) + oi.demo(4))
    assert create.mode == "passive" and create.last_demo == 4 and create.demo_running
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    create.feed(oi.demo(-1))
    assert create.last_demo == -1 and not create.demo_running


@pytest.mark.parametrize("opcode, demo", [(oi.SPOT, 2), (oi.COVER, 0),
                                          (oi.COVER_AND_DOCK, 1)])
def test_cleaning_demos(opcode, demo, started):
    create = started()
    create.feed(bytes([opcode]))
    assert create.mode == "passive" and create.last_demo == demo
    assert create.docking_requested == (opcode == oi.COVER_AND_DOCK)


def test_other_actuators(started):
    create = started()
    create.feed(bytes([oi.LOW_SIDE_DRIVERS, 5, oi.DIGITAL_OUTPUTS, 6, oi.SEND_IR, 42,
                       oi.PWM_LOW_SIDE_DRIVERS, 10, 128, 200, oi.BAUD, 11]))
    assert create.low_side_drivers == 5 and create.digital_outputs == 6
    assert create.sent_ir == [42] and create.pwm_low_side == (10, 128, 128)
    assert create.baud_code == 11


# ----------------------------------------------------------------------------- the decoder alone
def test_take_command_frames_skips_and_waits_for_the_rest():
    rx = bytearray([0, oi.SONG, 1, 2, 60, 8, 62])                 # junk, a song missing a byte
    assert oi_commands.take_command(rx, 1) == oi_commands.SKIPPED  # unknown opcode 0
    assert rx == bytearray([oi.SONG, 1, 2, 60, 8, 62])
    assert oi_commands.take_command(rx, 1) is None                 # incomplete: untouched
    assert len(rx) == 6
    rx += bytes([16]) + oi.drive(100, 500)
    assert oi_commands.take_command(rx, 1) == (oi.SONG, bytes([1, 2, 60, 8, 62, 16]))
    assert oi_commands.take_command(rx, 1) == (oi.DRIVE, oi.drive(100, 500)[1:])
    assert rx == bytearray()
    off = bytearray(oi.safe() + oi.start())                        # off: only Start is heard
    assert oi_commands.take_command(off, 0) == oi_commands.SKIPPED
    assert oi_commands.take_command(off, 0) == (oi.START, b"")


def test_execute_runs_a_command_only_in_its_modes():
    create = VirtualCreate()
    create.feed(oi.start())                                        # passive
    assert not oi_commands.execute(create, oi.DRIVE, oi.drive(100, 500)[1:])
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert oi_commands.execute(create, oi.FULL, b"") and create.mode == "full"
    assert oi_commands.execute(create, oi.DRIVE_DIRECT, oi.drive_direct(-50, 70)[1:])
    assert create.wheel_speed_cmd_mps == (-0.05, 0.07)
