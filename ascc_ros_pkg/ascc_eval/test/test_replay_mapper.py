"""replay_mapper's reading of the recorded mapper (--online-every-s) on a small synthetic bag
written with the real rosbag: odometry that drifts in scale and heading, a map -> odom that
jumps by a known amount, and the truth."""
import math
import os
import sys

import numpy as np
import pytest

rosbag = pytest.importorskip("rosbag")
import rospy  # noqa: E402
from geometry_msgs.msg import PoseStamped, TransformStamped  # noqa: E402
from sensor_msgs.msg import LaserScan  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import replay_mapper  # noqa: E402

from ascc_common.pose2d import quaternion_from_yaw  # noqa: E402

T0 = 100.0          # [s] bag time of the start
START = (2.0, 3.0)  # [m] true start in the world, heading 0; the robot drives +x at 1 m/s
SCALE, DRIFT = 1.01, 0.002   # odometry: 1 % long, 0.002 rad/s heading drift
JUMP_AT, JUMP_X, JUMP_YAW = 5.0, 0.5, 0.1  # map -> odom: identity, then this from JUMP_AT on


def _tf(stamp, parent, child, x, y, yaw):
    t = TransformStamped()
    t.header.stamp = rospy.Time.from_sec(stamp)
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y = x, y
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
     t.transform.rotation.w) = quaternion_from_yaw(yaw)
    return t


def _write_run(path, odom_at, map_odom_at, truth_at):
    """A 10 s run at 10 Hz from bag time T0: the laser's mount, then per tick k (t = 0.1 k
    [s]) odom -> base_link at ``odom_at(t)`` (x, y, yaw), map -> odom at ``map_odom_at(k,
    t)`` (None: not sent this tick), the truth at ``truth_at(t)`` (world frame) and, from the
    second tick on (the first scan after the first odometry), a five-beam scan."""
    with rosbag.Bag(path, "w") as bag:
        bag.write("/tf_static", TFMessage([_tf(T0, "base_link", "laser", 0.1, 0.0, 0.0)]),
                  rospy.Time.from_sec(T0))
        for k in range(0, 101):
            t = 0.1 * k
            now = rospy.Time.from_sec(T0 + t)
            bag.write("/tf", TFMessage([_tf(T0 + t, "odom", "base_link", *odom_at(t))]), now)
            map_odom = map_odom_at(k, t)
            if map_odom is not None:
                bag.write("/tf", TFMessage([_tf(T0 + t, "map", "odom", *map_odom)]), now)
            x, y, yaw = truth_at(t)
            truth = PoseStamped()
            truth.header.stamp = now
            truth.header.frame_id = "world"
            truth.pose.position.x, truth.pose.position.y = x, y
            (truth.pose.orientation.x, truth.pose.orientation.y, truth.pose.orientation.z,
             truth.pose.orientation.w) = quaternion_from_yaw(yaw)
            bag.write("/ground_truth/asccbot/pose", truth, now)
            if k >= 1:
                scan = LaserScan(ranges=[1.0] * 5, range_min=0.02, range_max=4.0,
                                 angle_min=-1.0, angle_increment=0.5)
                scan.header.stamp = now
                scan.header.frame_id = "laser"
                bag.write("/scan", scan, now)
    return path


@pytest.fixture(scope="module")
def bag_path(tmp_path_factory):
    """Driving +x at 1 m/s; map -> odom sent every 5th tick, jumping at JUMP_AT."""
    def map_odom(k, t):
        if k % 5:
            return None
        jumped = t >= JUMP_AT
        return JUMP_X * jumped, 0.0, JUMP_YAW * jumped

    return _write_run(str(tmp_path_factory.mktemp("replay") / "run.bag"),
                      lambda t: (SCALE * t, 0.0, DRIFT * t), map_odom,
                      lambda t: (START[0] + t, START[1], 0.0))


def test_online_track_separates_the_mapper_from_the_odometry(bag_path):
    run = replay_mapper.RunBag(bag_path)
    rows = run.online_track(1.0)
    assert len(rows) >= 8
    assert rows[0][0] == pytest.approx(0.0)  # from the first scan (0.1 s into the bag)
    first = (SCALE * 0.1, DRIFT * 0.1)  # the odometry there
    for t, x, y, th, odom_err, odom_head, map_err, map_head in rows:
        elapsed = t + 0.1  # since the odometry's start
        # truth in the map frame (the odometry frame, placed by the truth at the first
        # scan): straight ahead from the odometry's pose there
        assert x == pytest.approx(first[0] + t * math.cos(first[1]), abs=1e-6)
        assert y == pytest.approx(t * math.sin(first[1]), abs=1e-6)
        assert th == pytest.approx(first[1], abs=1e-9)
        # odometry: 1 % long and turning at DRIFT, relative to its pose at the first scan
        assert odom_head == pytest.approx(DRIFT * t, abs=1e-6)
        assert odom_err == pytest.approx(0.01 * t, abs=0.002)
        if elapsed < JUMP_AT:
            assert map_err == pytest.approx(odom_err, abs=1e-9)
            assert map_head == pytest.approx(odom_head, abs=1e-9)
        else:  # the estimate is map -> odom applied to the odometry's pose
            ox, oth = SCALE * elapsed, DRIFT * elapsed
            ex, ey = JUMP_X + ox * math.cos(JUMP_YAW), ox * math.sin(JUMP_YAW)
            assert map_err == pytest.approx(math.hypot(ex - x, ey - y), abs=1e-6)
            assert map_head == pytest.approx(oth + JUMP_YAW - th, abs=1e-9)


def test_online_track_is_empty_without_map_to_odom(tmp_path):
    path = str(tmp_path / "no_map.bag")
    with rosbag.Bag(path, "w") as bag:
        bag.write("/tf_static", TFMessage([_tf(T0, "base_link", "laser", 0.1, 0.0, 0.0)]),
                  rospy.Time.from_sec(T0))
        for k in range(3):
            now = rospy.Time.from_sec(T0 + 0.1 * k)
            bag.write("/tf", TFMessage([_tf(T0 + 0.1 * k, "odom", "base_link", 0.1 * k, 0, 0)]),
                      now)
            scan = LaserScan(ranges=[1.0], range_max=4.0)
            scan.header.stamp = now
            bag.write("/scan", scan, now)
    assert replay_mapper.RunBag(path).online_track(1.0) == []


def test_start_turn_counts_the_updates_in_the_first_turn_and_the_error_after_it(tmp_path):
    """A robot that stands 1 s, turns on the spot at 0.7 rad/s for 5 s and stands again; the
    recorded map -> odom (sent at 10 Hz) changes three times in the turn, to a final shift
    of 0.3 m along x; the truth is the odometry moved to START, so that shift is the
    estimate's error after the turn."""
    turn_from, turn_to, rate = 1.0, 6.0, 0.7
    shifts = [(0.0, 0.0), (2.0, 0.1), (3.5, 0.2), (5.0, 0.3)]  # (from t [s], x [m])

    def yaw(t):
        return rate * (min(max(t, turn_from), turn_to) - turn_from)

    path = _write_run(str(tmp_path / "turn.bag"), lambda t: (0.0, 0.0, yaw(t)),
                      lambda k, t: ([x for since, x in shifts if t >= since - 1e-9][-1], 0.0,
                                    0.0),
                      lambda t: (START[0], START[1], yaw(t)))
    turn = replay_mapper.RunBag(path).start_turn()
    assert turn["start_s"] == pytest.approx(turn_from, abs=0.15)   # from the first scan
    assert turn["turned_rad"] == pytest.approx(rate * (turn_to - turn_from), abs=0.1)
    assert turn["duration_s"] == pytest.approx(turn_to - turn_from, abs=0.6)
    assert turn["updates"] == 3
    assert turn["rad_per_update"] == pytest.approx(turn["turned_rad"] / 3)
    assert turn["error_after"] == pytest.approx((0.3, 0.0), abs=1e-6)


def test_start_turn_is_none_without_a_turn(bag_path):
    assert replay_mapper.RunBag(bag_path).start_turn() is None  # drives straight


def test_track_row_gives_the_best_particles_error_and_the_particles_heading_range():
    true = (1.0, 2.0, 3.1)
    best = (1.3, 2.4, -3.1)  # across +-pi: 0.083 rad to the left of the truth
    particles = [best, (1.0, 2.0, 3.05), (1.1, 2.0, 3.0)]
    row = replay_mapper.track_row(12.5, true, best, particles)
    assert row[:4] == (12.5, 1.0, 2.0, 3.1)
    assert row[4] == pytest.approx(0.5)
    assert row[5] == pytest.approx(2 * math.pi - 6.2)
    assert row[6] == pytest.approx(-0.1)
    assert row[7] == pytest.approx(2 * math.pi - 6.2)


def test_replay_tracks_its_estimate_every_period(bag_path):
    """The replay of the synthetic run (drives +x at 1 m/s for 10 s; a filter update every
    0.25 m) reports at the first update after each second, with the truth in the map frame
    (the odometry frame at the first scan)."""
    import bench_mapper

    run = replay_mapper.RunBag(bag_path)
    rows = []
    replay_mapper.replay(run, bench_mapper.load_params(bench_mapper.CONFIG), 0, 0.0,
                         run.tf_lateness(), track_every_s=1.0, on_track=rows.append)
    assert len(rows) >= 8
    first = (SCALE * 0.1, DRIFT * 0.1)  # the odometry at the first scan
    for k, (t, x, y, th, err, head, lo, hi) in enumerate(rows):
        assert k * 1.0 <= t < k * 1.0 + 0.5  # an update every 0.25 s of driving
        assert x == pytest.approx(first[0] + t * math.cos(first[1]), abs=1e-6)
        assert y == pytest.approx(t * math.sin(first[1]), abs=1e-6)
        assert th == pytest.approx(first[1], abs=1e-9)
        assert err >= 0.0
        assert lo <= head <= hi


def test_replay_counts_the_loop_searches_when_loop_closure_is_on(tmp_path):
    """With ``loop_closure`` on, the replay reports what the pose graph's loop searches did
    (status -> count, and the last reason of each); with it off (as shipped) there are none.
    The lab's loop (ascc_eval.drive_bag, about 26 m back to the start) with loop searches
    allowed after 8 m of travel, as mapper_loop.test sets them."""
    pytest.importorskip("ascc_sim")
    import bench_mapper

    from ascc_eval.drive_bag import ROUTES, write_drive_bag

    path = str(tmp_path / "lab.bag")
    write_drive_bag(path, "lab", ROUTES["lab"], seed=1)
    run = replay_mapper.RunBag(path)
    params = bench_mapper.load_params(bench_mapper.CONFIG)
    params["particles"] = 5
    off = replay_mapper.replay(run, params, 0, 0.0, run.tf_lateness())
    assert off["loops"] == {} and off["last_loop"] == {}
    params.update(loop_closure=True, loop_min_travel_m=8.0)
    on = replay_mapper.replay(run, params, 0, 0.0, run.tf_lateness())
    assert sum(on["loops"].values()) >= 1
    assert set(on["loops"]) <= {"rejected", "kept", "closed"}
    assert set(on["last_loop"]) == set(on["loops"])
    assert all(on["last_loop"][k] for k in on["loops"])  # every status names its reason


def test_lineage_travel_follows_the_best_particle_back_through_the_resamplings():
    """Three particles, four updates (the third turning, the second resampled): each
    particle's draw lies ``noise[i]`` ahead of the odometry's prediction along its heading
    and the matcher moves it ``match[i]`` further; the final best particle descends from
    particle 2 before the resampling, so its lineage sums particle 2's offsets before it and
    its own after it, split by the kind of update."""
    from ascc_common.pose2d import compose as comp
    noise = [0.001, -0.002, 0.004]
    match = [0.0005, 0.003, -0.001]
    deltas = [(0.25, 0.0, 0.0), (0.25, 0.01, 0.02), (0.1, 0.0, 0.2), (0.25, 0.0, 0.0)]
    came_from = [None, [2, 2, 0], None, None]
    pulls = [1.0, 1.0, 0.0, 1.0]
    poses = [[0.0, 0.0, 0.3], [0.1, 0.0, 0.31], [0.0, 0.1, 0.29]]
    steps = []
    for delta, idx, pull in zip(deltas, came_from, pulls):
        prev = [list(p) for p in poses]
        sampled, matched = [], []
        for i, p in enumerate(prev):
            pred = comp(p, delta)
            h = (math.cos(p[2]), math.sin(p[2]))
            sampled.append([pred[0] + noise[i] * h[0], pred[1] + noise[i] * h[1], pred[2]])
            m = match[i]
            matched.append([sampled[i][0] + m * h[0], sampled[i][1] + m * h[1], pred[2]])
        steps.append((np.array(prev), np.array(delta), np.array(sampled), np.array(matched),
                      None if idx is None else np.array(idx), pull))
        poses = [matched[j] for j in (idx if idx is not None else range(3))]
    kinds = replay_mapper.lineage_travel(steps, best=1)
    # best 1 after update 2 came from 2: updates 1-2 particle 2, updates 3-4 particle 1
    assert kinds["all"]["updates"] == 4
    assert kinds["all"]["odometry_m"] == pytest.approx(0.85)
    assert kinds["all"]["noise_m"] == pytest.approx(2 * noise[2] + 2 * noise[1])
    assert kinds["all"]["matcher_m"] == pytest.approx(2 * match[2] + 2 * match[1])
    assert kinds["turning, no pull"]["updates"] == 1
    assert kinds["turning, no pull"]["noise_m"] == pytest.approx(noise[1])
    assert kinds["straight, pull"]["matcher_m"] == pytest.approx(2 * match[2] + match[1])
    assert "aligned" not in kinds and "oblique" not in kinds
    # the walls' axes at 0.3 rad: the lineage's headings (0.29-0.51 rad) are within 0.4 rad
    # of them, of 0.3 + pi/2 too; at -0.2 rad all are oblique (0.49-0.71 rad off)
    for ref, kind in ((0.3, "aligned"), (0.3 + math.pi / 2, "aligned"), (-0.2, "oblique")):
        kinds = replay_mapper.lineage_travel(steps, best=1, wall_reference=ref)
        assert kinds[kind]["updates"] == 4
        assert kinds[kind]["matcher_m"] == pytest.approx(kinds["all"]["matcher_m"])
