"""Tests of the driver's pure logic: kinematics, odometry, watchdog, bump rule, decoding."""
import math

import pytest

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.driver_core import CreateDriverCore, StreamClock
from irobot_create_2_1.kinematics import twist_to_wheels, wheels_to_twist
from irobot_create_2_1.odometry import Odometry, integrate_arc
from irobot_create_2_1.sensor_state import battery_si, brown_fields

B = 0.258


def test_twist_to_wheels_basic():
    cmd = twist_to_wheels(0.2, 0.0, B)
    assert (cmd.left_mm_s, cmd.right_mm_s, cmd.saturated) == (200, 200, False)
    cmd = twist_to_wheels(0.0, 1.0, B)
    assert (cmd.left_mm_s, cmd.right_mm_s) == (-129, 129)
    v, w = wheels_to_twist(-0.129, 0.129, B)
    assert v == pytest.approx(0.0) and w == pytest.approx(1.0)


def test_saturation_keeps_turn_ratio():
    cmd = twist_to_wheels(0.6, 2.0, B)
    assert cmd.saturated
    assert max(abs(cmd.left_mm_s), abs(cmd.right_mm_s)) == 500
    v, w = wheels_to_twist(cmd.left_mm_s / 1000, cmd.right_mm_s / 1000, B)
    assert w / v == pytest.approx(2.0 / 0.6, rel=0.01)


@pytest.mark.parametrize("v,w", [(math.nan, 0.0), (0.1, math.inf), (-math.inf, 0.0)])
def test_non_finite_twist_rejected(v, w):
    with pytest.raises(ValueError):
        twist_to_wheels(v, w, B)


def test_arc_integration_closes_a_circle():
    x = y = th = 0.0
    n = 1000
    radius = 0.5
    for _ in range(n):
        x, y, th = integrate_arc(x, y, th, 2 * math.pi * radius / n, 2 * math.pi / n)
    assert abs(x) < 1e-9 and abs(y) < 1e-9


def test_odometry_backwards_is_negative_x():
    odom = Odometry()
    odom.update(-0.5, 0.0)
    assert odom.x == pytest.approx(-0.5)
    odom.update(0.0, math.pi / 2)
    odom.update(0.3, 0.0)
    assert odom.y == pytest.approx(0.3)


def test_odometry_covariance_grows_with_travel():
    odom = Odometry()
    cov0 = odom.pose_covariance()
    odom.update(1.0, 0.0)
    cov1 = odom.pose_covariance()
    odom.update(1.0, 0.5)
    cov2 = odom.pose_covariance()
    for i in (0, 7, 35):
        assert cov0[i] < cov1[i] < cov2[i]


def frame(distance_mm=0, angle_deg=0, bumps=0):
    values = {pid: 0 for pid in oi.PACKETS}
    values.update({7: bumps, 19: distance_mm, 20: angle_deg, 22: 16000, 25: 2000, 26: 2700})
    return oi.frame_stream_packets([6], values)


def test_core_integrates_frames_and_reports_fields():
    core = CreateDriverCore(wheel_base_m=B)
    data = b"".join(frame(10, 0) for _ in range(100))
    frames = core.on_bytes(data, now=1.0)
    assert len(frames) == 100
    assert core.odom.x == pytest.approx(1.0)
    core.on_bytes(b"".join(frame(0, 1) for _ in range(90)), now=2.0)
    assert math.degrees(core.odom.theta) == pytest.approx(90.0)
    fields = brown_fields(core.values)
    assert fields["voltage"] == 16000 and fields["bumpLeft"] is False
    b = battery_si(core.values)
    assert b["voltage_v"] == pytest.approx(16.0)
    assert b["percentage"] == pytest.approx(2000 / 2700)


def test_linear_scale_correction_scales_distance_not_angle_or_raw_fields():
    core = CreateDriverCore(wheel_base_m=B, linear_scale=0.996)
    core.on_bytes(b"".join(frame(10, 0) for _ in range(100)), now=1.0)   # 1 m reported
    assert core.odom.x == pytest.approx(0.996)
    assert brown_fields(core.values)["distance"] == 10  # sensorPacket: the raw 10 mm per frame
    core.on_bytes(b"".join(frame(0, 1) for _ in range(90)), now=2.0)
    assert math.degrees(core.odom.theta) == pytest.approx(90.0)
    for bad in (0.0, 0.5, 1.6, math.nan):
        with pytest.raises(ValueError, match="linear_scale"):
            CreateDriverCore(wheel_base_m=B, linear_scale=bad)


def test_corrupt_frames_never_reach_odometry():
    core = CreateDriverCore(wheel_base_m=B)
    bad = bytearray(frame(500, 0))
    bad[10] ^= 0xFF
    core.on_bytes(bytes(bad) * 3 + frame(10, 0), now=0.0)
    assert core.odom.x == pytest.approx(0.01)
    assert core.parser.bad_checksum >= 3


def test_init_sequence_starts_stream():
    core = CreateDriverCore(mode="full")
    seq = core.init_sequence()
    assert seq.startswith(bytes([128, 132]))
    assert seq.endswith(oi.stream([6]))


def test_watchdog_stops_stale_commands():
    core = CreateDriverCore(wheel_base_m=B, cmd_timeout_s=0.5)
    assert core.command_bytes(0.0) == oi.drive_direct(0, 0)
    core.set_twist(0.2, 0.0, now=1.0)
    assert core.command_bytes(1.0) == oi.drive_direct(200, 200)
    assert core.command_bytes(1.2) is None  # unchanged, not yet due for a resend
    assert core.command_bytes(1.6) == oi.drive_direct(0, 0)
    assert core.watchdog_stops == 1


def test_nan_twist_stops_robot():
    core = CreateDriverCore(wheel_base_m=B)
    core.set_twist(0.3, 0.0, now=0.0)
    assert core.target_wheels(0.1) == (300, 300)
    warning = core.set_twist(math.nan, 0.0, now=0.2)
    assert "rejected" in warning
    assert core.target_wheels(0.2) == (0, 0)
    assert core.rejected_cmds == 1


def test_bump_stops_forward_but_allows_turning_and_reversing():
    core = CreateDriverCore(wheel_base_m=B, stop_on_bump=True)
    core.on_bytes(frame(bumps=oi.BUMP_LEFT), now=0.0)
    core.set_twist(0.2, 0.0, now=0.0)
    assert core.target_wheels(0.0) == (0, 0)
    core.set_twist(0.2, 1.0, now=0.0)
    assert core.target_wheels(0.0) == (-129, 129)
    core.set_twist(-0.1, 0.0, now=0.0)
    assert core.target_wheels(0.0) == (-100, -100)
    core_off = CreateDriverCore(wheel_base_m=B, stop_on_bump=False)
    core_off.on_bytes(frame(bumps=oi.BUMP_RIGHT), now=0.0)
    core_off.set_twist(0.2, 0.0, now=0.0)
    assert core_off.target_wheels(0.0) == (200, 200)


def test_bad_parameters_refused():
    with pytest.raises(ValueError):
        CreateDriverCore(mode="passive")
    with pytest.raises(ValueError):
        CreateDriverCore(cmd_timeout_s=0.0)


# --- frame time stamps (StreamClock) -------------------------------------------------------
P = oi.STREAM_PERIOD_S


def test_stream_clock_on_time_frames_keep_their_arrival_times():
    clock = StreamClock()
    for k in range(200):
        (stamp,) = clock.stamps(1, 10.0 + k * P)
        assert stamp == pytest.approx(10.0 + k * P, abs=1e-9)


def test_stream_clock_spreads_a_backlog_over_the_cadence():
    # frames every 15 ms; the reader is starved for 1 s and then gets 67 frames at once
    clock = StreamClock()
    for k in range(20):
        clock.stamps(1, k * P)
    produced = [(20 + i) * P for i in range(67)]
    stamps = clock.stamps(67, produced[-1])
    assert stamps == pytest.approx(produced, abs=1e-9)
    # read-time stamping would have put the first of them 1 s late
    assert produced[-1] - produced[0] > 0.9


def test_stream_clock_stamps_never_decrease_and_restart_when_time_goes_back():
    clock = StreamClock()
    clock.stamps(1, 1.0)
    assert clock.stamps(10, 1.0 + P) == pytest.approx([1.0] * 9 + [1.0 + P])
    assert clock.stamps(2, 0.5) == pytest.approx([0.5 - P, 0.5])   # simulator restarted
    assert clock.resets == 1


def test_stream_clock_never_stamps_before_time_zero():
    # A backlog read at the start of a simulated clock (seen in a benchmark run: the reader
    # thread died on rospy.Time's "time values must be positive", the robot had no odometry)
    clock = StreamClock()
    stamps = clock.stamps(10, 0.03)
    assert min(stamps) == 0.0 and stamps[-1] == pytest.approx(0.03)
    assert stamps == sorted(stamps)
    assert StreamClock().stamps(3, 0.0) == [0.0, 0.0, 0.0]  # read before /clock started


def test_stream_clock_stamps_never_decrease_under_jitter():
    import random
    rng = random.Random(3)
    clock = StreamClock()
    produced, last = 0.0, -1.0
    for _ in range(2000):
        n = rng.choice([1, 1, 1, 2, 3, 30])
        produced += n * P
        stamps = clock.stamps(n, produced + rng.uniform(0.0, 0.01))
        assert stamps == sorted(stamps) and stamps[0] >= last
        last = stamps[-1]


def test_core_stamps_a_burst_along_the_cadence():
    core = CreateDriverCore(wheel_base_m=B)
    core.on_bytes(frame(10, 0), now=1.0)
    core.on_bytes(b"".join(frame(10, 0) for _ in range(40)), now=1.8)
    assert core.last_frame_time == pytest.approx(1.8)
    assert core.last_frame_stamp == pytest.approx(1.8)
    assert core.frame_poses[0][0] == pytest.approx(1.8 - 39 * P)


def test_core_keeps_the_pose_after_each_frame_of_a_burst():
    core = CreateDriverCore(wheel_base_m=B)
    core.on_bytes(frame(0, 0), now=2.0)
    core.on_bytes(b"".join(frame(10, 1) for _ in range(30)), now=2.0 + 30 * P)
    stamps = [s for s, _ in core.frame_poses]
    assert stamps == pytest.approx([2.0 + (i + 1) * P for i in range(30)], abs=1e-3)
    xs = [pose[0] for _, pose in core.frame_poses]
    assert xs == sorted(xs) and xs[-1] == pytest.approx(core.odom.x)
    assert math.degrees(core.frame_poses[9][1][2]) == pytest.approx(10.0)


def test_warning_kind():
    core = CreateDriverCore()
    assert core.set_twist(0.1, 0.0, now=0.0) is None and core.warning_kind is None
    assert core.set_twist(2.0, 0.0, now=0.0) and core.warning_kind == "saturated"
    assert core.set_twist(math.nan, 0.0, now=0.0) and core.warning_kind == "rejected"
    assert core.set_wheels(0.1, 0.1, now=0.0) is None and core.warning_kind is None


def test_frame_bytes_is_the_length_of_a_stream_frame():
    from irobot_create_2_1.models import CREATE_2
    assert CreateDriverCore(wheel_base_m=B).frame_bytes == len(frame()) == 56
    c2 = {pid: 0 for pid in oi.PACKETS}
    assert CreateDriverCore(robot=CREATE_2).frame_bytes == len(
        oi.frame_stream_packets([100], c2))


def test_event_key_changes_with_a_bump_not_with_odometry():
    core = CreateDriverCore(wheel_base_m=B)
    core.on_bytes(frame(10, 0), now=0.0)
    key = core.event_key()
    core.on_bytes(frame(20, 3), now=0.015)   # moving: odometry and angle change
    assert core.event_key() == key
    core.on_bytes(frame(0, 0, bumps=oi.BUMP_LEFT), now=0.03)
    assert core.event_key() != key
