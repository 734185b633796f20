"""Tests of the emulated Create's sensor packets (irobot_create_2_1.oi_sensors): reply
sizes, bits, odometry reads and stream frames.

Expected values come from the iRobot Create Open Interface specification (sizes, bits,
special radii, 15 ms stream period, group layout) and from kinematics worked out here, not
from the emulator's own tables. No ROS master needed; `started`, `query`, `run` and
`collect_frames` are fixtures of conftest.py.
"""

import math

import pytest

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.create_state import CreateState
from irobot_create_2_1.oi_sensors import SensorEncoder

WHEEL_BASE_M = 0.258
# Spec, Sensor Packets: data bytes of every packet id 7..42.
SPEC_SIZES = {pid: 1 for pid in range(7, 43)}
SPEC_SIZES.update({pid: 2 for pid in (19, 20, 22, 23, 25, 26, 27, 28, 29, 30, 31, 33,
                                      39, 40, 41, 42)})
# Spec, Sensor Packets: group id -> bytes.
SPEC_GROUP_SIZES = {0: 26, 1: 10, 2: 6, 3: 10, 4: 14, 5: 12, 6: 52}


def test_requested_velocity_and_radius_packets(started, query):
    create = started()
    create.feed(oi.drive(-200, 500))
    assert query(create, 39, 40) == {39: -200, 40: 500}
    create.feed(oi.drive(100, oi.STRAIGHT_RADIUS))
    assert query(create, 39, 40) == {39: 100, 40: -32768}   # 0x8000 read as int16


@pytest.mark.parametrize("pid", sorted(SPEC_SIZES) + sorted(SPEC_GROUP_SIZES))
def test_sensors_reply_size(pid, started):
    create = started()
    create.read_output()
    create.feed(oi.sensors(pid))
    expected = SPEC_SIZES.get(pid, SPEC_GROUP_SIZES.get(pid))
    assert len(create.read_output()) == expected


def test_sensors_unknown_id_sends_nothing(started):
    create = started()
    create.feed(bytes([oi.SENSORS, 43, oi.SENSORS, 100]))
    assert create.read_output() == b""


def test_query_list_order_and_size(started):
    create = started()
    create.feed(oi.query_list([35, 7, 6, 19]))
    assert len(create.read_output()) == 1 + 1 + 52 + 2


def test_bump_wheel_drop_cliff_wall_bits(started, query):
    create = started(oi.full)
    create.set_bumpers(True, False)
    create.set_wheel_drops(left=False, right=True, caster=True)
    create.set_cliffs(left=True, front_right=True)
    create.set_wall(True)
    create.set_virtual_wall(True)
    create.set_buttons(play=True, advance=True)
    create.set_charging_sources(home_base=True)
    values = query(create, 1, 18, 28, 29, 34)
    assert values[7] == 0x02 | 0x04 | 0x10         # bump left, drop right, caster
    assert (values[8], values[9], values[10], values[11], values[12], values[13]) == (
        1, 1, 0, 1, 0, 1)
    assert values[18] == 0x05                      # play bit 0, advance bit 2
    assert values[28] < values[29]                 # the cliff side sees less light
    assert values[34] == 0x02                      # home base bit 1
    create.set_bumpers(False, True)
    assert query(create, 7)[7] & 0x03 == 0x01


def test_distance_and_angle_reset_on_read(started, query, run):
    create = started()
    create.feed(oi.drive_direct(200, 200))
    run(create, 1.0)
    assert query(create, 19)[19] == 200
    assert query(create, 19)[19] == 0
    create.feed(oi.drive_direct(-100, 100))       # counter-clockwise spin
    run(create, 1.0)
    expected_deg = math.degrees(0.2 / WHEEL_BASE_M)
    assert query(create, 20)[20] == int(expected_deg)
    assert query(create, 20)[20] == 0


@pytest.mark.parametrize("left, right, pid, per_s", [
    (100, 100, 19, 100.0),                         # 1.5 mm per 15 ms read
    (-70, -70, 19, -70.0),                         # 1.05 mm per read, backwards
    (-30, 30, 20, -math.degrees(-0.06 / WHEEL_BASE_M)),   # ~0.2 deg per read, CCW
    (30, -30, 20, math.degrees(-0.06 / WHEEL_BASE_M)),    # clockwise is negative
])
def test_many_small_reads_are_not_biased(left, right, pid, per_s, started, query):
    create = started()
    create.feed(oi.drive_direct(left, right))
    total = 0
    for _ in range(1000):                          # 15 s in 15 ms reads
        create.step(0.015)
        total += query(create, pid)[pid]
    expected = per_s * 15.0
    # Truncating each read would lose up to 1 unit per read (up to 1000 units here).
    assert abs(total - expected) <= 1.0
    assert abs(total) > 0.5 * abs(expected)


def test_distance_clamps_to_int16(started, query, run):
    create = started(oi.full)
    create.feed(oi.drive_direct(500, 500))
    run(create, 70.0, dt=0.1)                      # 35 m without a read
    assert query(create, 19)[19] == 32767
    create.feed(oi.drive_direct(-500, -500))
    run(create, 70.0, dt=0.1)
    assert query(create, 19)[19] == -32768


def test_stream_frame_bytes(started, query, run):
    create = started()
    create.set_cliffs(left=True)
    create.feed(oi.stream([29, 13]))
    run(create, 0.015)
    frame = create.read_output()
    signal = query(create, 29)[29]
    body = [29, signal >> 8, signal & 0xFF, 13, 0]
    head = [19, len(body)]
    assert frame == bytes(head + body + [(-sum(head + body)) & 0xFF])


def test_stream_of_a_group_carries_the_group_id(started, run):
    create = started()
    create.feed(oi.stream([2]))
    run(create, 0.015)
    frame = create.read_output()
    assert frame[:3] == bytes([19, 1 + 6, 2]) and len(frame) == 3 + 7
    assert sum(frame) % 256 == 0


def test_stream_distance_sums_to_travel(started, collect_frames):
    create = started()
    create.feed(oi.stream([19, 20]) + oi.drive(150, 1000))
    frames, _ = collect_frames(create, 6.0, 0.005)
    assert sum(f[19] for f in frames) == pytest.approx(900, abs=1)
    assert sum(f[20] for f in frames) == pytest.approx(math.degrees(0.9 / 1.0), abs=1)


def test_stream_frame_never_exceeds_255_data_bytes(started, run):
    create = started()
    create.feed(bytes([oi.STREAM, 10] + [6] * 10))  # 10 x 53 bytes requested
    run(create, 0.015)
    frame = create.read_output()
    assert frame[0] == 19 and frame[1] == 4 * 53 and len(frame) == 3 + 4 * 53
    assert sum(frame) % 256 == 0


# ----------------------------------------------------------------------------- the encoder alone
def test_sensor_encoder_reads_a_bare_state_and_clamps():
    state = CreateState()
    encoder = SensorEncoder(state)
    state.set_bumpers(True, True)
    assert encoder.encode_request(7) == bytes([0x03])
    assert encoder.encode_request(43) == b""
    state.set_wall(True, signal=70000)          # beyond the 2-byte packet: clamped
    assert encoder.encode_request(27) == b"\xff\xff"
    state.stream_ids = [7, 43, 35]              # 43 is not a packet: left out of the frame
    assert encoder.stream_frame(state.stream_ids) == oi.frame_stream([(7, 3), (35, 0)])
