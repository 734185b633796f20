"""Tests of the gmapping-compatible mapper's pure code: scan preparation, the
Rao-Blackwellized particle filter and the mapper front end (no ROS master needed)."""

import math

import numpy as np
import pytest

from ascc_common import pose2d as P
from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_common.params import from_params, parameters
from ascc_navigation import grid as G
from ascc_navigation import mapper as M
from ascc_navigation import rbpf as R
from ascc_navigation import synthetic as S
from ascc_navigation.laser import LaserMount, prepare_scan, seen_before

SPEC = S.LaserSpec()
MOUNT = LaserMount(0.05, 0.0, 0.0)


def _room_scan(pose, mount=MOUNT, world=None, noise=0.0, seed=0):
    truth, info = world if world is not None else S.office_world()
    return S.simulate_scan(truth == OCCUPIED, info, pose, mount, SPEC,
                           np.random.default_rng(seed), noise_std=noise)


def _prepare(ranges, mount=MOUNT, max_urange=3.9, **kw):
    return prepare_scan(ranges, SPEC.angle_min, SPEC.angle_increment, SPEC.range_min,
                        SPEC.range_max, mount, max_urange, **kw)


# ---------------------------------------------------------------- laser

def test_prepare_scan_classifies_beams_like_gmapping():
    r = np.full(SPEC.n, 2.0)
    r[0] = np.nan           # dropped return
    r[1] = -np.inf          # too close (REP 117)
    r[2] = 0.01             # below range_min
    r[3] = np.inf           # no return -> range_max -> beyond the default maxRange
    r[4] = 3.95             # beyond maxUrange (3.9) but within maxRange: free only
    sc = _prepare(r)
    assert sc.n_hits == SPEC.n - 5 and sc.n_free_only == 1
    # hits lie 2 m from the laser, which sits 5 cm ahead of the base
    d = np.hypot(sc.hits[:, 0] - 0.05, sc.hits[:, 1])
    assert np.allclose(d, 2.0)
    # with maxRange above range_max a no-return beam clears space up to maxUrange
    sc2 = _prepare(r, max_range=4.5)
    assert sc2.n_free_only == 2
    far = np.hypot(sc2.free_polygon[:, 0] - 0.05, sc2.free_polygon[:, 1]).max()
    assert far == pytest.approx(3.9, abs=1e-6)


def test_prepare_scan_offsets_lskip_and_gaps():
    r = np.full(SPEC.n, 2.0)
    r[100:200] = np.nan
    sc = _prepare(r, lskip=2, free_pullback=0.05, hit_offset=0.025)
    assert np.allclose(np.hypot(sc.hits[:, 0] - 0.05, sc.hits[:, 1]), 2.025)
    assert sc.match.shape[0] == math.ceil(sc.n_hits / 3)
    reach = np.hypot(sc.free_polygon[:, 0] - 0.05, sc.free_polygon[:, 1])
    assert reach.max() == pytest.approx(1.95)
    # the polygon returns to the laser at the gap and at both ends: 3 origin vertices
    assert int(np.sum(reach < 1e-9)) == 3


def test_free_space_pulls_back_more_where_a_beam_grazes_a_wall():
    # a wall along x at y = 1 m: the beam straight at it (90 deg) is head-on, beams at a
    # shallow angle graze it; the free wedge must stop ~one cell short *perpendicular* to it
    info = GridInfo.from_bounds(0.05, -5.0, -1.0, 5.0, 3.0)
    truth = np.zeros(info.shape, dtype=np.int8)
    truth[info.world_to_cell(0.0, 1.0)[1]:, :] = OCCUPIED
    mount = LaserMount()
    r = _room_scan(np.zeros(3), mount=mount, world=(truth, info))
    sc = _prepare(r, mount=mount, free_pullback=0.05)
    poly = sc.free_polygon
    reach = np.hypot(poly[:, 0], poly[:, 1])
    a = np.arctan2(poly[:, 1], poly[:, 0])
    near_wall = poly[(reach > 0.5) & (a > 0.3) & (a < math.pi - 0.3)]
    gap = 1.0 - near_wall[:, 1]  # distance of the free wedge's end from the wall
    assert gap.min() > 0.02 and np.median(gap) < 0.1


def test_beams_past_the_previous_scans_reach_are_not_matched():
    # only the far beams hit something: with the robot having moved 0.5 m they reach past
    # maxUrange - motion - new_area_margin, so no particle is matched (odometry only)
    world = S.office_world()
    cfg = R.RbpfConfig(particles=3, xmin=0, ymin=0, xmax=14, ymax=10)
    slam = R.RbpfSlam(cfg, seed=0)
    p0 = np.array([2.0, 2.0, 0.0])
    slam.start(p0, _prepare(_room_scan(p0, world=world), max_urange=3.9))
    p1 = p0 + [0.5, 0.0, 0.0]
    r = _room_scan(p1, world=world)
    r[r < 3.4] = np.nan
    sc = _prepare(r, max_urange=3.9)
    assert sc.match.shape[0] > 0 and sc.match_range.min() >= 3.4
    assert slam.update(P.relative(p0, p1), sc).matched == 0
    # the same beams are matched when the robot has hardly moved
    assert slam.update(np.zeros(3), sc).matched == 3


def _recess_corridor(length=30.0, recess_width=1.0, recess_depth=0.45, every=2.0):
    """A corridor along x (walls' surfaces at y = 0.5 and 2.9 m) with a door recess
    ``recess_width`` x ``recess_depth`` [m] in the north wall every ``every`` metres."""
    info = GridInfo.from_bounds(0.05, 0.0, 0.0, length, 3.4)
    truth = np.zeros(info.shape, dtype=np.int8)
    truth[:10, :] = OCCUPIED
    truth[-10:, :] = OCCUPIED
    depth = int(round(recess_depth / 0.05))
    for x0 in np.arange(2.0, length - 1.0, every):
        truth[-10:-10 + depth, int(round(x0 / 0.05)):int(round((x0 + recess_width) / 0.05))] = 0
    return truth, info


def test_seen_before_flags_what_the_previous_scan_could_not_see():
    world = _recess_corridor()
    kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
    p0 = np.array([3.0, 1.7, 0.0])           # 1 m before the recess at x 4.0 .. 5.0
    p1 = p0 + [0.5, 0.0, 0.05]
    prev = _prepare(_room_scan(p0, world=world), **kw)
    sc = _prepare(_room_scan(p1, world=world), **kw)
    motion = P.relative(p0, p1)
    seen = seen_before(prev, motion, sc.match, 0.2)
    world_pts = P.transform_points(p1, sc.match)
    back_wall = (world_pts[:, 1] > 2.95) & (world_pts[:, 0] > 4.05) & (world_pts[:, 0] < 4.95)
    # the recess's back wall near its first jamb: hidden behind the jamb from p0, not from p1
    hidden = back_wall & (world_pts[:, 0] < 4.3)
    assert hidden.sum() >= 3 and not seen[hidden].any()
    # the side walls within reach of both scans were seen
    walls = (np.abs(world_pts[:, 1] - 0.5) < 0.05) & (np.abs(world_pts[:, 0] - p1[0]) < 2.5)
    assert walls.sum() > 50 and seen[walls].all()
    # beyond the previous scan's range: not seen; a dropout in the previous scan hides nothing
    far = np.hypot(world_pts[:, 0] - p0[0] - 0.05, world_pts[:, 1] - p0[1]) > 4.0 + 0.2 + 0.03
    assert far.any() and not seen[far].any()
    r = _room_scan(p0, world=world)
    r[::2] = np.nan
    assert seen_before(_prepare(r, **kw), motion, sc.match, 0.2)[walls].all()
    # without the previous beams' geometry everything counts as seen
    bare = R.PreparedScan(prev.origin, prev.hits, prev.match, prev.match_range, prev.max_urange,
                          prev.free_polygon, prev.n_beams, prev.n_hits, prev.n_free_only)
    assert seen_before(bare, motion, sc.match, 0.2).all()


def _drift_past_recesses(seen_margin_m, seed, steps=40):
    """Along-corridor error [m] of a one-particle filter with exact odometry and no motion
    noise after ``steps`` updates of 0.25 m past door recesses (1 cm range noise)."""
    world = _recess_corridor()
    cfg = R.RbpfConfig(particles=1, xmin=0, ymin=0, xmax=30, ymax=3.4, srr=0.0, srt=0.0,
                       str=0.0, stt=0.0, seen_margin_m=seen_margin_m)
    slam = R.RbpfSlam(cfg, seed=0)
    kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
    pose = np.array([3.0, 1.7, 0.0])
    slam.start(pose, _prepare(_room_scan(pose, world=world, noise=0.01, seed=seed), **kw))
    for k in range(steps):
        new = pose + [0.25, 0.0, 0.0]
        slam.update(P.relative(pose, new), _prepare(
            _room_scan(new, world=world, noise=0.01, seed=seed + k + 1), **kw))
        pose = new
    return slam.best_pose[0] - pose[0]


def test_recess_back_walls_coming_into_view_do_not_pull_the_pose_forward():
    # Driving past door recesses, each update sees a little more of a recess's back wall
    # behind its jamb. Matched against the map, whose part of that wall ends where the
    # previous scan's view ended, those end points pull the pose forwards: with exact
    # odometry the along error grows by several mm per update (the corridor's long sides
    # came out long). Leaving them out (seen_margin_m) removes most of it.
    seeds = (100, 200)
    without = np.mean([_drift_past_recesses(-1.0, s) for s in seeds])
    with_check = np.mean([_drift_past_recesses(0.2, s) for s in seeds])
    assert without > 0.08          # 10 m: > 2 mm per update, always forwards
    assert abs(with_check) < 0.5 * without


def test_laser_mount_upside_down_mirrors_and_tilt_rejected():
    flipped = LaserMount.from_transform(0.1, 0.0, 1.0, 0.0, 0.0, 0.0)  # roll = pi
    assert flipped.upside_down and flipped.yaw == pytest.approx(0.0)
    r = np.full(SPEC.n, np.inf)
    r[SPEC.n - 1] = 1.0  # last beam: +120 deg in the laser frame
    sc = _prepare(r, mount=flipped)
    angle = math.atan2(sc.hits[0, 1], sc.hits[0, 0] - 0.1)
    assert angle == pytest.approx(-SPEC.angles()[-1], abs=1e-9)
    tilt = math.radians(20.0)
    with pytest.raises(ValueError):
        LaserMount.from_transform(0.0, 0.0, 0.0, math.sin(tilt / 2), 0.0, math.cos(tilt / 2))


# ---------------------------------------------------------------- filter pieces

def test_resampling_entropy_and_neff():
    rng = np.random.default_rng(0)
    assert R.low_variance_resample(np.array([0.0, 0.0, 1.0, 0.0]), rng).tolist() == [2] * 4
    idx = R.low_variance_resample(np.array([0.5, 0.25, 0.25, 0.0]), rng)
    assert np.bincount(idx, minlength=4).tolist() == [2, 1, 1, 0]
    uniform = np.full(8, 1 / 8)
    assert R.weight_entropy(uniform) == pytest.approx(math.log(8))
    assert R.weight_entropy(np.array([1.0, 0.0, 0.0])) == 0.0
    assert R.effective_sample_size(uniform) == pytest.approx(8)
    w = R.normalized_weights(np.array([-1000.0, 0.0, -1000.0]))
    assert w[1] == pytest.approx(1.0) and R.effective_sample_size(w) == pytest.approx(1.0)


def test_motion_model_mean_and_spread():
    cfg = R.RbpfConfig(srr=0.1, srt=0.2, str=0.1, stt=0.2)
    rng = np.random.default_rng(1)
    start = np.tile([1.0, 2.0, 0.5], (20000, 1))
    delta = np.array([0.5, 0.0, 0.2])
    out = R.sample_motion(start, delta, cfg, rng)
    expected = P.compose(start[0], delta)
    assert np.allclose(out.mean(axis=0), expected, atol=0.01)
    s_xy, s_th = R.motion_noise(delta, cfg)
    assert s_xy == pytest.approx(0.1 * 0.5 + 0.1 * 0.2)
    assert np.std(out[:, 2]) == pytest.approx(s_th, rel=0.05)
    # noise-free model moves every particle exactly by the odometry
    exact = R.sample_motion(start[:3], delta, R.RbpfConfig(srr=0, srt=0, str=0, stt=0), rng)
    assert np.allclose(exact, expected)


def test_register_marks_walls_free_space_and_unknown():
    world = S.office_world()
    truth, tinfo = world
    pose = np.array([2.0, 2.0, 0.3])
    sc = _prepare(_room_scan(pose, world=world), free_pullback=0.05, hit_offset=0.025)
    maps = R.ParticleMaps(2, GridInfo.from_bounds(0.05, 0.0, 0.0, 14.0, 10.0))
    maps.register(np.array([pose, pose]), sc)
    occ = maps.occupancy(0, 0.25)
    assert np.array_equal(occ, maps.occupancy(1, 0.25))
    res = G.map_agreement(occ, maps.info, truth, tinfo)
    assert res["accuracy"] > 0.97 and res["occupied_cells"] > 100
    # the robot's own cell is free, a cell behind the central block's wall is unknown
    ix, iy = maps.info.world_to_cell([2.1, 6.0], [2.0, 4.5])
    assert occ[iy[0], ix[0]] == FREE and occ[iy[1], ix[1]] == UNKNOWN


def test_counts_once_per_scan_and_saturate_without_changing_the_map():
    pose = np.array([[2.0, 2.0, 0.0]])
    sc = _prepare(_room_scan(pose[0]), free_pullback=0.05, hit_offset=0.025)
    maps = R.ParticleMaps(1, GridInfo.from_bounds(0.05, 0.0, 0.0, 14.0, 10.0))
    maps.register(pose, sc)
    assert maps.visits.max() == 1 and maps.hits.max() == 1  # many beams, one count per scan
    first = maps.occupancy(0, 0.25)
    for _ in range(300):
        maps.register(pose, sc)
    assert maps.visits.max() <= R.COUNT_MAX
    assert np.array_equal(maps.occupancy(0, 0.25), first)


def test_resampling_gives_each_particle_the_map_it_drew():
    # In place for sorted indices (systematic resampling), by a copy otherwise: the same
    # maps as a fancy-indexed copy of the stack, for draws that shift slots both ways.
    rng = np.random.default_rng(3)
    n = 12
    for trial in range(40):
        maps = R.ParticleMaps(n, GridInfo.from_bounds(0.05, 0.0, 0.0, 0.5, 0.4))
        maps.hits[:] = rng.integers(0, 255, maps.hits.shape, dtype=np.uint8)
        maps.visits[:] = rng.integers(0, 255, maps.visits.shape, dtype=np.uint8)
        weights = rng.dirichlet(np.full(n, 0.3))
        idx = R.low_variance_resample(weights, rng)
        if trial % 4 == 3:
            idx = rng.permutation(idx)             # not sorted: the copying path
        want_h, want_v = maps.hits[idx].copy(), maps.visits[idx].copy()
        maps.select(idx)
        assert np.array_equal(maps.hits, want_h) and np.array_equal(maps.visits, want_v)


def test_map_grows_and_keeps_content_in_place():
    maps = R.ParticleMaps(2, GridInfo.from_bounds(0.05, 0.0, 0.0, 2.0, 2.0))
    maps.hits[1, 10, 20] = 3
    maps.visits[1, 10, 20] = 4
    wx, wy = maps.info.cell_to_world(20, 10)
    assert maps.ensure_contains(-1.0, 0.5, 2.5, 1.0, margin=0.5)
    assert maps.info.origin_x <= -1.5 + 1e-9 and maps.info.xmax >= 3.0 - 1e-9
    assert maps.info.height == 40  # y already fitted: no growth there
    ix, iy = maps.info.world_to_cell(wx, wy)
    assert maps.hits[1, iy, ix] == 3 and maps.visits[1, iy, ix] == 4
    assert not maps.ensure_contains(0.0, 0.0, 1.0, 1.0, margin=0.5)


def test_scan_matching_corrects_an_odometry_error():
    world = S.office_world()
    true0 = np.array([4.0, 1.8, 0.1])
    true1 = np.array([4.3, 1.85, 0.12])
    cfg = R.RbpfConfig(particles=4, xmin=0, ymin=0, xmax=14, ymax=10,
                       srr=0.0, srt=0.0, str=0.0, stt=0.0, motion_prior=0.0)
    slam = R.RbpfSlam(cfg, seed=0)
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
    # odometry claims 6 cm more forward, 4 cm left and 3 degrees more turn than happened
    wrong = P.compose(true1, [0.06, 0.04, math.radians(3.0)])
    stats = slam.update(P.relative(true0, wrong), _prepare(_room_scan(true1, world=world), **kw))
    err = slam.best_pose - true1
    assert stats.matched == 4
    assert math.hypot(err[0], err[1]) < 0.015 and abs(err[2]) < math.radians(0.5)


def test_update_stats_report_the_weighing_before_resampling():
    world = S.office_world()
    true0 = np.array([4.0, 1.8, 0.1])
    true1 = np.array([4.3, 1.85, 0.12])
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    for threshold in (0.0, 1.0):  # never / always resample
        cfg = R.RbpfConfig(particles=6, xmin=0, ymin=0, xmax=14, ymax=10,
                           resample_threshold=threshold)
        slam = R.RbpfSlam(cfg, seed=3)
        slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
        before = slam.log_w.copy()
        stats = slam.update(P.relative(true0, true1),
                            _prepare(_room_scan(true1, world=world), **kw))
        assert stats.log_gain.shape == (6,) and stats.weighed_poses.shape == (6, 3)
        assert np.ptp(stats.log_gain) > 0.0  # the particles' poses differ, so do their gains
        if threshold == 0.0:
            assert not stats.resampled
            gained = before + stats.log_gain
            assert np.allclose(slam.log_w, gained - gained.max())
            assert np.array_equal(slam.poses, stats.weighed_poses)
        else:
            assert stats.resampled
            # every particle after resampling is one of the weighed ones
            for pose in slam.poses:
                assert np.any(np.all(stats.weighed_poses == pose, axis=1))


def test_weight_radius_bounds_each_beams_term_in_the_weights():
    world = S.office_world()
    true0 = np.array([4.0, 1.8, 0.1])
    true1 = np.array([4.3, 1.85, 0.12])
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    gains = {}
    for radius in (-1.0, 0.03):
        cfg = R.RbpfConfig(particles=2, xmin=0, ymin=0, xmax=14, ymax=10, srr=0.0, srt=0.0,
                           str=0.0, stt=0.0, resample_threshold=0.0, recover_score=0.0,
                           minimum_score=1e9, weight_radius_m=radius)  # poses kept
        slam = R.RbpfSlam(cfg, seed=0)
        slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
        slam.poses[1] = P.compose(true0, [0.0, 0.0, math.radians(10.0)])  # a wrong particle
        stats = slam.update(P.relative(true0, true1),
                            _prepare(_room_scan(true1, world=world), **kw))
        floor = -stats.beams * cfg.weight_radius ** 2 / (2 * cfg.lsigma ** 2) / cfg.ogain
        assert np.all(stats.log_gain >= floor - 1e-9)
        assert stats.log_gain[0] > stats.log_gain[1]  # the right particle still wins
        gains[radius] = stats.log_gain
    assert R.RbpfConfig(weight_radius_m=-1.0).weight_radius == R.RbpfConfig().match_radius
    assert R.RbpfConfig(weight_radius_m=1.0).weight_radius == R.RbpfConfig().match_radius
    # the wrong particle's beams lie far from its map: the cap takes most of its penalty,
    # and it still loses by far
    assert gains[0.03][1] > 0.2 * gains[-1.0][1]
    assert gains[0.03][1] < gains[0.03][0] - 5.0


@pytest.mark.parametrize("heading", [0.3, math.pi - 0.02])
def test_detrend_along_drops_the_trend_along_the_heading_only(heading):
    rng = np.random.default_rng(4)
    n = 30
    along = rng.normal(0.0, 0.05, n)
    across = rng.normal(0.0, 0.05, n)
    c, s_ = math.cos(heading), math.sin(heading)
    poses = np.column_stack([2.0 + c * along - s_ * across, 1.0 + s_ * along + c * across,
                             heading + rng.normal(0.0, 0.01, n)])
    poses[:, 2] = P.wrap_angle(poses[:, 2])  # headings on both sides of +-pi
    gain = -40.0 * along + 60.0 * across - 5.0
    out = R.detrend_along(gain, poses)
    assert out.mean() == pytest.approx(gain.mean())
    a = along - along.mean()
    # no trend along left (up to the mean heading's noise, 0.01 rad / sqrt(30))
    assert abs(float(out @ a)) < 0.01 * abs(float(gain @ a))
    # what tells the particles apart across the travel is kept
    fit = np.polyfit(across, out, 1)
    assert fit[0] == pytest.approx(60.0, rel=0.1)
    # particles that do not spread along the heading: nothing to remove
    still = poses.copy()
    still[:, 0] = 2.0 - s_ * across
    still[:, 1] = 1.0 + c * across
    assert np.allclose(R.detrend_along(gain, still), gain, atol=1e-6)


@pytest.mark.parametrize("recover_score", [0.0, 0.7])
def test_wide_heading_search_recovers_a_turn_the_odometry_missed(recover_score):
    # The robot spun 25 degrees more than the odometry says (odometry stamped late while it
    # turned): far outside the hill climber's reach, so only the wide search finds it.
    world = S.office_world()
    true0 = np.array([4.0, 1.8, 0.1])
    true1 = np.array([4.0, 1.8, 0.1 + math.radians(60.0)])
    said = np.array([4.0, 1.8, 0.1 + math.radians(35.0)])
    cfg = R.RbpfConfig(particles=4, xmin=0, ymin=0, xmax=14, ymax=10,
                       srr=0.0, srt=0.0, str=0.0, stt=0.0, recover_score=recover_score)
    slam = R.RbpfSlam(cfg, seed=0)
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
    stats = slam.update(P.relative(true0, said), _prepare(_room_scan(true1, world=world), **kw))
    err = slam.best_pose - true1
    recovered = math.hypot(err[0], err[1]) < 0.03 and abs(err[2]) < math.radians(0.5)
    assert recovered == (recover_score > 0.0)
    assert stats.recovered == (4 if recover_score > 0.0 else 0)


def test_wide_heading_search_leaves_good_matches_alone():
    # The ordinary case: odometry a little off; every particle matches well, none is moved.
    world = S.office_world()
    true0 = np.array([4.0, 1.8, 0.1])
    true1 = np.array([4.3, 1.85, 0.12])
    cfg = R.RbpfConfig(particles=4, xmin=0, ymin=0, xmax=14, ymax=10)
    slam = R.RbpfSlam(cfg, seed=0)
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
    stats = slam.update(P.relative(true0, true1), _prepare(_room_scan(true1, world=world), **kw))
    assert stats.recovered == 0


def test_motion_prior_keeps_pose_in_an_unconstrained_direction():
    # A featureless corridor along x: the scan cannot tell x, so the prior must hold it.
    info = GridInfo.from_bounds(0.05, 0.0, 0.0, 40.0, 3.0)
    truth = np.zeros(info.shape, dtype=np.int8)
    truth[[0, -1], :] = OCCUPIED
    world = (truth, info)
    cfg = R.RbpfConfig(particles=8, xmin=0, ymin=0, xmax=40, ymax=3)
    slam = R.RbpfSlam(cfg, seed=3)
    kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
    pose = np.array([10.0, 1.5, 0.0])
    slam.start(pose, _prepare(_room_scan(pose, world=world), **kw))
    for _ in range(8):
        new = pose + [0.25, 0.0, 0.0]
        slam.update(P.relative(pose, new), _prepare(_room_scan(new, world=world), **kw))
        pose = new
    assert abs(slam.best_pose[0] - pose[0]) < 0.15
    assert abs(slam.best_pose[1] - pose[1]) < 0.02


def _fields_after_mapping(world, poses, pose, **cfg_kw):
    """A one-particle filter that mapped the scans taken at ``poses`` (true); its likelihood
    fields and the end points of the scan at ``pose`` that an update would match (those
    within the previous scan's reach, as ``RbpfSlam.update`` selects them)."""
    cfg = R.RbpfConfig(particles=1, xmin=0, ymin=0, xmax=world[1].width * world[1].resolution,
                       ymax=world[1].height * world[1].resolution, **cfg_kw)
    slam = R.RbpfSlam(cfg, seed=0)
    kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
    slam.start(poses[0], _prepare(_room_scan(poses[0], world=world), **kw))
    for p in poses[1:]:
        slam.poses[:] = p
        slam._register(_prepare(_room_scan(p, world=world), **kw))
    slam.poses[:] = pose
    scan = _prepare(_room_scan(pose, world=world), **kw)
    moved = math.hypot(*(np.asarray(pose) - poses[-1])[:2])
    pts = scan.match[scan.match_range <= scan.max_urange - moved - cfg.new_area_margin]
    return slam, slam._fields(pts), pts


def _corridor_world(length=40.0, width=3.0):
    info = GridInfo.from_bounds(0.05, 0.0, 0.0, length, width)
    truth = np.zeros(info.shape, dtype=np.int8)
    truth[[0, -1], :] = OCCUPIED
    return truth, info


def test_likelihood_lookup_is_bilinear_on_each_particles_field():
    """interpolate / gradients against scipy's linear interpolation and the corner cells
    on the fields' own distance images (two particles, their maps different)."""
    from scipy.ndimage import map_coordinates
    world = S.office_world()
    slam, fields, pts = _fields_after_mapping(world, [np.array([4.0, 1.8, 0.1])],
                                              np.array([4.1, 1.8, 0.1]))
    assert fields.h >= 20 and fields.w >= 20
    rng = np.random.default_rng(3)
    images = [rng.random((fields.band, fields.w), dtype=np.float32) for _ in range(2)]
    fields.dist = np.concatenate(images).reshape(-1)
    u = rng.uniform(-3.0, fields.w + 3.0, (2, 3, 50)).astype(np.float32)
    v = rng.uniform(-3.0, fields.h + 3.0, (2, 3, 50)).astype(np.float32)
    got = fields.interpolate(u.copy(), v.copy(), np.array([1, 0]))
    for row, particle in enumerate((1, 0)):
        uu = np.clip(u[row], 0.0, fields.w - 1.001)   # off-window: clamped to the border
        vv = np.clip(v[row], 0.0, fields.h - 1.001)
        want = map_coordinates(images[particle].astype(np.float64), [vv, uu], order=1)
        np.testing.assert_allclose(got[row], want, atol=1e-5)
    # gradients: the same lookup at the end points seen from a pose, and its slope [m/m]
    # from the four corner cells of the image
    pose = np.array([[slam.poses[0, 0] + 0.013, slam.poses[0, 1] - 0.021, 0.3]])
    d, gx, gy, rx, ry = fields.gradients(pose, np.array([1]), pts)
    np.testing.assert_allclose(d, fields.distances(pose[:, None, :], np.array([1]), pts)[:, 0],
                               atol=1e-6)
    c, s_ = math.cos(0.3), math.sin(0.3)
    res = fields.res
    uu = np.clip((pose[0, 0] - fields.origin_x + c * pts[:, 0] - s_ * pts[:, 1]) / res,
                 0.0, fields.w - 1.001)
    vv = np.clip((pose[0, 1] - fields.origin_y + s_ * pts[:, 0] + c * pts[:, 1]) / res,
                 0.0, fields.h - 1.001)
    iu, iv = uu.astype(int), vv.astype(int)
    fu, fv = uu - iu, vv - iv
    img = images[1].astype(np.float64)
    d00, d10, d01, d11 = img[iv, iu], img[iv, iu + 1], img[iv + 1, iu], img[iv + 1, iu + 1]
    np.testing.assert_allclose(gx[0], ((d10 - d00) * (1 - fv) + (d11 - d01) * fv) / res,
                               atol=1e-2)
    np.testing.assert_allclose(gy[0], ((d01 - d00) * (1 - fu) + (d11 - d10) * fu) / res,
                               atol=1e-2)
    assert np.allclose(rx ** 2 + ry ** 2, (pts ** 2).sum(axis=1), atol=1e-6)


def test_scan_information_of_a_corridor_has_a_flat_direction_along_it():
    pose = np.array([10.0, 1.5, 0.0])
    slam, fields, pts = _fields_after_mapping(_corridor_world(), [pose - [2, 0, 0],
                                                                  pose - [0.25, 0, 0]], pose)
    info = R.scan_information(*fields.gradients(pose[None], np.zeros(1, int), pts),
                              slam.cfg.sigma)[0]
    vals, vecs = np.linalg.eigh(info[:2, :2])
    # across the corridor (y): many beams; along it (x): nothing
    assert abs(vecs[1, 1]) > 0.999 and vals[1] > 1e5
    assert vals[0] < 1e-2 * vals[1]
    # in a room corner every direction is constrained
    world = S.office_world()
    corner = np.array([4.0, 1.8, 0.1])
    slam, fields, pts = _fields_after_mapping(world, [corner], corner)
    info = R.scan_information(*fields.gradients(corner[None], np.zeros(1, int), pts),
                              slam.cfg.sigma)[0]
    assert np.linalg.eigvalsh(info[:2, :2])[0] > 0.05 * np.linalg.eigvalsh(info[:2, :2])[1]


def test_degeneracy_projection_keeps_the_prediction_only_where_the_scan_is_flat():
    pose = np.array([10.0, 1.5, 0.0])
    slam, fields, pts = _fields_after_mapping(_corridor_world(), [pose - [2, 0, 0],
                                                                  pose - [0.25, 0, 0]], pose)
    predicted = pose + [0.05, 0.04, 0.01]     # what the motion model said
    matched = pose + [0.30, 0.0, 0.0]         # the matcher fixed y and theta and slid in x
    std = 0.0075  # srr 0.03 m/m over 0.25 m
    args = (fields, pts, slam.cfg.sigma, predicted[None], matched[None], np.zeros(1, int), std)
    out, flat = R.degeneracy_projection(*args, 1.0)
    assert flat.tolist() == [True]
    assert abs(out[0, 0] - predicted[0]) < 0.005           # along: the prediction
    assert abs(out[0, 1] - pose[1]) < 0.005                 # across: the scan's
    assert out[0, 2] == matched[2]                          # heading: the matcher's
    out, flat = R.degeneracy_projection(*args, 0.0)         # off: the matcher's pose
    assert not flat[0] and np.allclose(out[0], matched)
    out, flat = R.degeneracy_projection(*args, 1e12)        # nothing trusted: prediction
    assert flat[0] and np.allclose(out[0, :2], predicted[:2]) and out[0, 2] == matched[2]
    # in a room corner the matcher's correction is kept in full
    world = S.office_world()
    corner = np.array([4.0, 1.8, 0.1])
    slam, fields, pts = _fields_after_mapping(world, [corner], corner)
    out, flat = R.degeneracy_projection(fields, pts, slam.cfg.sigma, (corner + 0.03)[None],
                                        corner[None], np.zeros(1, int), std, 1.0)
    assert not flat[0] and np.allclose(out[0], corner)


def test_degenerate_directions_follow_the_odometry_in_a_featureless_corridor():
    # Exact odometry, scans of a corridor without features: with degeneracy-aware matching
    # the along-corridor position is the odometry's up to the sampled motion noise.
    world = _corridor_world()
    cfg = R.RbpfConfig(particles=8, xmin=0, ymin=0, xmax=40, ymax=3, srr=0.01,
                       motion_prior=0.0, degenerate_info=1.0)
    slam = R.RbpfSlam(cfg, seed=3)
    kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
    pose = np.array([10.0, 1.5, 0.0])
    slam.start(pose, _prepare(_room_scan(pose, world=world), **kw))
    flat = 0
    for _ in range(12):
        new = pose + [0.25, 0.0, 0.0]
        flat += slam.update(P.relative(pose, new),
                            _prepare(_room_scan(new, world=world), **kw)).degenerate
        pose = new
    assert flat == 12 * 8
    # 12 steps of srr * 0.25 m = 2.5 mm noise: a random walk of ~9 mm (1 sigma)
    assert abs(slam.best_pose[0] - pose[0]) < 0.03
    assert abs(slam.best_pose[1] - pose[1]) < 0.02


# ---------------------------------------------------------------- mapper front end

def _scan_input(stamp, ranges):
    return M.ScanInput(stamp, ranges, SPEC.angle_min, SPEC.angle_increment, SPEC.range_min,
                       SPEC.range_max)


def _mapper(**params):
    base = {"particles": 5, "xmin": 0.0, "ymin": 0.0, "xmax": 14.0, "ymax": 10.0,
            "linearUpdate": 0.25, "angularUpdate": 0.25, "maxUrange": 3.9, "maxRange": 4.5}
    base.update(params)
    return M.SlamMapper(from_params(M.MapperConfig, base.get), seed=0)


def test_parameters_keep_gmapping_names_and_check_types():
    defaults = {p.name: p.default for p in parameters(M.MapperConfig)}
    for name in ("particles", "delta", "linearUpdate", "angularUpdate", "temporalUpdate",
                 "maxUrange", "xmin", "ymax", "srr", "ogain"):
        assert name in defaults
    cfg = from_params(M.MapperConfig, {"particles": 12, "linearUpdate": 0.3, "delta": 0.1}.get)
    assert cfg.rbpf.particles == 12 and cfg.linear_update == 0.3 and cfg.rbpf.delta == 0.1
    with pytest.raises(ValueError, match="particles"):
        from_params(M.MapperConfig, {"particles": 2.5}.get)
    with pytest.raises(ValueError, match="linearUpdate"):
        from_params(M.MapperConfig, {"linearUpdate": "far"}.get)


def test_mapper_updates_only_after_enough_motion():
    mapper = _mapper()
    p0 = np.array([2.0, 2.0, 0.0])
    out = mapper.handle_scan(_scan_input(1.0, _room_scan(p0)), p0, MOUNT)
    assert out.status == M.STARTED and mapper.started
    assert np.allclose(mapper.map_to_odom(), 0.0)  # the map frame starts at the odom frame
    p1 = p0 + [0.1, 0.0, 0.0]
    assert mapper.handle_scan(_scan_input(1.1, _room_scan(p1)), p1, MOUNT).status == M.SKIPPED
    p2 = p0 + [0.3, 0.0, 0.0]
    out = mapper.handle_scan(_scan_input(1.2, _room_scan(p2)), p2, MOUNT)
    assert out.status == M.UPDATED and out.stats.entropy <= math.log(5) + 1e-9
    p3 = p2 + [0.0, 0.0, 0.3]
    assert mapper.handle_scan(_scan_input(1.3, _room_scan(p3)), p3, MOUNT).status == M.UPDATED


def test_temporal_update_fires_without_motion():
    mapper = _mapper(temporalUpdate=2.0)
    p0 = np.array([2.0, 2.0, 0.0])
    scan = _room_scan(p0)
    mapper.handle_scan(_scan_input(0.0, scan), p0, MOUNT)
    assert mapper.handle_scan(_scan_input(1.0, scan), p0, MOUNT).status == M.SKIPPED
    assert mapper.handle_scan(_scan_input(2.5, scan), p0, MOUNT).status == M.UPDATED


def test_bad_scans_are_rejected_with_a_reason():
    mapper = _mapper()
    p0 = np.array([2.0, 2.0, 0.0])
    bad = [
        (M.ScanInput(1.0, [], -1.0, 0.01, 0.02, 4.0), "empty"),
        (_scan_input(1.0, np.full(SPEC.n, np.nan)), "no valid range"),
        (M.ScanInput(1.0, np.ones(10), -1.0, 0.0, 0.02, 4.0), "angle_increment"),
        (M.ScanInput(1.0, np.ones(10), -1.0, float("nan"), 0.02, 4.0), "not finite"),
        (M.ScanInput(1.0, np.ones(10), -1.0, 0.1, 4.0, 1.0), "range_max"),
    ]
    for scan, word in bad:
        out = mapper.handle_scan(scan, p0, MOUNT)
        assert out.status == M.REJECTED and word in out.reason
    assert not mapper.started
    # beams that all return beyond maxUrange cannot start a map
    far = _mapper(maxUrange=0.5)
    out = far.handle_scan(_scan_input(1.0, _room_scan(p0)), p0, MOUNT)
    assert out.status == M.REJECTED and not far.started


def test_time_going_backwards_resets_the_map():
    mapper = _mapper()
    p0 = np.array([2.0, 2.0, 0.0])
    mapper.handle_scan(_scan_input(10.0, _room_scan(p0)), p0, MOUNT)
    p1 = p0 + [0.5, 0.0, 0.0]
    assert mapper.handle_scan(_scan_input(10.5, _room_scan(p1)), p1, MOUNT).status == M.UPDATED
    assert mapper.slam.updates == 2
    out = mapper.handle_scan(_scan_input(3.0, _room_scan(p0)), p0, MOUNT)
    assert out.status == M.RESET and "backwards" in out.reason
    assert mapper.slam.updates == 1 and np.allclose(mapper.robot_pose(), p0)


def test_odometry_jump_is_ignored_and_absorbed_by_map_to_odom():
    mapper = _mapper()
    p0 = np.array([2.0, 2.0, 0.0])
    mapper.handle_scan(_scan_input(1.0, _room_scan(p0)), p0, MOUNT)
    before = P.compose(mapper.map_to_odom(), p0)  # robot in map through the TF chain
    jumped = np.array([-3.0, 5.0, 1.0])  # odometry reset: same place, new odom pose
    out = mapper.handle_scan(_scan_input(1.1, _room_scan(p0)), jumped, MOUNT)
    assert out.status == M.REJECTED and "jumped" in out.reason
    # After the next update the TF chain map->odom->base still gives the true place.
    moved = P.compose(jumped, [0.3, 0.0, 0.0])
    out = mapper.handle_scan(_scan_input(1.2, _room_scan(p0 + [0.3, 0, 0])), moved, MOUNT)
    assert out.status == M.UPDATED
    after = P.compose(mapper.map_to_odom(), moved)
    assert np.allclose(after, before + [0.3, 0.0, 0.0], atol=0.03)


def test_a_long_step_after_a_long_gap_is_motion_not_a_jump():
    """Scans dropped for late TF (a loaded machine): 1.2 m and a quarter turn in 3 s is
    driving, not an odometry reset; ignoring it would rotate the map by the turn."""
    mapper = _mapper()
    p0 = np.array([2.0, 2.0, 0.0])
    mapper.handle_scan(_scan_input(1.0, _room_scan(p0)), p0, MOUNT)
    p1 = np.array([2.6, 3.0, math.pi / 2])  # 1.17 m away, turned by 90 deg
    out = mapper.handle_scan(_scan_input(4.0, _room_scan(p1)), p1, MOUNT)
    assert out.status == M.UPDATED, out
    assert np.allclose(mapper.robot_pose(), p1, atol=0.05)
    # the same step within one scan period is a jump
    quick = _mapper()
    quick.handle_scan(_scan_input(1.0, _room_scan(p0)), p0, MOUNT)
    out = quick.handle_scan(_scan_input(1.1, _room_scan(p1)), p1, MOUNT)
    assert out.status == M.REJECTED and "jumped" in out.reason


def test_mapping_a_loop_of_the_synthetic_office():
    """Short end-to-end run: drifting odometry, noisy scans; the map must agree with the
    ground truth and the pose must stay close, and the map must grow beyond its start."""
    truth, tinfo = S.office_world()
    rng = np.random.default_rng(7)
    traj = S.waypoint_trajectory(S.office_loop_waypoints()[:6])
    odom = S.noisy_odometry(traj, rng)
    mapper = _mapper(particles=15, xmin=0.0, ymin=0.0, xmax=6.0, ymax=4.0, lskip=2)
    for k in range(0, traj.shape[0], 2):
        scan = S.simulate_scan(truth == OCCUPIED, tinfo, traj[k], MOUNT, SPEC, rng)
        out = mapper.handle_scan(_scan_input(0.1 * k, scan), odom[k], MOUNT)
        assert out.status in (M.STARTED, M.UPDATED, M.SKIPPED)
    est, einfo = mapper.occupancy()
    res = G.map_agreement(est, einfo, truth, tinfo)
    assert res["accuracy"] >= 0.95, res
    assert einfo.xmax > 6.0 and einfo.ymax > 4.0  # grew while exploring
    # the robot pose through the TF chain map->odom->base is close to the truth
    final = P.compose(mapper.map_to_odom(), odom[k])
    assert math.hypot(*(final[:2] - traj[k][:2])) < 0.1
    # ... much closer than the odometry alone
    assert math.hypot(*(final[:2] - traj[k][:2])) < 0.5 * math.hypot(*(odom[k][:2] - traj[k][:2]))


def test_slam_node_params_tf_delay_follows_the_publish_period_and_seed_stays_unset():
    p = from_params(M.SlamNodeParams, {"transform_publish_period": 0.1, "particles": 12}.get)
    assert p.seed is None and p.tf_delay is None and p.tf_delay_s() == 0.1
    assert p.mapper.rbpf.particles == 12
    p = from_params(M.SlamNodeParams, {"tf_delay": 0.0, "seed": 7}.get)
    assert p.tf_delay_s() == 0.0 and p.seed == 7


def test_each_particles_trajectory_rebuilds_its_map_after_resampling():
    """RbpfSlam.trajectory: the poses at which a particle registered its scans, carried
    through resampling with its map, so re-registering the scans there gives its map."""
    from ascc_navigation.posegraph import rebuild_counts

    world = S.office_world()
    cfg = R.RbpfConfig(particles=8, xmin=0, ymin=0, xmax=14, ymax=10, srr=0.05, srt=0.1,
                       str=0.05, stt=0.1, resample_threshold=1.0)  # resample every update
    slam = R.RbpfSlam(cfg, seed=3)
    kw = dict(lskip=2, free_pullback=0.05, hit_offset=0.025)
    truth = [np.array([2.0 + 0.25 * k, 1.8, 0.0]) for k in range(12)]
    scans = [_prepare(_room_scan(p, world=world, noise=0.01, seed=k), **kw)
             for k, p in enumerate(truth)]
    slam.start(truth[0], scans[0])
    resampled = 0
    for k in range(1, len(truth)):
        before = slam.poses.copy()
        delta = P.relative(truth[k - 1], truth[k])
        stats = slam.update(delta, scans[k])
        resampled += stats.resampled
        # what the update reports of its steps: the draws, the matched poses, the ancestry
        np.testing.assert_array_equal(stats.odom_delta, delta)
        assert stats.sampled_poses.shape == stats.weighed_poses.shape == (cfg.particles, 3)
        assert np.abs(stats.sampled_poses[:, :2] - before[:, :2]).max() < 0.5
        if stats.resampled:
            np.testing.assert_array_equal(slam.poses, stats.weighed_poses[stats.resampled_from])
        else:
            assert stats.resampled_from is None
    assert resampled >= 5
    for p in (slam.best, (slam.best + 3) % cfg.particles):
        traj = slam.trajectory(particle=p)
        assert traj.shape == (len(truth), 3)
        np.testing.assert_array_equal(traj[-1], slam.poses[p])
        maps = rebuild_counts(lambda: R.ParticleMaps(1, slam.maps.info), traj, scans)
        np.testing.assert_array_equal(maps.hits[0], slam.maps.hits[p])
        np.testing.assert_array_equal(maps.visits[0], slam.maps.visits[p])
    # particles differ: their trajectories are their own
    assert len({tuple(slam.trajectory(particle=p)[-1]) for p in range(cfg.particles)}) > 1


@pytest.mark.parametrize("heading", [0.1, 0.1 + math.pi / 2])
def test_prior_along_holds_the_position_along_the_heading_only(heading):
    # The office room constrains the pose in every direction; odometry 5 cm off along the
    # robot's heading stays off under a strong prior_along, 5 cm off across it is corrected.
    world = S.office_world()
    true0 = np.array([4.0, 1.8, heading])
    true1 = P.compose(true0, [0.2, 0.0, 0.02])
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    errors = {}
    for along in (0.0, 100.0):
        for name, offset in (("along", [0.05, 0.0, 0.0]), ("across", [0.0, 0.05, 0.0])):
            cfg = R.RbpfConfig(particles=1, xmin=0, ymin=0, xmax=14, ymax=10, srr=0.0,
                               srt=0.0, str=0.0, stt=0.0, motion_prior=0.0, prior_along=along)
            slam = R.RbpfSlam(cfg, seed=0)
            slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
            wrong = P.compose(true1, offset)
            slam.update(P.relative(true0, wrong), _prepare(_room_scan(true1, world=world), **kw))
            err = P.relative(true1, slam.best_pose)   # in the robot's frame at true1
            errors[along, name] = err
    assert math.hypot(*errors[0.0, "along"][:2]) < 0.015     # the scan alone corrects both
    assert math.hypot(*errors[0.0, "across"][:2]) < 0.015
    assert errors[100.0, "along"][0] > 0.04                    # held along the heading ...
    assert math.hypot(*errors[100.0, "across"][:2]) < 0.015    # ... not across it
    with pytest.raises(ValueError, match="prior_along"):
        R.RbpfConfig(prior_along=-1.0).validate()


def test_adaptive_prior_along_pulls_where_the_scan_is_blind_along_the_heading():
    # prior_along_adaptive: the pull along the heading tops up the scan's own information
    # there. In a featureless corridor (nothing along it) it is the full prior_along and
    # holds a 5 cm odometry error along the travel; facing a room's wall it vanishes and
    # the scan corrects the same error, where the fixed pull keeps half of it.
    def step(world, true0, true1, grid, adaptive):
        cfg = R.RbpfConfig(particles=1, xmin=0, ymin=0, xmax=grid[0], ymax=grid[1], srr=0.0,
                           srt=0.0, str=0.0, stt=0.0, motion_prior=0.0, prior_along=15.0,
                           prior_along_adaptive=adaptive)
        slam = R.RbpfSlam(cfg, seed=0)
        kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
        slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
        wrong = P.compose(true1, [0.05, 0.0, 0.0])
        stats = slam.update(P.relative(true0, wrong),
                            _prepare(_room_scan(true1, world=world), **kw))
        full = cfg.prior_along / cfg.prior_min_xy ** 2      # srr 0: the floor's variance
        return stats, full, P.relative(true1, slam.best_pose)[0]

    corridor, start = _corridor_world(), np.array([10.0, 1.5, 0.0])
    stats, full, along = step(corridor, start, start + [0.25, 0.0, 0.0], (40, 3), True)
    assert stats.along_info < 1e-2 * full and stats.along_pull > 0.99 * full
    assert along > 0.045                                      # held to the odometry
    room, start = S.office_world(), np.array([4.0, 1.8, 0.1 + math.pi / 2])
    end = P.compose(start, [0.2, 0.0, 0.02])
    stats, full, along = step(room, start, end, (14, 10), True)
    assert stats.along_info > 2.0 * full and stats.along_pull == 0.0
    assert abs(along) < 0.01                                  # the scan's
    stats, full, along = step(room, start, end, (14, 10), False)
    assert stats.along_pull == full and along > 0.02          # the fixed pull holds it


@pytest.mark.parametrize("oblique", [0.5, -0.6])
def test_blind_prior_along_pulls_along_the_corridor_when_the_robot_drives_obliquely(oblique):
    # prior_along_blind: the pull tops up the scan's least-held direction, not the heading.
    # Driving obliquely down a featureless corridor the heading's information includes the
    # corridor's across, so the heading's pull is mostly off, and little holds the
    # corridor's axis; the blind pull is the full prior_along along that axis (its angle from the
    # heading -oblique), and still lets the scan correct an error across the corridor.
    def step(blind, offset_world):
        cfg = R.RbpfConfig(particles=1, xmin=0, ymin=0, xmax=40, ymax=3, srr=0.0, srt=0.0,
                           str=0.0, stt=0.0, motion_prior=0.0, prior_along=15.0,
                           prior_along_adaptive=True, prior_along_blind=blind)
        slam = R.RbpfSlam(cfg, seed=0)
        kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
        true0 = np.array([10.0, 1.5, oblique])
        true1 = P.compose(true0, [0.25, 0.0, 0.0])
        slam.start(true0, _prepare(_room_scan(true0, world=corridor), **kw))
        wrong = true1 + [offset_world[0], offset_world[1], 0.0]
        stats = slam.update(P.relative(true0, wrong),
                            _prepare(_room_scan(true1, world=corridor), **kw))
        full = cfg.prior_along / cfg.prior_min_xy ** 2      # srr 0: the floor's variance
        return stats, full, slam.best_pose - true1

    corridor = _corridor_world()
    stats, full, _ = step(False, (0.0, 0.0))
    assert stats.along_info > full and stats.along_pull < 0.5 * full  # heading: mostly off
    stats, full, _ = step(True, (0.0, 0.0))
    assert stats.along_info < 1e-2 * full and stats.along_pull > 0.99 * full
    assert stats.along_angle == pytest.approx(-oblique, abs=0.02)      # the corridor's axis
    stats, full, err = step(True, (0.0, 0.05))                # 5 cm across the corridor
    assert abs(err[1]) < 0.015                                # the scan corrects it


@pytest.mark.parametrize("where", ["corridor", "room"])
def test_draw_along_blind_drops_the_draws_spread_only_where_the_scan_cannot_see_it(where):
    # draw_along_blind: in a featureless corridor the weights cannot tell draws along it
    # apart, so the particles keep the odometry's distance there (their spread along the
    # travel goes), and keep the spread across it and in heading; in a room, whose scan
    # holds the position in every direction, the draws are left as they were.
    def sampled(draw):
        world = _corridor_world() if where == "corridor" else S.office_world()
        true0 = np.array([10.0, 1.5, 0.0]) if where == "corridor" else np.array([4.0, 1.8, 0.1])
        true1 = P.compose(true0, [0.25, 0.0, 0.0])
        cfg = R.RbpfConfig(particles=30, xmin=0, ymin=0, xmax=40, ymax=10, srr=0.1, srt=0.2,
                           str=0.0, stt=0.0, prior_along=15.0, prior_along_adaptive=True,
                           draw_along_blind=draw)
        slam = R.RbpfSlam(cfg, seed=4)
        kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
        slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
        stats = slam.update([0.25, 0.0, 0.0], _prepare(_room_scan(true1, world=world), **kw))
        offset = P.relative(true1, stats.sampled_poses)     # in the robot's frame at true1
        return stats, offset.std(axis=0)

    stats0, spread0 = sampled(False)
    stats1, spread1 = sampled(True)
    assert spread0[0] > 0.015 and stats0.draw_along_share == 1.0    # srr 0.1: 2.5 cm
    np.testing.assert_allclose(spread1[1:], spread0[1:], rtol=1e-3)  # across, heading kept
    if where == "corridor":
        assert stats1.draw_along_share < 0.01 and spread1[0] < 0.01 * spread0[0]
    else:
        assert stats1.draw_along_share == 1.0
        np.testing.assert_allclose(spread1, spread0, rtol=1e-9)


def test_wall_axis_pull_moves_the_matched_heading_towards_the_walls_within_its_gate():
    # wall_axis_pull_std_rad: after the climb, one Gauss-Newton step of the match plus the
    # walls' heading prior moves each matched heading towards the one the scan's walls give
    # (the first scan's, modulo a right angle), part of the way (the scan's own heading
    # information weighs in), and its score is recomputed. The gate (three of the pull's
    # std) is on the matched headings; beyond it, or without walls, nothing changes.
    world = _corridor_world()
    kw = dict(max_range=4.5, free_pullback=0.05, hit_offset=0.025)
    cfg = R.RbpfConfig(particles=3, xmin=0, ymin=0, xmax=40, ymax=3, wall_axis_std_rad=0.01,
                       wall_axis_pull_std_rad=0.002)
    slam = R.RbpfSlam(cfg, seed=0)
    true0 = np.array([10.0, 1.5, 0.3])
    slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
    assert slam.wall_reference is not None
    true1 = np.array([10.5, 1.4, 0.25])
    scan = _prepare(_room_scan(true1, world=world), **kw)
    wall = R.scan_wall_axis(scan.hits)
    assert wall.disagreement < 0.006                              # one family of walls
    pts = scan.match
    fields = slam._fields(pts)
    prior = np.array([400.0, 400.0, 400.0])
    for err, pulled in ((0.004, True), (-0.005, True), (0.01, False), (-0.02, False)):
        matched = np.tile(true1, (3, 1))
        matched[:, 2] += err
        score = np.zeros(3)
        before = matched.copy()
        assert slam._wall_axis_pull(wall, fields, pts, prior, matched, score) == pulled
        if pulled:
            left = matched[:, 2] - true1[2]
            assert np.all(np.sign(left) == np.sign(err))          # towards it, not past it
            assert np.all(np.abs(left) < 0.8 * abs(err))          # by a real share
            assert np.all(np.hypot(*(matched[:, :2] - before[:, :2]).T) < 0.02)
            np.testing.assert_allclose(score, fields.match_score(fields.distances(
                matched[:, None, :], np.arange(3), pts), cfg.sigma)[:, 0])
        else:
            np.testing.assert_array_equal(matched, before)
            np.testing.assert_array_equal(score, 0.0)
    matched = np.tile(true1, (3, 1))
    assert not slam._wall_axis_pull(None, fields, pts, prior, matched, np.zeros(3))
    np.testing.assert_array_equal(matched, np.tile(true1, (3, 1)))  # no straight walls


def _wall_axis_update(std, offsets, true0=(4.0, 1.8, 0.1), **cfg_kw):
    """One update in the synthetic office with particles held at the truth turned by
    ``offsets`` [rad] (no motion noise; matched poses not accepted, so they stay)."""
    world = S.office_world()
    true0 = np.array(true0)
    true1 = P.compose(true0, [0.25, 0.0, 0.05])
    kw = dict(lskip=1, free_pullback=0.05, hit_offset=0.025)
    cfg = R.RbpfConfig(particles=len(offsets), xmin=0, ymin=0, xmax=14, ymax=10, srr=0.0,
                       srt=0.0, str=0.0, stt=0.0, resample_threshold=0.0, recover_score=0.0,
                       minimum_score=1e9, wall_axis_std_rad=std, **cfg_kw)
    slam = R.RbpfSlam(cfg, seed=0)
    slam.start(true0, _prepare(_room_scan(true0, world=world), **kw))
    slam.poses[:, 2] += np.asarray(offsets)
    delta = P.relative(true0, true1)
    stats = slam.update(delta, _prepare(_room_scan(true1, world=world), **kw))
    return slam, stats


def test_wall_axis_prior_weighs_each_particles_heading_against_the_first_scans_walls():
    offsets = [0.0, 0.02, -0.04]
    off, off_stats = _wall_axis_update(-1.0, offsets)
    on, on_stats = _wall_axis_update(0.01, offsets)
    assert off.wall_reference is None and not off_stats.wall_axis_used
    # the office's walls lie along the map's axes: the first scan's, placed at the start
    # pose, say so to a milliradian
    assert abs(on.wall_reference) < 2e-3
    assert on_stats.wall_axis_used
    # the prior's term: -e^2 / (2 std^2), e the particle's heading error (to the axis's
    # own error of a milliradian or two), capped at the gate (0.03: the -0.04 particle)
    extra = on_stats.log_gain - off_stats.log_gain
    expected = -np.square(np.minimum(np.abs(offsets), 0.03)) / (2 * 0.01 ** 2)
    assert np.allclose(extra, expected, atol=1.0)
    assert extra[0] > extra[1] > extra[2]


def test_wall_axis_prior_leaves_out_walls_off_the_first_scans_directions():
    # all particles 0.3 rad off: the scan's walls then lie 0.3 rad from the reference
    # directions (beyond wall_axis_gate_rad 0.03), as walls not at right angles would
    off, off_stats = _wall_axis_update(-1.0, [0.3, 0.31])
    on, on_stats = _wall_axis_update(0.01, [0.3, 0.31])
    assert on_stats.wall_axis is not None and not on_stats.wall_axis_used
    assert np.allclose(on_stats.log_gain, off_stats.log_gain)
    # walls 0.062 rad off (the held-out annex world's skewed side): left out by the shipped
    # gate, weighed (and so bent towards the first walls' axes) by a 0.1 rad gate
    _, narrow = _wall_axis_update(0.01, [0.062, 0.063])
    _, wide = _wall_axis_update(0.01, [0.062, 0.063], wall_axis_gate_rad=0.1)
    assert not narrow.wall_axis_used and wide.wall_axis_used
    with pytest.raises(ValueError, match="wall_axis_gate_rad"):
        R.RbpfConfig(wall_axis_gate_rad=1.0).validate()
