"""Create 2 Open Interface conformance: protocol.py, the virtual Create 2 (as a black box)
and the driver core, against the iRobot Create 2 Open Interface (OI) Specification based on
the Roomba 600 (iRobot, 2015) alone.

Every expected byte and number below was worked out by hand from that specification, not
from `protocol.py`, `models.py` or the emulator; each test names the spec section its
vectors come from ("Spec: <section>"). Multi-byte values are big-endian, signed ones two's
complement (spec: "Sensor Packets"). The Create 1 conformance test is test_oi_conformance.py.
A failure here is a deviation from the spec, not a test to relax.
"""
import math

import pytest

from irobot_create_2_1 import protocol
from irobot_create_2_1.driver_core import CreateDriverCore
from irobot_create_2_1.models import CREATE_2, model
from irobot_create_2_1.virtual_create import VirtualCreate

# Spec: Sensor Packets, 43-58: id -> (data bytes, signed).
SPEC_NEW_PACKETS = {
    43: (2, True), 44: (2, True),                    # left/right encoder counts
    45: (1, False),                                  # light bumper bits
    46: (2, False), 47: (2, False), 48: (2, False),  # light bump signals 0-4095
    49: (2, False), 50: (2, False), 51: (2, False),
    52: (1, False), 53: (1, False),                  # IR character left / right
    54: (2, True), 55: (2, True), 56: (2, True), 57: (2, True),  # motor currents [mA]
    58: (1, False),                                  # stasis
}
# Spec: Sensor Packets, group table: group id -> (bytes, first id, last id).
SPEC_NEW_GROUPS = {100: (80, 7, 58), 101: (28, 43, 58), 106: (12, 46, 51), 107: (9, 54, 58)}
# Spec: Light Bumper (45): bit 0 left, 1 front left, 2 center left, 3 center right,
# 4 front right, 5 right. Stasis (58): bit 0 toggling, bit 1 disabled.
LT_LEFT, LT_RIGHT = 0x01, 0x20
STASIS_TOGGLING = 0x01
# Spec: Left/Right Encoder Counts: "The number of counts per revolution is 508.8 ...
# wheel diameter 72.0 mm"; Drive Direct / robot dimensions: wheel base 235 mm.
COUNTS_PER_REV, WHEEL_DIAMETER_MM, WHEEL_BASE_MM = 508.8, 72.0, 235.0
MM_PER_COUNT = math.pi * WHEEL_DIAMETER_MM / COUNTS_PER_REV   # 0.4446 mm


def test_model_numbers():
    # Spec: Serial Port Settings, "Baud: 115200 or 19200"; 115200 is the default; Baud
    # command, code 11 = 115200.
    m = model("create_2")
    assert m.baud == 115200
    assert m.wheel_base_m == pytest.approx(WHEEL_BASE_MM / 1000.0)
    assert m.metres_per_count * 1000.0 == pytest.approx(MM_PER_COUNT)
    assert MM_PER_COUNT == pytest.approx(0.4446, abs=1e-4)
    assert VirtualCreate(robot=m).baud_code == 11


@pytest.mark.parametrize("pid", sorted(SPEC_NEW_PACKETS))
def test_new_packet_sizes_and_signedness(pid):
    size, signed = SPEC_NEW_PACKETS[pid]
    spec = protocol.PACKETS[pid]
    assert (spec.size, bool(spec.signed)) == (size, signed)
    assert protocol.expand(pid, protocol.CREATE_2_IDS) == (pid,)
    with pytest.raises(ValueError):        # not a Create 1 packet
        protocol.expand(pid)


@pytest.mark.parametrize("gid", sorted(SPEC_NEW_GROUPS))
def test_new_groups(gid):
    size, first, last = SPEC_NEW_GROUPS[gid]
    assert protocol.expand(gid, protocol.CREATE_2_IDS) == tuple(range(first, last + 1))
    assert protocol.packet_size(gid) == size


def test_stream_command_for_group_100():
    # Spec: Stream, [148][Number of packets][Packet ID 1]...
    assert protocol.stream([100], protocol.CREATE_2_IDS) == bytes([148, 1, 100])
    assert protocol.query_list([43, 44], protocol.CREATE_2_IDS) == bytes([149, 2, 43, 44])
    with pytest.raises(ValueError):
        protocol.stream([100])             # the Create 1 has no group 100


# Group 101 (packets 43-58, 28 bytes), assembled by hand.
GROUP101 = bytes([
    0xFF, 0xFE,          # 43 left encoder -2
    0x7F, 0xFF,          # 44 right encoder 32767
    0x21,                # 45 light bumper: left and right
    0x0F, 0xFF,          # 46 left signal 4095
    0x00, 0x00,          # 47 front left 0
    0x01, 0x00,          # 48 center left 256
    0x00, 0x01,          # 49 center right 1
    0x00, 0x64,          # 50 front right 100
    0x0B, 0xB8,          # 51 right 3000
    0xA1, 0x00,          # 52 IR left 161, 53 IR right 0
    0xFE, 0xD4,          # 54 left motor -300 mA
    0x01, 0x2C,          # 55 right motor 300 mA
    0x80, 0x00,          # 56 main brush -32768 mA
    0x7F, 0xFF,          # 57 side brush 32767 mA
    0x03,                # 58 stasis toggling + disabled
])
GROUP101_VALUES = {43: -2, 44: 32767, 45: LT_LEFT | LT_RIGHT, 46: 4095, 47: 0, 48: 256,
                   49: 1, 50: 100, 51: 3000, 52: 161, 53: 0, 54: -300, 55: 300,
                   56: -32768, 57: 32767, 58: 3}


def test_decode_group_101():
    assert len(GROUP101) == 28
    assert protocol.decode_packets([101], GROUP101) == GROUP101_VALUES


def _frame(body):
    # Spec: Stream, [19][N-bytes][ids and data][Checksum]: all bytes sum to 0 mod 256.
    head = bytes([19, len(body)]) + body
    return head + bytes([(256 - sum(head) % 256) % 256])


def test_stream_frame_of_group_101_with_garbage_between_frames():
    frame = _frame(bytes([101]) + GROUP101)
    assert len(frame) == 2 + 1 + 28 + 1
    garbage = bytes([19, 29, 0, 0, 5, 19, 200, 7, 19])  # headers that are not frames
    parser = protocol.StreamParser([101], protocol.CREATE_2_IDS)
    out = parser.feed(garbage + frame + garbage[:4] + frame + bytes([19]) + frame)
    assert out == [GROUP101_VALUES] * 3
    assert parser.dropped_bytes >= len(garbage) + 4 + 1


def test_virtual_create2_streams_group_100_frames():
    # Spec: Stream, a frame every 15 ms; group 100 = 80 data bytes -> N-bytes 81.
    robot = VirtualCreate(robot=CREATE_2)
    robot.feed(bytes([128, 131]) + bytes([148, 1, 100]))
    robot.step(0.151)
    out = robot.read_output()
    assert len(out) == 10 * (3 + 81)
    for i in range(10):
        frame = out[i * 84:(i + 1) * 84]
        assert frame[:3] == bytes([19, 81, 100]) and sum(frame) % 256 == 0
        assert frame[3 + 26 + 14] == 2  # packet 35, after groups 0 and 4: safe


def test_virtual_create1_does_not_answer_create2_packets():
    robot = VirtualCreate()
    robot.feed(bytes([128, 131, 149, 2, 35, 43]))       # Query List [35, 43]
    assert robot.read_output() == bytes([2])            # only the mode byte: safe


def test_virtual_create2_encoders_follow_the_wheels():
    robot = VirtualCreate(robot=CREATE_2)
    robot.feed(bytes([128, 131]) + bytes([145, 0x00, 0xC8, 0x00, 0x64]))  # R 200, L 100
    for _ in range(200):
        robot.step(0.005)                                # 1 s
    robot.feed(bytes([149, 2, 43, 44]))
    left, right = protocol.decode_packets([43, 44], robot.read_output()).values()
    assert left == pytest.approx(100.0 / MM_PER_COUNT, abs=1.0)
    assert right == pytest.approx(200.0 / MM_PER_COUNT, abs=1.0)


def test_driver_core_odometry_from_encoders_across_the_rollover():
    robot = VirtualCreate(robot=CREATE_2)
    robot.set_encoder_counts(32767 - 300, -32768 + 100)  # near both ends of the range
    core = CreateDriverCore(robot=CREATE_2)
    robot.feed(core.init_sequence())
    robot.step(0.05)                                     # standing: the first frames
    t = 0.05
    core.on_bytes(robot.read_output(), t)
    core.set_twist(0.25, 0.0, t)
    robot.feed(core.command_bytes(t))
    wrapped = False
    while robot.pose[0] < 1.0:
        robot.step(0.005)
        t += 0.005
        core.on_bytes(robot.read_output(), t)
        wrapped |= robot.encoder_counts[0] < 0
    robot.feed(protocol.drive_direct(0, 0))
    for _ in range(20):
        robot.step(0.005)
        t += 0.005
        core.on_bytes(robot.read_output(), t)
    assert wrapped                                       # the left counter rolled over
    assert core.odom.x == pytest.approx(robot.pose[0], abs=0.002)
    assert abs(core.odom.y) < 1e-3 and abs(core.odom.theta) < 1e-3


def _mode(robot):
    robot.read_output()
    robot.feed(bytes([142, 35]))                         # Sensors [35]: OI mode
    return robot.read_output()[0]


def test_virtual_create2_frames_the_create2_command_set():
    # Spec: Max [136] has no data byte (the Create 1's Demo [136][n] has one): Max then
    # Safe puts the robot into safe mode; a Create 1 reads the same bytes as Demo 131.
    for robot, expected in ((VirtualCreate(robot=CREATE_2), 2), (VirtualCreate(), 1)):
        robot.feed(bytes([128, 131, 136, 131]))
        assert _mode(robot) == expected, robot.robot.name
    robot = VirtualCreate(robot=CREATE_2)
    robot.feed(bytes([128, 131]))
    # Spec: Schedule [167] + 15 data bytes, Set Day/Time [168][day][hour][minute],
    # Digit LEDs ASCII [164] + 4, Scheduling LEDs [162] + 2, Buttons [165] + 1: all
    # framed by their lengths, so the Drive Direct after them drives.
    robot.feed(bytes([167] + [0] * 15 + [168, 1, 12, 30] + [164, 65, 66, 67, 68]
                     + [162, 0, 0] + [165, 0]) + bytes([145, 0, 100, 0, 100]))
    assert robot.wheel_speed_cmd_mps == (0.1, 0.1)
    # Spec: Stop [173]: the OI stops (off: only Start is heard).
    robot.feed(bytes([173]))
    assert robot.oi_mode == 0 and robot.wheel_speed_cmd_mps == (0.0, 0.0)
    # The Create 1's Wait Time [155][t] is no Create 2 command: it does not hold the
    # input (both bytes, 155 and 20, are no opcodes), the Drive Direct after it drives.
    robot.feed(bytes([128, 131, 155, 20, 145, 0, 50, 0, 50]))
    assert robot.wheel_speed_cmd_mps == (0.05, 0.05)
    create1 = VirtualCreate()
    create1.feed(bytes([128, 131, 155, 20, 145, 0, 50, 0, 50]))
    assert create1.waiting and create1.wheel_speed_cmd_mps == (0.0, 0.0)
