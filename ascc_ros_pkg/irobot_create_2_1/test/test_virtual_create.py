"""Tests of the virtual Create (irobot_create_2_1.virtual_create) and its pty link.

Expected values come from the iRobot Create Open Interface specification (sizes, bits,
special radii, 15 ms stream period, group layout) and from kinematics worked out here, not
from the emulator's own tables. No ROS master needed.
"""

import math
import os
import random
import threading
import time

import pytest
import serial

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.pty_link import PtyLink
from irobot_create_2_1.virtual_create import VirtualCreate

WHEEL_BASE_M = 0.258
# Spec, Sensor Packets: data bytes of every packet id 7..42.
SPEC_SIZES = {pid: 1 for pid in range(7, 43)}
SPEC_SIZES.update({pid: 2 for pid in (19, 20, 22, 23, 25, 26, 27, 28, 29, 30, 31, 33,
                                      39, 40, 41, 42)})
# Spec, Sensor Packets: group id -> bytes.
SPEC_GROUP_SIZES = {0: 26, 1: 10, 2: 6, 3: 10, 4: 14, 5: 12, 6: 52}


def raw16(value):
    """Two bytes, big-endian two's complement (to send out-of-range values on purpose)."""
    return (value & 0xFFFF).to_bytes(2, "big")


def started(mode=oi.safe, **kwargs):
    create = VirtualCreate(**kwargs)
    create.feed(oi.start() + mode())
    return create


def query(create, *pids):
    create.read_output()
    create.feed(oi.query_list(list(pids)))
    return oi.decode_packets(list(pids), create.read_output())


def run(create, seconds, dt=0.005):
    for _ in range(int(round(seconds / dt))):
        create.step(dt)


# ----------------------------------------------------------------------------- modes
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
def test_mode_commands(command, mode):
    create = VirtualCreate()
    create.feed(oi.start() + command())
    assert create.mode == mode
    assert query(create, 35)[35] == {"passive": 1, "safe": 2, "full": 3}[mode]


def test_start_from_full_returns_to_passive_and_stops():
    create = started(oi.full)
    create.feed(oi.drive_direct(100, 100))
    assert create.wheel_speed_cmd_mps == (0.1, 0.1)
    create.feed(oi.start())
    assert create.mode == "passive"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)


def test_actuator_commands_are_ignored_in_passive():
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


# ----------------------------------------------------------------------------- driving
@pytest.mark.parametrize("radius", [oi.STRAIGHT_RADIUS, 0x7FFF])
def test_drive_straight_special_radii(radius):
    create = started()
    create.feed(bytes([oi.DRIVE]) + raw16(-150) + raw16(radius))
    assert create.wheel_speed_cmd_mps == (-0.15, -0.15)


def test_drive_spin_in_place():
    create = started()
    create.feed(oi.drive(200, -1))                # clockwise: left forward, right back
    assert create.wheel_speed_cmd_mps == (0.2, -0.2)
    run(create, 0.5)
    assert create.pose[2] < 0
    create.feed(oi.drive(200, 1))                 # counter-clockwise
    assert create.wheel_speed_cmd_mps == (-0.2, 0.2)


@pytest.mark.parametrize("velocity, radius", [(200, 500), (-200, 500), (300, -400),
                                              (100, 2000), (250, -1000)])
def test_drive_arc_wheel_speeds(velocity, radius):
    create = started()
    create.feed(oi.drive(velocity, radius))
    left, right = create.wheel_speed_cmd_mps
    # centre speed = velocity; curvature (right - left) / b = 1 / radius, + = left turn
    assert 0.5 * (left + right) == pytest.approx(velocity / 1000.0)
    assert (right - left) / WHEEL_BASE_M == pytest.approx(velocity / radius)


def test_drive_direct_right_wheel_first_on_the_wire():
    create = started()
    create.feed(bytes([oi.DRIVE_DIRECT]) + raw16(300) + raw16(-100))
    assert create.wheel_speed_cmd_mps == (-0.1, 0.3)
    assert query(create, 41, 42) == {41: 300, 42: -100}


def test_wheel_saturation():
    create = started()
    create.feed(bytes([oi.DRIVE_DIRECT]) + raw16(1000) + raw16(-32768))
    assert create.wheel_speed_cmd_mps == (-0.5, 0.5)
    assert query(create, 41, 42) == {41: 500, 42: -500}
    create.feed(bytes([oi.DRIVE]) + raw16(2000) + raw16(oi.STRAIGHT_RADIUS))
    assert create.wheel_speed_cmd_mps == (0.5, 0.5)
    # an arc whose outer wheel would exceed 0.5 m/s: slowed down, the radius kept
    create.feed(oi.drive(500, 200))
    left, right = create.wheel_speed_cmd_mps
    assert max(abs(left), abs(right)) == pytest.approx(0.5)
    v, w = 0.5 * (left + right), (right - left) / WHEEL_BASE_M
    assert v / w == pytest.approx(0.2)
    # a radius beyond 2000 mm is clamped to 2000 mm
    create.feed(bytes([oi.DRIVE]) + raw16(200) + raw16(5000))
    left, right = create.wheel_speed_cmd_mps
    assert 0.5 * (left + right) / ((right - left) / WHEEL_BASE_M) == pytest.approx(2.0)


def test_requested_velocity_and_radius_packets():
    create = started()
    create.feed(oi.drive(-200, 500))
    assert query(create, 39, 40) == {39: -200, 40: 500}
    create.feed(oi.drive(100, oi.STRAIGHT_RADIUS))
    assert query(create, 39, 40) == {39: 100, 40: -32768}   # 0x8000 read as int16


def test_pose_follows_an_arc():
    create = started()
    create.feed(oi.drive(200, 500))               # quarter circle of radius 0.5 m
    quarter_s = (math.pi / 2 * 0.5) / 0.2
    run(create, quarter_s, dt=quarter_s / 400)
    x, y, theta = create.pose
    assert (x, y) == pytest.approx((0.5, 0.5), abs=1e-6)
    assert theta == pytest.approx(math.pi / 2, abs=1e-6)


def test_wheel_travel_from_the_simulator_overrides_the_command():
    create = started()
    create.feed(oi.drive_direct(300, 300))
    create.step(1.0, wheel_travel_m=(0.0, 0.0))   # blocked by a wall
    assert create.pose == (0.0, 0.0, 0.0)
    assert query(create, 19)[19] == 0
    create.step(1.0, wheel_travel_m=(0.1, 0.12))
    assert query(create, 19)[19] == 110
    assert create.pose[2] == pytest.approx(0.02 / WHEEL_BASE_M)


def test_command_split_across_feeds():
    create = started()
    data = oi.drive_direct(120, 80)
    for byte in data[:-1]:
        create.feed(bytes([byte]))
        assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    create.feed(data[-1:])
    assert create.wheel_speed_cmd_mps == (0.12, 0.08)


def test_unknown_opcodes_are_skipped():
    create = started()
    create.feed(bytes([0, 17, 133, 146, 159, 255]) + oi.sensors(35))
    assert create.read_output() == bytes([2])
    assert create.unknown_bytes == 6


def test_random_bytes_never_raise():
    rng = random.Random(7)
    create = started(oi.full)
    for _ in range(300):
        create.feed(bytes(rng.randrange(256) for _ in range(rng.randint(1, 40))))
        create.step(rng.choice([0.0, 0.001, 0.015, 0.1]))
        create.read_output()
    assert create.mode in ("off", "passive", "safe", "full")


# ----------------------------------------------------------------------------- actuators
def test_leds():
    create = started()
    create.feed(oi.leds(True, False, 200, 17))
    assert create.leds == (True, False, 200, 17)
    create.feed(oi.leds(False, True, 0, 255))
    assert (create.leds.play, create.leds.advance) == (False, True)


def test_song_and_play():
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


def test_demo_and_abort():
    create = started(oi.full)
    create.feed(oi.drive_direct(100, 100) + oi.demo(4))
    assert create.mode == "passive" and create.last_demo == 4 and create.demo_running
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    create.feed(oi.demo(-1))
    assert create.last_demo == -1 and not create.demo_running


@pytest.mark.parametrize("opcode, demo", [(oi.SPOT, 2), (oi.COVER, 0),
                                          (oi.COVER_AND_DOCK, 1)])
def test_cleaning_demos(opcode, demo):
    create = started()
    create.feed(bytes([opcode]))
    assert create.mode == "passive" and create.last_demo == demo
    assert create.docking_requested == (opcode == oi.COVER_AND_DOCK)


def test_other_actuators():
    create = started()
    create.feed(bytes([oi.LOW_SIDE_DRIVERS, 5, oi.DIGITAL_OUTPUTS, 6, oi.SEND_IR, 42,
                       oi.PWM_LOW_SIDE_DRIVERS, 10, 128, 200, oi.BAUD, 11]))
    assert create.low_side_drivers == 5 and create.digital_outputs == 6
    assert create.sent_ir == [42] and create.pwm_low_side == (10, 128, 128)
    assert create.baud_code == 11


# ----------------------------------------------------------------------------- sensors
@pytest.mark.parametrize("pid", sorted(SPEC_SIZES) + sorted(SPEC_GROUP_SIZES))
def test_sensors_reply_size(pid):
    create = started()
    create.read_output()
    create.feed(oi.sensors(pid))
    expected = SPEC_SIZES.get(pid, SPEC_GROUP_SIZES.get(pid))
    assert len(create.read_output()) == expected


def test_sensors_unknown_id_sends_nothing():
    create = started()
    create.feed(bytes([oi.SENSORS, 43, oi.SENSORS, 100]))
    assert create.read_output() == b""


def test_query_list_order_and_size():
    create = started()
    create.feed(oi.query_list([35, 7, 6, 19]))
    assert len(create.read_output()) == 1 + 1 + 52 + 2


def test_bump_wheel_drop_cliff_wall_bits():
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


def test_distance_and_angle_reset_on_read():
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
def test_many_small_reads_are_not_biased(left, right, pid, per_s):
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


def test_distance_clamps_to_int16():
    create = started(oi.full)
    create.feed(oi.drive_direct(500, 500))
    run(create, 70.0, dt=0.1)                      # 35 m without a read
    assert query(create, 19)[19] == 32767
    create.feed(oi.drive_direct(-500, -500))
    run(create, 70.0, dt=0.1)
    assert query(create, 19)[19] == -32768


# ----------------------------------------------------------------------------- safety
def test_safe_mode_cliff_stops_forward_motion():
    create = started()
    create.feed(oi.drive_direct(200, 200))
    create.set_cliffs(front_left=True)
    assert create.mode == "passive"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert create.safety_trips == 1
    x = create.pose[0]
    run(create, 0.5)
    assert create.pose[0] == x


def test_safe_mode_allows_backing_straight_away_from_a_cliff():
    create = started()
    create.set_cliffs(front_right=True)
    create.feed(oi.drive_direct(-100, -100))
    run(create, 0.2)
    assert create.mode == "safe" and create.wheel_speed_cmd_mps == (-0.1, -0.1)
    create.feed(oi.drive_direct(100, 100))        # driving at it trips at once
    assert create.mode == "passive" and create.wheel_speed_cmd_mps == (0.0, 0.0)


@pytest.mark.parametrize("hazard", [
    lambda c: c.set_wheel_drops(left=True), lambda c: c.set_wheel_drops(caster=True),
    lambda c: c.set_charging_sources(home_base=True)])
def test_safe_mode_wheel_drop_or_charger_trips_even_when_still(hazard):
    create = started()
    hazard(create)
    assert create.mode == "passive"


def test_full_mode_ignores_cliffs_and_drops():
    create = started(oi.full)
    create.feed(oi.drive_direct(200, 200))
    create.set_cliffs(True, True, True, True)
    create.set_wheel_drops(True, True, True)
    run(create, 0.1)
    assert create.mode == "full" and create.wheel_speed_cmd_mps == (0.2, 0.2)


# ----------------------------------------------------------------------------- stream
def collect_frames(create, seconds, dt):
    parser = oi.StreamParser()
    frames = []
    for _ in range(int(round(seconds / dt))):
        create.step(dt)
        frames += parser.feed(create.read_output())
    return frames, parser


@pytest.mark.parametrize("dt", [0.001, 0.005, 0.015, 0.05, 0.1])
def test_stream_sends_a_frame_every_15_ms(dt):
    create = started()
    create.feed(oi.stream([7, 19, 35]))
    frames, parser = collect_frames(create, 3.0, dt)
    assert len(frames) == 200                      # 3 s / 15 ms
    assert parser.bad_checksum == 0 and parser.dropped_bytes == 0
    assert all(set(f) == {7, 19, 35} for f in frames)


def test_stream_frame_bytes():
    create = started()
    create.set_cliffs(left=True)
    create.feed(oi.stream([29, 13]))
    run(create, 0.015)
    frame = create.read_output()
    signal = query(create, 29)[29]
    body = [29, signal >> 8, signal & 0xFF, 13, 0]
    head = [19, len(body)]
    assert frame == bytes(head + body + [(-sum(head + body)) & 0xFF])


def test_stream_of_a_group_carries_the_group_id():
    create = started()
    create.feed(oi.stream([2]))
    run(create, 0.015)
    frame = create.read_output()
    assert frame[:3] == bytes([19, 1 + 6, 2]) and len(frame) == 3 + 7
    assert sum(frame) % 256 == 0


def test_stream_distance_sums_to_travel():
    create = started()
    create.feed(oi.stream([19, 20]) + oi.drive(150, 1000))
    frames, _ = collect_frames(create, 6.0, 0.005)
    assert sum(f[19] for f in frames) == pytest.approx(900, abs=1)
    assert sum(f[20] for f in frames) == pytest.approx(math.degrees(0.9 / 1.0), abs=1)


def test_pause_resume_and_empty_stream():
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


def test_power_cycle_stops_everything_until_start_and_stream_again():
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


def test_stream_frame_never_exceeds_255_data_bytes():
    create = started()
    create.feed(bytes([oi.STREAM, 10] + [6] * 10))  # 10 x 53 bytes requested
    run(create, 0.015)
    frame = create.read_output()
    assert frame[0] == 19 and frame[1] == 4 * 53 and len(frame) == 3 + 4 * 53
    assert sum(frame) % 256 == 0


# ----------------------------------------------------------------------------- scripts, waits
def test_spec_example_script_drive_40_cm_and_stop():
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


def test_wait_time_and_wait_event():
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


def test_wait_angle():
    create = started()
    create.feed(oi.drive(100, 1) + bytes([oi.WAIT_ANGLE]) + raw16(90) + oi.drive(0, 0))
    run(create, 10.0, dt=0.001)
    assert create.pose[2] == pytest.approx(math.pi / 2, abs=math.radians(0.1))


# ----------------------------------------------------------------------------- battery
def test_battery_drains_faster_with_motors():
    idle, moving = started(), started()
    moving.feed(oi.drive_direct(500, 500))
    run(idle, 60.0, dt=0.1)
    run(moving, 60.0, dt=0.1)
    used_idle = 2700.0 - idle.battery.charge_mah
    used_moving = 2700.0 - moving.battery.charge_mah
    assert 0 < used_idle < used_moving
    values = query(moving, 3)
    assert values[23] < query(idle, 23)[23] < 0   # discharging: negative current [mA]
    assert values[25] < 2700 and values[26] == 2700 and values[21] == 0
    assert query(moving, 22)[22] < query(idle, 22)[22] <= 16500


def test_battery_charges_on_the_home_base_and_empty_stops_motors():
    create = started(oi.full, initial_charge_mah=1000.0)
    create.set_charging_sources(home_base=True)
    run(create, 10.0, dt=0.1)
    values = query(create, 3)
    assert values[21] == 2 and values[23] > 0 and create.battery.charge_mah > 1000.0
    empty = started(oi.full, initial_charge_mah=0.001)
    empty.feed(oi.drive_direct(300, 300))
    run(empty, 1.0)
    assert empty.wheel_speed_cmd_mps == (0.0, 0.0)
    empty.feed(oi.drive_direct(300, 300))
    assert empty.wheel_speed_cmd_mps == (0.0, 0.0)


# ----------------------------------------------------------------------------- pty link
def wait_for(predicate, timeout_s=5.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met within %.1f s" % timeout_s)
        time.sleep(0.001)


def read_reply(link, port, n, timeout_s=5.0):
    got = bytearray()

    def done():
        link.pump()
        got.extend(port.read(n - len(got)))
        return len(got) >= n
    wait_for(done, timeout_s)
    return bytes(got)


@pytest.fixture
def link_path(tmp_path):
    return str(tmp_path / "ttyCreate")


def test_pty_end_to_end_with_pyserial(link_path):
    create = VirtualCreate()
    with PtyLink(create, link_path) as link:
        assert os.path.realpath(link.port) == link.tty_path
        with serial.Serial(link.port, 57600, timeout=0) as port:
            port.write(oi.start() + oi.safe() + oi.drive(200, oi.STRAIGHT_RADIUS)
                       + oi.sensors(6))
            reply = read_reply(link, port, 52)
            values = oi.decode_packets([6], reply)
            assert values[35] == 2 and values[39] == 200 and values[40] == -32768
            assert create.wheel_speed_cmd_mps == (0.2, 0.2)


def test_pty_is_raw_both_ways(link_path):
    """The host opens the port WITHOUT configuring it (plain os.open, unlike pyserial,
    which sets raw mode itself): every byte must pass unchanged, nothing may echo back."""
    special = bytes([0x0D, 0x0A, 0x03, 0x04, 0x11, 0x13, 0x1A, 0x7F, 0xFF, 0x00])

    class Recorder:
        def __init__(self):
            self.got = bytearray()

        def feed(self, data):
            self.got.extend(data)

        def read_output(self):
            return b""

    rec = Recorder()
    with PtyLink(rec, link_path) as link:
        host = os.open(link.port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            os.write(host, special)
            wait_for(lambda: link.pump() and len(rec.got) >= len(special))
            assert bytes(rec.got) == special       # no CR/LF translation, no signals
            assert link.inject(special) == len(special)
            got = bytearray()

            def host_read():
                try:
                    got.extend(os.read(host, 100))
                except BlockingIOError:
                    pass
                return len(got) >= len(special)
            wait_for(host_read)
            assert bytes(got) == special
            link.pump()
            assert bytes(rec.got) == special       # the robot's bytes were not echoed
        finally:
            os.close(host)


def test_reopen_keeps_the_symlink_and_drops_the_old_port(link_path):
    create = VirtualCreate()
    link = PtyLink(create, link_path)
    try:
        port = serial.Serial(link.port, 57600, timeout=0)
        link.reopen()
        assert link.port == link_path and os.path.realpath(link_path) == link.tty_path
        assert link.opens == 2
        with pytest.raises(serial.SerialException):   # the "unplugged" adapter is gone
            port.write(oi.start())
            port.read(1)
        port.close()
        with serial.Serial(link.port, 57600, timeout=0) as port2:
            port2.write(oi.start() + oi.sensors(35))
            assert read_reply(link, port2, 1) == bytes([1])
        link.close()
        assert not os.path.lexists(link_path)
        assert link.pump() == (0, 0)
    finally:
        link.close()


def test_stale_symlink_is_replaced_but_a_file_is_not(link_path, tmp_path):
    os.symlink("/dev/pts/does-not-exist", link_path)
    with PtyLink(VirtualCreate(), link_path) as link:
        assert os.readlink(link_path) == link.tty_path
    regular = str(tmp_path / "regular")
    with open(regular, "w") as handle:
        handle.write("keep me")
    with pytest.raises(FileExistsError):
        PtyLink(VirtualCreate(), regular)
    with open(regular) as handle:
        assert handle.read() == "keep me"


def test_no_blocking_when_nobody_reads():
    create = started()
    create.feed(oi.stream([6]))                    # 56-byte frame every 15 ms
    link = PtyLink(create)
    result = {}

    def flood():
        link.inject(bytes(1 << 20))                # 1 MiB of robot->host bytes
        for _ in range(4000):                      # 60 s of emulated stream
            create.step(0.015)
            link.pump()
        result["done"] = True

    worker = threading.Thread(target=flood, daemon=True)
    worker.start()
    worker.join(timeout=60.0)
    try:
        assert not worker.is_alive(), "pump() or inject() blocked"
        assert result.get("done")
        assert link.dropped_bytes > 0
        assert link.bytes_out + link.dropped_bytes == (1 << 20) + 4000 * 56
    finally:
        link.close()


def test_host_commands_reach_the_emulator_while_it_streams(link_path):
    create = VirtualCreate()
    with PtyLink(create, link_path) as link:
        with serial.Serial(link.port, 57600, timeout=0) as port:
            port.write(oi.start() + oi.full() + oi.stream([19]) + oi.drive_direct(100, 100))
            parser = oi.StreamParser([19])
            frames = []

            def enough():
                link.pump()
                create.step(0.015)
                link.pump()
                frames.extend(parser.feed(port.read(4096)))
                return len(frames) >= 100
            wait_for(enough, 20.0)
            assert parser.bad_checksum == 0
            assert all(f[19] in (1, 2) for f in frames[1:])   # 1.5 mm per frame, carried
