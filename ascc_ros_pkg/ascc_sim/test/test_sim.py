"""The stepping core with the real virtual Create: kinematics, collisions and bumpers,
encoder noise against ground truth, determinism, scans of other robots and people."""
import math
import os

import numpy as np
import pytest

from ascc_common.grid import OCCUPIED, GridInfo
from ascc_common.params import ParamError, from_params
from ascc_sim.grid import GridMap
from ascc_sim.runner import SimRunner, SimulatorParams
from ascc_sim.sim import RobotModel, Simulation, integrate_arc, select_robots
from ascc_sim.world import PersonSpec, Pose2D, RobotSpec, Waypoint, World, load_world
from irobot_create_2_1 import protocol
from irobot_create_2_1.models import CREATE_2
from irobot_create_2_1.virtual_create import VirtualCreate

NOISELESS = RobotModel(encoder_scale_sigma=0.0, encoder_noise_m_per_sqrt_m=0.0)


def box_world(robots, size=(8.0, 6.0), people=(), res=0.05):
    """A walled room [0, size] (walls one cell thick), robots [(name, x, y, yaw)]."""
    w, h = int(round(size[0] / res)), int(round(size[1] / res))
    occ = np.zeros((h, w), dtype=np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = OCCUPIED
    grid = GridMap(occ, GridInfo(res, w, h))
    specs = [RobotSpec(n, n if len(robots) > 1 else "", Pose2D(x, y, yaw))
             for n, x, y, yaw in robots]
    return World("/tmp/box.yaml", "box", "/tmp/box_map.yaml", grid, specs, [], list(people))


def started_create():
    c = VirtualCreate()
    c.feed(protocol.start() + protocol.full())
    return c


def drive(create, left_mm_s, right_mm_s):
    create.feed(protocol.drive_direct(left_mm_s, right_mm_s))


def run(sim, seconds, dt=0.01):
    for _ in range(int(round(seconds / dt))):
        sim.step(dt)


def read_bumps_and_odometry(create):
    """What a driver would read: (bump_left, bump_right, distance_mm, angle_deg)."""
    create.feed(protocol.query_list([7, 19, 20]))
    out = create.read_output()
    v = protocol.decode_packets([7, 19, 20], out)
    return bool(v[7] & 2), bool(v[7] & 1), v[19], v[20]


def test_integrate_arc_exact():
    # Quarter circle of radius 1 m: left wheel on radius 1 - b/2, right on 1 + b/2.
    b = 0.258
    x, y, th = integrate_arc(0.0, 0.0, 0.0, (1 - b / 2) * math.pi / 2,
                             (1 + b / 2) * math.pi / 2, b)
    assert (x, y, th) == (pytest.approx(1.0), pytest.approx(1.0), pytest.approx(math.pi / 2))
    assert integrate_arc(1.0, 2.0, 0.3, 0.2, 0.2, b) == pytest.approx(
        (1.0 + 0.2 * math.cos(0.3), 2.0 + 0.2 * math.sin(0.3), 0.3))


def test_straight_drive_matches_create_odometry_without_noise():
    world = box_world([("r", 1.0, 3.0, 0.0)])
    c = started_create()
    sim = Simulation(world, {"r": c}, NOISELESS)
    drive(c, 200, 200)
    run(sim, 10.0)
    r = sim.robot("r")
    # 0.2 m/s for 10 s minus the acceleration ramp (0.2 / 2.0 s at about half speed;
    # the ramp is stepped, hence the tolerance).
    assert r.x == pytest.approx(1.0 + 0.2 * 10.0 - 0.2 * 0.1 / 2, abs=2e-3)
    assert r.y == pytest.approx(3.0) and r.yaw == pytest.approx(0.0)
    assert not (r.bump_left or r.bump_right or r.blocked)
    # The Create integrated exactly the travel the core gave it (its frame starts at 0).
    cx, cy, cth = c.pose
    assert (cx, cy, cth) == (pytest.approx(r.x - 1.0), pytest.approx(0.0), pytest.approx(0.0))
    _, _, dist_mm, _ = read_bumps_and_odometry(c)
    assert dist_mm == pytest.approx(1000.0 * (r.x - 1.0), abs=1.0)


def test_spin_in_place():
    world = box_world([("r", 4.0, 3.0, 0.0)])
    c = started_create()
    sim = Simulation(world, {"r": c}, NOISELESS)
    drive(c, -129, 129)  # 0.129 m/s per wheel on a 0.258 m base: 1 rad/s
    run(sim, 2.0)
    r = sim.robot("r")
    assert (r.x, r.y) == (pytest.approx(4.0), pytest.approx(3.0))
    ramp_s = 0.129 / 2.0  # wheel speed / acceleration
    assert r.yaw == pytest.approx(2.0 - ramp_s / 2, abs=6e-3)  # 1 rad/s, minus the ramp
    assert r.w == pytest.approx(1.0, rel=1e-3)


def test_create2_robot_turns_on_its_own_wheel_base_and_counts_encoders():
    world = box_world([("r", 4.0, 3.0, 0.0)])
    c = VirtualCreate(robot=CREATE_2)
    c.feed(protocol.start() + protocol.full())
    sim = Simulation(world, {"r": c}, NOISELESS)
    drive(c, -235, 235)  # 0.235 m/s per wheel on the Create 2's 0.235 m base: 2 rad/s
    run(sim, 1.0)
    r = sim.robot("r")
    assert r.w == pytest.approx(2.0, rel=1e-3)
    c.feed(protocol.query_list([43, 44], protocol.CREATE_2_IDS))
    left, right = protocol.decode_packets([43, 44], c.read_output()).values()
    counts = r.yaw * 0.235 / 2 / CREATE_2.metres_per_count   # each wheel's arc [counts]
    assert right == pytest.approx(counts, abs=1.0) and left == pytest.approx(-counts, abs=1.0)


def test_wall_stops_robot_and_presses_both_bumpers():
    world = box_world([("r", 6.0, 3.0, 0.0)])
    c = started_create()
    sim = Simulation(world, {"r": c}, NOISELESS)
    drive(c, 300, 300)
    run(sim, 7.0)  # the east wall's face is at x = 8 - 0.05 = 7.95
    r = sim.robot("r")
    assert r.x <= 7.95 - 0.165 + 1e-9  # never inside the wall
    assert r.x > 7.95 - 0.165 - 0.002  # but right against it
    assert r.bump_left and r.bump_right and r.blocked
    assert r.v == pytest.approx(0.0, abs=1e-3)
    bl, br, dist_mm, _ = read_bumps_and_odometry(c)
    assert bl and br
    x_before = r.x
    run(sim, 1.0)  # pushing on: no motion, no odometry
    assert r.x == pytest.approx(x_before, abs=1e-9)
    assert read_bumps_and_odometry(c)[2] == 0
    # Backing off releases the bumper.
    drive(c, -100, -100)
    run(sim, 0.5)
    assert r.x < x_before - 0.02
    assert not (r.bump_left or r.bump_right)
    assert read_bumps_and_odometry(c)[:2] == (False, False)


def test_oblique_contact_presses_one_bumper_and_turning_is_free():
    world = box_world([("r", 7.0, 3.0, math.radians(45.0))])  # east wall on the right
    c = started_create()
    sim = Simulation(world, {"r": c}, NOISELESS)
    drive(c, 200, 200)
    run(sim, 7.0)
    r = sim.robot("r")
    assert r.blocked and r.bump_right and not r.bump_left
    assert r.x <= 7.95 - 0.165 + 1e-9
    drive(c, 100, -100)  # spinning in place against the wall is possible
    yaw0 = r.yaw
    run(sim, 0.5)
    assert r.yaw < yaw0 - 0.2


def test_robots_block_each_other_and_see_each_other():
    world = box_world([("a", 2.0, 3.0, 0.0), ("b", 3.0, 3.0, math.pi)])
    ca, cb = started_create(), started_create()
    sim = Simulation(world, {"a": ca, "b": cb}, NOISELESS)
    ranges = sim.true_scan("a")
    front = np.argmin(np.abs(sim.laser.angles))
    # a's laser is 0.05 m ahead of its centre; b's body starts 0.165 m before b's centre.
    assert ranges[front] == pytest.approx(1.0 - 0.05 - 0.165, abs=1e-4)  # beam at -0.12 deg
    drive(ca, 200, 200)
    run(sim, 5.0)
    a, b = sim.robot("a"), sim.robot("b")
    assert math.hypot(a.x - b.x, a.y - b.y) >= 0.33 - 1e-9
    assert a.bump_left and a.bump_right
    assert (b.x, b.y) == (3.0, 3.0)


def test_encoder_noise_makes_odometry_drift_deterministically():
    def final(seed):
        world = box_world([("r", 1.0, 1.0, 0.0)], size=(10.0, 10.0))
        c = started_create()
        sim = Simulation(world, {"r": c}, RobotModel(), seed=seed)
        drive(c, 250, 250)
        run(sim, 20.0)  # about 5 m
        r = sim.robot("r")
        cx, cy, _ = c.pose
        return (r.x - 1.0, r.y - 1.0), (cx, cy)

    (tx, ty), (ox, oy) = final(1)
    assert (tx, ty) == (pytest.approx(5.0 - 0.25 * 0.125 / 2, abs=2e-3), pytest.approx(0.0))
    err = math.hypot(ox - tx, oy - ty)
    assert 1e-4 < err < 0.5  # odometry drifts, but like a robot, not like a random walk
    assert final(1) == final(1)
    assert final(2)[1] != final(1)[1]


def test_select_robots():
    world = box_world([("robotA", 1, 1, 0), ("robotB", 3, 3, 0)])
    assert [r.name for r in select_robots(world, [])] == ["robotA", "robotB"]
    assert [r.name for r in select_robots(world, ["robotB"])] == ["robotB"]
    with pytest.raises(KeyError) as info:
        select_robots(world, ["/"])
    assert "no robot with namespace /" in str(info.value)


def test_person_is_seen_and_blocks():
    walker = PersonSpec("p", (Waypoint(2.0, 1.0, 0.0, ""), Waypoint(2.0, 5.0, 0.0, "")), 0.5,
                        0.2, 1.75, False, 0.0, (1.0, 0.5, 0.0))
    world = box_world([("r", 0.8, 3.0, 0.0)], people=[walker])
    c = started_create()
    sim = Simulation(world, {"r": c}, NOISELESS)
    front = np.argmin(np.abs(sim.laser.angles))
    assert math.isinf(sim.true_scan("r")[front])  # the wall is 7.1 m away: no return
    run(sim, 4.0)  # the person is at (2, 3): right in front
    assert sim.people_states[0].y == pytest.approx(3.0)
    assert sim.true_scan("r")[front] == pytest.approx(2.0 - 0.2 - 0.85, abs=1e-3)


def test_same_seed_same_run():
    def trace(seed):
        world = box_world([("r", 2.0, 2.0, 0.3)])
        c = started_create()
        sim = Simulation(world, {"r": c}, RobotModel(), seed=seed)
        drive(c, 150, 220)
        out = []
        for _ in range(5):
            run(sim, 0.5)
            out.append(sim.scan("r"))
        r = sim.robot("r")
        return (r.x, r.y, r.yaw, c.pose), np.array(out)

    a, b = trace(4), trace(4)
    assert a[0] == b[0] and np.allclose(a[1], b[1], rtol=0, atol=0, equal_nan=True)
    assert not np.allclose(trace(5)[1], a[1], rtol=0, atol=0, equal_nan=True)


class FakeLink:
    def __init__(self):
        self.pumps = 0

    def pump(self):
        self.pumps += 1


def test_runner_schedules_in_sim_time_and_paces():
    world = box_world([("r", 2.0, 2.0, 0.0)])
    sim = Simulation(world, {"r": started_create()}, NOISELESS)
    wall = [0.0]
    slept = []

    def sleep(s):
        slept.append(s)
        wall[0] += s

    link = FakeLink()
    runner = SimRunner(sim, {"r": link}, 0.01, real_time_factor=2.0, max_sim_time_s=3.0,
                       wall_clock=lambda: wall[0], sleep=sleep)
    scans, clocks = [], []
    runner.every(0.1, scans.append)
    runner.every(0.01, clocks.append)
    runner.start()
    while not runner.done:
        wall[0] += 0.001  # each step costs 1 ms of wall time
        runner.step()
    assert runner.steps == 300 and link.pumps == 300
    assert len(scans) == 31 and scans[0] == 0.0 and scans[-1] == pytest.approx(3.0)
    assert np.allclose(np.diff(scans), 0.1)
    assert len(clocks) == 301
    # Paced to 2x real time: 3 s of sim time took 1.5 s of wall time.
    assert wall[0] == pytest.approx(1.5, abs=0.002)
    assert runner.achieved_real_time_factor() == pytest.approx(2.0, rel=0.01)


def test_runner_unpaced_and_catch_up():
    world = box_world([("r", 2.0, 2.0, 0.0)])
    sim = Simulation(world, {"r": started_create()}, NOISELESS)
    wall = [0.0]
    runner = SimRunner(sim, {}, 0.01, real_time_factor=0.0, wall_clock=lambda: wall[0],
                       sleep=lambda s: pytest.fail("must not sleep"))
    runner.start()
    for _ in range(10):
        wall[0] += 0.001
        runner.step()
    assert runner.achieved_real_time_factor() == pytest.approx(10.0)
    # A paced runner that fell far behind restarts its pacing instead of bursting.
    runner2 = SimRunner(sim, {}, 0.01, real_time_factor=1.0, wall_clock=lambda: wall[0],
                        sleep=lambda s: None)
    runner2.start()
    wall[0] += 5.0
    runner2.step()
    assert runner2.catch_up_resets == 1


def test_runner_stamps_on_the_wall_clock_across_a_lost_second():
    """stamp_s (the node's mode without /clock): simulated time on the epoch clock, from
    start(); when pacing gives up catching up, the lost wall time moves the stamps on with
    it, so they stay on the wall clock."""
    world = box_world([("r", 2.0, 2.0, 0.0)])
    sim = Simulation(world, {"r": started_create()}, NOISELESS)
    wall, epoch0 = [10.0], 1.7e9

    def sleep(s):
        wall[0] += s

    runner = SimRunner(sim, {}, 0.01, real_time_factor=1.0, wall_clock=lambda: wall[0],
                       sleep=sleep, epoch_clock=lambda: epoch0 + wall[0] - 10.0)
    t_start = sim.time_s
    runner.start()
    assert runner.stamp_s(t_start) == pytest.approx(epoch0)
    for _ in range(100):
        runner.step()
    # paced: one simulated second = one wall second, on both clocks
    assert runner.stamp_s(sim.time_s) == pytest.approx(epoch0 + wall[0] - 10.0, abs=1e-6)
    wall[0] += 2.0          # the process was stopped for 2 s
    runner.step()
    assert runner.catch_up_resets == 1
    assert runner.stamp_s(sim.time_s) == pytest.approx(epoch0 + wall[0] - 10.0, abs=0.011)
    for _ in range(50):
        runner.step()
    assert runner.stamp_s(sim.time_s) == pytest.approx(epoch0 + wall[0] - 10.0, abs=0.011)


def test_simulator_params_clock_period_follows_the_physics_step_unless_set():
    p = from_params(SimulatorParams, {"physics_dt_s": 0.02}.get, "")
    assert p.world is None and p.link_dir is None and p.clock_period() == 0.02
    p = from_params(SimulatorParams, {"physics_dt_s": 0.02, "clock_period_s": 0.05}.get)
    assert p.clock_period() == 0.05
    for bad in ({"physics_dt_s": 0}, {"clock_period_s": 0}, {"marker_rate_hz": -1}):
        with pytest.raises(ParamError, match="must be > 0"):
            from_params(SimulatorParams, bad.get)


def test_a_seed_draws_the_same_wheels_in_every_one_robot_world():
    # what launch/calibrate.launch relies on: the calibration world's robot of a seed has
    # the wheels the corridor's (or the office's) robot of that seed has
    worlds = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "worlds")
    model = RobotModel()
    for seed in (0, 3):
        scales = []
        for name in ("calibration", "corridor", "office"):
            world = load_world(os.path.join(worlds, name + ".yaml"))
            assert len(world.robots) == 1
            sim = Simulation(world, {world.robots[0].name: started_create()}, model, seed=seed)
            scales.append(sim.robots[0].encoder_scale)
        assert scales[0] == scales[1] == scales[2]
        assert scales[0] != (1.0, 1.0)
