"""Tests of the emulated Create's state and physics (irobot_create_2_1.create_state):
kinematics of Drive, pose integration, safe-mode safety and the battery.

Expected values come from the iRobot Create Open Interface specification (sizes, bits,
special radii, 15 ms stream period, group layout) and from kinematics worked out here, not
from the emulator's own tables. No ROS master needed; `started`, `query`, `run` and
`collect_frames` are fixtures of conftest.py.
"""

import math

import pytest

from irobot_create_2_1 import protocol as oi
from irobot_create_2_1.create_state import CreateState

WHEEL_BASE_M = 0.258


def raw16(value):
    """Two bytes, big-endian two's complement (to send out-of-range values on purpose)."""
    return (value & 0xFFFF).to_bytes(2, "big")


def test_drive_spin_in_place(started, run):
    create = started()
    create.feed(oi.drive(200, -1))                # clockwise: left forward, right back
    assert create.wheel_speed_cmd_mps == (0.2, -0.2)
    run(create, 0.5)
    assert create.pose[2] < 0
    create.feed(oi.drive(200, 1))                 # counter-clockwise
    assert create.wheel_speed_cmd_mps == (-0.2, 0.2)


@pytest.mark.parametrize("velocity, radius", [(200, 500), (-200, 500), (300, -400),
                                              (100, 2000), (250, -1000)])
def test_drive_arc_wheel_speeds(velocity, radius, started):
    create = started()
    create.feed(oi.drive(velocity, radius))
    left, right = create.wheel_speed_cmd_mps
    # centre speed = velocity; curvature (right - left) / b = 1 / radius, + = left turn
    assert 0.5 * (left + right) == pytest.approx(velocity / 1000.0)
    assert (right - left) / WHEEL_BASE_M == pytest.approx(velocity / radius)


def test_wheel_saturation(started, query):
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


def test_pose_follows_an_arc(started, run):
    create = started()
    create.feed(oi.drive(200, 500))               # quarter circle of radius 0.5 m
    quarter_s = (math.pi / 2 * 0.5) / 0.2
    run(create, quarter_s, dt=quarter_s / 400)
    x, y, theta = create.pose
    assert (x, y) == pytest.approx((0.5, 0.5), abs=1e-6)
    assert theta == pytest.approx(math.pi / 2, abs=1e-6)


def test_wheel_travel_from_the_simulator_overrides_the_command(started, query):
    create = started()
    create.feed(oi.drive_direct(300, 300))
    create.step(1.0, wheel_travel_m=(0.0, 0.0))   # blocked by a wall
    assert create.pose == (0.0, 0.0, 0.0)
    assert query(create, 19)[19] == 0
    create.step(1.0, wheel_travel_m=(0.1, 0.12))
    assert query(create, 19)[19] == 110
    assert create.pose[2] == pytest.approx(0.02 / WHEEL_BASE_M)


def test_safe_mode_cliff_stops_forward_motion(started, run):
    create = started()
    create.feed(oi.drive_direct(200, 200))
    create.set_cliffs(front_left=True)
    assert create.mode == "passive"
    assert create.wheel_speed_cmd_mps == (0.0, 0.0)
    assert create.safety_trips == 1
    x = create.pose[0]
    run(create, 0.5)
    assert create.pose[0] == x


def test_safe_mode_allows_backing_straight_away_from_a_cliff(started, run):
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
def test_safe_mode_wheel_drop_or_charger_trips_even_when_still(hazard, started):
    create = started()
    hazard(create)
    assert create.mode == "passive"


def test_full_mode_ignores_cliffs_and_drops(started, run):
    create = started(oi.full)
    create.feed(oi.drive_direct(200, 200))
    create.set_cliffs(True, True, True, True)
    create.set_wheel_drops(True, True, True)
    run(create, 0.1)
    assert create.mode == "full" and create.wheel_speed_cmd_mps == (0.2, 0.2)


def test_battery_drains_faster_with_motors(started, query, run):
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


def test_battery_charges_on_the_home_base_and_empty_stops_motors(started, query, run):
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


# ----------------------------------------------------------------------------- the state alone
def test_create_state_drives_integrates_and_trips_without_bytes():
    state = CreateState()
    state.enter_safe()
    state.drive(200, 500)                       # an arc of 0.5 m to the left
    left, right = state.wheel_speed_cmd_mps
    assert (right - left) / WHEEL_BASE_M == pytest.approx(0.2 / 0.5)
    distance_mm, angle_deg = state.advance_physics(0.5, None)
    assert distance_mm == pytest.approx(100.0)
    assert angle_deg == pytest.approx(math.degrees(0.1 / 0.5))
    assert (state.read_distance(), state.read_distance()) == (100, 0)
    state.set_cliffs(front_left=True)           # moving forward at a cliff: safe mode trips
    assert state.mode == "passive" and state.wheel_speed_cmd_mps == (0.0, 0.0)
    assert state.safety_trips == 1
