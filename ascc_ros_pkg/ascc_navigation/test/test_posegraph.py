"""Tests of the mapper's loop closure (``ascc_navigation.posegraph``), no ROS master: a
synthetic office loop whose pose estimates carry a known injected drift, a false loop
candidate, an ambiguous corridor match, the correction bound, and the mapper with it on."""

import copy
import math

import numpy as np
import pytest

from ascc_common import pose2d as P
from ascc_common.grid import OCCUPIED
from ascc_common.params import from_params, parameters
from ascc_navigation import grid as G
from ascc_navigation import mapper as M
from ascc_navigation import posegraph as PG
from ascc_navigation import rbpf as R
from ascc_navigation import synthetic as S
from ascc_navigation.laser import LaserMount, prepare_scan

SPEC = S.LaserSpec()
MOUNT = LaserMount(0.05, 0.0, 0.0)
KEYFRAME_M = 0.25  # the shipped linearUpdate


def _prepare(ranges):
    return prepare_scan(ranges, SPEC.angle_min, SPEC.angle_increment, SPEC.range_min,
                        SPEC.range_max, MOUNT, 3.9, max_range=4.5, lskip=2,
                        free_pullback=0.05, hit_offset=0.025)


def _keyframes(world, waypoints, seed=0):
    """True keyframe poses (one per 0.25 m or 0.25 rad, as the filter updates) along the
    waypoint route, and their scans (1 cm range noise)."""
    traj = S.waypoint_trajectory(waypoints, v=0.3, w=0.8, dt=0.1)
    keep = [0]
    for k in range(1, traj.shape[0]):
        d = P.relative(traj[keep[-1]], traj[k])
        if math.hypot(d[0], d[1]) >= KEYFRAME_M or abs(d[2]) >= 0.25:
            keep.append(k)
    truth = traj[keep]
    rng = np.random.default_rng(seed)
    occupied = world[0] == OCCUPIED
    scans = [_prepare(S.simulate_scan(occupied, world[1], p, MOUNT, SPEC, rng))
             for p in truth]
    return truth, scans


def _drifted_increments(truth, rad_per_m):
    """Motion as a drifting filter estimates it: the true increments with an extra heading
    error of ``rad_per_m`` per metre driven (the injected drift)."""
    inc = P.relative(truth[:-1], truth[1:])
    inc[:, 2] += rad_per_m * np.hypot(inc[:, 0], inc[:, 1])
    return inc


def _odometry(truth, rng, noise=0.01):
    """Odometry increments: the truth's with a little noise [m, rad per step]."""
    inc = P.relative(truth[:-1], truth[1:])
    return inc + noise * rng.standard_normal(inc.shape) * np.array([1.0, 1.0, 0.5])


def _feed(graph, truth, scans, drift_inc, odom, first, last):
    """Keyframes first..last-1; each estimate is the previous node's (corrected, if a loop
    closed) composed with the drifting increment, as the filter continues after a closure."""
    results = []
    for k in range(first, last):
        est = truth[0] if k == 0 else P.compose(graph.poses[-1], drift_inc[k - 1])
        results.append(graph.add_keyframe(est, scans[k], np.zeros(3) if k == 0
                                          else odom[k - 1]))
    return results


def _pose_error(poses, truth):
    return np.hypot(poses[:, 0] - truth[:, 0], poses[:, 1] - truth[:, 1])


def _map_accuracy(poses, scans, world):
    info = world[1]
    maps = PG.rebuild_counts(lambda: R.ParticleMaps(1, info), poses, scans)
    grid = maps.occupancy(0, 0.25)
    return G.map_agreement(grid, maps.info, world[0], info)["accuracy"]


@pytest.fixture(scope="module")
def office_loop():
    """The synthetic office loop (about 33 m) driven with a heading drift of 0.004 rad/m,
    fed to a graph up to where the robot is about to re-enter the start area (the
    expensive part, shared; each test continues a copy)."""
    world = S.office_world()
    truth, scans = _keyframes(world, S.office_loop_waypoints())
    drift = _drifted_increments(truth, 0.004)
    odom = _odometry(truth, np.random.default_rng(1))
    back = np.hypot(truth[:, 0] - truth[0, 0], truth[:, 1] - truth[0, 1]) < 5.0
    path = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(truth[:, :2], axis=0).T))])
    split = int(np.nonzero(back & (path > 20.0))[0][0])
    graph = PG.PoseGraph(PG.LoopClosureConfig(enabled=False))
    _feed(graph, truth, scans, drift, odom, 0, split)
    return world, truth, scans, drift, odom, split, graph


def _continue(office_loop, **cfg):
    world, truth, scans, drift, odom, split, graph = office_loop
    graph = copy.deepcopy(graph)
    graph.cfg = PG.LoopClosureConfig(enabled=True, **cfg)
    results = _feed(graph, truth, scans, drift, odom, split, truth.shape[0])
    return graph, results


@pytest.mark.parametrize("solver", ["trust_region", "direct"])
def test_loop_with_injected_drift_is_closed(office_loop, solver):
    world, truth, scans, drift, odom, split, _ = office_loop
    open_loop = PG.PoseGraph(PG.LoopClosureConfig(enabled=False))
    open_loop.poses = truth[:1].copy()
    for inc in drift:
        open_loop.poses = np.vstack([open_loop.poses, P.compose(open_loop.poses[-1], inc)])
    before = _pose_error(open_loop.poses, truth)
    assert 0.3 < before[-1] < 0.8  # the drift is real, and within the search window
    graph, results = _continue(office_loop, window_m=0.8, solver=solver)
    closed = [r for r in results if r.status == "closed"]
    assert closed, [r.reason for r in results if r.status != "none"]
    # the loop edge joins the way back to the start (>= loop_min_travel_m of path apart)
    first = split + results.index(closed[0])
    assert graph.path_m[first] - graph.path_m[closed[0].anchor] >= graph.cfg.min_travel_m
    # the corrected trajectory is much nearer the truth than the drifted one
    after = _pose_error(graph.poses, truth)
    assert after.mean() < 0.4 * before.mean(), (after.mean(), before.mean())
    assert after.max() < 0.5 * before.max(), (after.max(), before.max())
    # the map rebuilt from the corrected keyframes agrees better with the floor plan
    acc_before = _map_accuracy(open_loop.poses, scans, world)
    acc_after = _map_accuracy(graph.poses, scans, world)
    assert acc_after > acc_before + 0.03, (acc_before, acc_after)
    print("office loop, 0.004 rad/m drift, %s: keyframe error mean %.3f -> %.3f m, max "
          "%.3f -> %.3f m; map agreement %.1f -> %.1f %%"
          % (solver, before.mean(), after.mean(), before.max(), after.max(),
             100 * acc_before, 100 * acc_after))


def test_correction_bound_rejects_a_large_closure(office_loop):
    split = office_loop[5]
    graph, results = _continue(office_loop, window_m=0.8, max_correction_m=0.15)
    rejected = [r for r in results if r.status == "rejected" and "loop_max_correction_m"
                in r.reason]
    assert rejected and all(r.correction_m > 0.15 for r in rejected)
    assert not [r for r in results if r.status in ("closed", "kept")]
    # nothing applied: no node moved, no loop edge stayed in the graph
    assert np.array_equal(graph.poses[:split], office_loop[6].poses)
    assert graph.loop_edges == 0
    assert all(j == i + 1 for i, j, _, _ in graph.edges)


def test_false_loop_candidate_is_rejected(office_loop):
    """A keyframe whose estimate lies within the search radius of the start, but whose
    scan was taken elsewhere (in a north room): no match, no edge, no correction."""
    world = office_loop[0]
    truth = office_loop[1]
    graph = copy.deepcopy(office_loop[6])
    graph.cfg = PG.LoopClosureConfig(enabled=True)
    elsewhere = np.array([8.0, 8.4, math.pi / 2])  # in a north room, facing north
    scan = _prepare(S.simulate_scan(world[0] == OCCUPIED, world[1], elsewhere, MOUNT, SPEC,
                                    np.random.default_rng(3)))
    claimed = truth[2] + np.array([0.3, 0.2, 0.05])  # the estimate says: back at the start
    graph._next_check_m = 0.0
    poses_before = graph.poses.copy()
    result = graph.add_keyframe(claimed, scan, np.zeros(3))
    assert result.status == "rejected"
    assert "loop_min_score" in result.reason
    assert result.score < graph.cfg.min_score
    assert graph.loop_edges == 0
    assert np.array_equal(graph.poses[:-1], poses_before)


def test_corridor_match_fixes_only_the_lateral_position_and_heading():
    """In a straight corridor without features a scan slides along the walls: a loop match
    there must constrain the lateral position and the heading, not the position along the
    corridor (which it cannot know), and must not move the trajectory along it."""
    world = S.rect_world((28.0, 2.6), 0.05, [])
    truth, scans = _keyframes(world, [(6.0, 1.3), (19.0, 1.3), (12.0, 1.3)])
    cfg = PG.LoopClosureConfig(enabled=True)
    graph = PG.PoseGraph(cfg)
    # the estimates slide 2 cm per metre along the corridor on the way back
    inc = P.relative(truth[:-1], truth[1:])
    results = _feed(graph, truth, scans, inc, _odometry(truth, np.random.default_rng(4)), 0,
                    truth.shape[0])
    searched = [r for r in results if r.status != "none"]
    assert searched, "the way back passes the keyframes of the way out"
    loops = [w for i, j, _, w in graph.edges if j != i + 1]
    for w in loops:
        # anchor frame x = along the corridor (the anchor faces east or west)
        assert np.abs(w[:2, 0]).max() < 1e-2 * np.abs(w[:2, 1]).max(), w
        assert w[2, 2] > 0.0
    assert loops or all(r.status == "rejected" for r in searched)
    assert _pose_error(graph.poses, truth).max() < 0.1


def test_the_seen_space_is_the_union_of_the_scans_polygons():
    """Space that two, three or four keyframes' scans all saw is seen: the polygons are
    filled one by one (one ``cv2.fillPoly`` call on all of them fills by the even-odd rule
    and leaves space seen by an even number of scans out: along a corridor driven in 0.25 m
    steps, stripes of it)."""
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    polys = [square + [0.5 * k, 0.0] for k in range(4)]  # overlapping 1-4 deep
    field = PG.LikelihoodField(np.array([[0.0, 0.0], [3.5, 2.0]]), 0.02, 0.5, 0.15, polys)
    inside = np.array([[0.25 + 0.5 * k, 1.0] for k in range(7)])  # seen by 1, 2, 3, 4, 3, 2, 1
    assert field.seen_share(np.zeros(3), inside) == 1.0
    outside = np.array([[-0.2, 1.0], [3.7, 1.0], [1.0, 2.2], [1.0, -0.2]])
    assert field.seen_share(np.zeros(3), outside) == 0.0


@pytest.mark.parametrize("x", [4.3, 4.5, 4.8])
def test_a_loop_match_scores_only_what_the_submap_saw(x):
    """A submap of keyframes driven east from x = 5 m along a corridor (a door recess at 8-9
    m on one side) and a scan from x m, which sees the walls behind it past where the
    submap's scans saw (the URG's 240 degrees): counted as misses, those end points pull
    the match east onto the submap's walls (0.2-0.7 m, with a claimed std along of
    0.15-0.2 m); scored only where the submap saw, the match keeps the lateral position and
    heading and does not claim the position along the corridor (its std there above
    loop_max_spread_m) or rests on too little to be used (``min_seen_share``)."""
    world = S.rect_world((30.0, 3.2), 0.05, [(0.0, 2.6, 8.0, 3.2), (9.0, 2.6, 30.0, 3.2)])
    truth, scans = _keyframes(world, [(5.0, 1.3), (9.0, 1.3)])
    pose = np.array([x, 1.3, 0.0])
    scan = _prepare(S.simulate_scan(world[0] == OCCUPIED, world[1], pose, MOUNT, SPEC,
                                    np.random.default_rng(1)))
    cloud = np.vstack([PG._transform(p, PG._surface_points(s.origin, s.hits, 0.025)
                                     .astype(float)) for p, s in zip(truth, scans)])
    pts = PG._subsample(PG._surface_points(scan.origin, scan.match, 0.025).astype(float), 400)
    cfg = PG.LoopClosureConfig()
    guess = pose + np.array([0.2, 0.05, 0.01])

    def match(seen):
        field = PG.LikelihoodField(cloud, cfg.coarse_step_m, 6.0, 3.0 * cfg.match_sigma_m,
                                   seen)
        best, _, cov, _ = PG.correlative_match(
            field, pts, guess, cfg.window_m, cfg.window_rad, cfg.coarse_step_rad,
            cfg.match_sigma_m, coarse_points=cfg.coarse_points,
            seen_floor_share=cfg.seen_floor_share)
        return best - pose, np.sqrt(np.diag(cov)), field.seen_share(best, pts)

    err, _, _ = match(None)
    assert err[0] > 0.15, err  # pulled east, onto more of the submap's walls
    seen = [PG._transform(p, PG._seen_polygon(s, 3.0 * cfg.match_sigma_m))
            for p, s in zip(truth, scans)]
    err, std, share = match(seen)
    assert abs(err[1]) < 0.02 and abs(err[2]) < 0.01, err
    assert std[0] > cfg.max_spread_m or share < cfg.min_seen_share, (err, std, share)


def test_optimise_distributes_a_loop_residual():
    """Back end alone: a square of 4 x 10 unit steps whose odometry edges turn 1 degree
    too little each; one loop edge end -> start makes the optimised square close."""
    graph, truth = _square_with_turn_errors()
    assert _pose_error(graph.poses, truth)[-1] > 0.3
    r = graph.close_loop(0, 40, np.zeros(3), np.array([20.0, 20.0, 50.0]))
    assert r.status == "closed"
    assert math.hypot(*graph.poses[-1, :2]) < 0.1
    assert abs(P.wrap_angle(graph.poses[-1, 2])) < 0.02


def _square_with_turn_errors():
    """The square of ``test_optimise_distributes_a_loop_residual``: truth, and a graph of
    its edges with turns 1 degree short and the loop edge end -> start not yet added."""
    graph = PG.PoseGraph(PG.LoopClosureConfig(min_correction_m=0.0, max_correction_m=10.0,
                                              wall_headings=True))
    truth, est = [np.zeros(3)], [np.zeros(3)]
    for k in range(40):
        corner = k % 10 == 9
        truth.append(P.compose(truth[-1], np.array([1.0, 0.0, math.pi / 2 if corner else 0.0])))
        z = np.array([1.0, 0.0, math.pi / 2 - math.radians(1.0) if corner else 0.0])
        est.append(P.compose(est[-1], z))
        graph.edges.append((k, k + 1, z, np.array([10.0, 10.0, 50.0])))
    graph.poses = np.array(est)
    return graph, np.array(truth)


def _hold_headings(graph, truth):
    """Every other node of the square saw walls: the filter's heading there (the walls held
    it: the true heading) becomes a heading measurement with a 0.01 rad std."""
    graph.headings = np.full(truth.shape[0], np.nan)
    graph.headings[::2] = truth[::2, 2]
    graph.heading_std_rad = 0.01


def test_wall_headings_hold_the_headings_while_a_loop_closes():
    """Keyframes where the filter's wall-axis prior held carry the filter's heading there
    into the graph (the walls held it: here the true heading, while the square's edges
    turn 1 degree short at each corner): the loop edge then moves positions, not
    headings, and the square closes on the truth, not on a rotated copy of it."""
    plain, truth = _square_with_turn_errors()
    plain.cfg.wall_headings = False
    held, _ = _square_with_turn_errors()
    for graph in (plain, held):
        _hold_headings(graph, truth)
        assert graph.close_loop(0, 40, np.zeros(3), np.array([20.0, 20.0, 50.0])).status \
            == "closed"
    heading = {n: np.abs(P.wrap_angle(g.poses[:, 2] - truth[:, 2]))
               for n, g in (("plain", plain), ("held", held))}
    position = {n: np.hypot(*(g.poses[:, :2] - truth[:, :2]).T)
                for n, g in (("plain", plain), ("held", held))}
    assert heading["plain"].mean() > math.radians(0.2)   # the closure turned whole sides
    assert heading["held"].mean() < 0.3 * heading["plain"].mean()
    assert position["held"].mean() < 0.25 * position["plain"].mean()


@pytest.mark.parametrize("walls", [False, True])
def test_direct_solve_reaches_the_minimum(walls):
    """``loop_solver`` direct (Gauss-Newton on the sparse normal equations) closes the
    square to a cost no higher than the trust region's, with or without the wall-heading
    measurements, and to the same poses within a few millimetres (the trust region's 20
    evaluations end near the minimum on a graph this small)."""
    out = {}
    for solver in ("trust_region", "direct"):
        graph, truth = _square_with_turn_errors()
        graph.cfg.solver = solver
        if walls:
            _hold_headings(graph, truth)
        assert graph.close_loop(0, 40, np.zeros(3), np.array([20.0, 20.0, 50.0])).status \
            == "closed"
        out[solver] = graph
    direct, trust = out["direct"], out["trust_region"]
    assert direct.last_cost <= trust.last_cost + 1e-9, (direct.last_cost, trust.last_cost)
    assert np.hypot(*(direct.poses[:, :2] - trust.poses[:, :2]).T).max() < 0.005
    assert math.hypot(*direct.poses[40, :2]) < 0.1


def test_a_loop_match_closes_only_with_a_second_that_agrees():
    """``loop_confirm``: the first accepted match waits; a second that disagrees with it
    (optimised together, a residual beyond confirm_sigmas of its stds) drops the first,
    and one that agrees closes the loop with both. The square's end, node 40, is back at
    the start; a wrong match puts it 0.8 m along the first side, as a corridor match can."""
    graph, truth = _square_with_turn_errors()
    graph.cfg.confirm = True
    w = np.array([20.0, 20.0, 50.0])
    before = graph.poses.copy()
    wrong = graph.propose_loop(0, 40, np.array([0.8, 0.0, 0.0]), w, "wrong")
    assert wrong.status == "pending"
    np.testing.assert_array_equal(graph.poses, before)   # nothing applied yet
    right = P.relative(truth[1], truth[40])
    r = graph.propose_loop(1, 40, right, w, "right")
    assert r.status == "rejected" and "disagree" in r.reason, r.reason
    np.testing.assert_array_equal(graph.poses, before)
    assert len(graph.edges) == 40                          # no loop edge kept
    r = graph.propose_loop(2, 40, P.relative(truth[2], truth[40]), w, "right again")
    assert r.status == "closed", r.reason
    assert graph.loop_edges == 2 and graph.pending is None
    assert math.hypot(*graph.poses[40, :2]) < 0.1          # the square closed
    # without loop_confirm the wrong match alone would have closed it, 0.8 m off
    graph, _ = _square_with_turn_errors()
    graph.cfg.confirm = False
    assert graph.propose_loop(0, 40, np.array([0.8, 0.0, 0.0]), w).status == "closed"
    assert math.hypot(*graph.poses[40, :2]) > 0.6


def test_a_pair_closes_only_the_axes_both_matches_fix():
    """``loop_confirm`` with a first match that fixes both position axes, 0.8 m wrong along
    the square's first side (as a corridor match can be while claiming an 11 cm std), and a
    right second one that leaves that axis free (a corridor's match often does): the
    second cannot disagree along it, so the first's information along it is dropped and
    the pair closes across it and in heading only. Before, the pair closed with the wrong
    0.8 m (node 40 ended 0.8 m along the first side)."""
    graph, truth = _square_with_turn_errors()
    graph.cfg.confirm = True
    assert graph.propose_loop(0, 40, np.array([0.8, 0.0, 0.0]), np.array([20.0, 20.0, 50.0]),
                              "wrong along").status == "pending"
    r = graph.propose_loop(1, 40, P.relative(truth[1], truth[40]), np.array([0.0, 20.0, 50.0]),
                           "right, along free")
    assert r.status == "closed", r.reason
    first, second = graph.edges[-2], graph.edges[-1]
    assert (first[0], second[0]) == (0, 1)
    np.testing.assert_allclose(first[3][:, 0], 0.0, atol=1e-9)  # no information along x
    np.testing.assert_allclose(np.abs(first[3][1:, 1:]), [[20.0, 0.0], [0.0, 50.0]],
                               atol=1e-9)  # the rest kept
    assert math.hypot(*graph.poses[40, :2]) < 0.1  # the square closed, not 0.8 m off


def test_the_rest_of_a_match_waits_for_the_next_one():
    """``loop_confirm`` (``confirm_rest``): a first match that leaves the position along the
    square's first side free and a second that fixes it close across it and in heading;
    the second's information along it waits (its rest) and closes with a third that fixes
    it too; the same in the other order. A rest 0.8 m wrong along it is dropped by a right
    third match, which waits."""
    def square():
        graph, truth = _square_with_turn_errors()
        graph.cfg.confirm = True
        return graph, truth, lambda k: P.relative(truth[k], truth[40])

    both, across = np.array([20.0, 20.0, 50.0]), np.array([0.0, 20.0, 50.0])
    graph, truth, right = square()
    assert graph.propose_loop(0, 40, right(0), across, "across").status == "pending"
    assert graph.propose_loop(1, 40, right(1), both, "both").status == "closed"
    rest = graph.pending
    assert rest is not None and rest[6] and rest[:2] == (1, 40)
    np.testing.assert_allclose(np.abs(rest[3]), [[20.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                                                 [0.0, 0.0, 0.0]], atol=1e-9)  # along only
    after_two = math.hypot(*graph.poses[40, :2])
    r = graph.propose_loop(2, 40, right(2), both, "both again")
    assert r.status in ("closed", "kept"), r.reason
    assert graph.loop_edges == 4
    assert math.hypot(*graph.poses[40, :2]) < min(0.5 * after_two, 0.02), after_two
    # the same with the match that fixes both first: its rest waits
    graph, truth, right = square()
    graph.propose_loop(0, 40, right(0), both, "both")
    assert graph.propose_loop(1, 40, right(1), across, "across").status == "closed"
    assert graph.pending is not None and graph.pending[6] and graph.pending[0] == 0
    assert graph.propose_loop(2, 40, right(2), both).status in ("closed", "kept")
    assert graph.loop_edges == 4 and math.hypot(*graph.poses[40, :2]) < 0.02
    # without the rest the along information of match 1 is dropped: the third waits
    graph, truth, right = square()
    graph.cfg.confirm_rest = False
    graph.propose_loop(0, 40, right(0), across)
    graph.propose_loop(1, 40, right(1), both)
    assert graph.pending is None
    assert graph.propose_loop(2, 40, right(2), both).status == "pending"
    # a wrong rest: the second match 0.8 m off along the side
    graph, truth, right = square()
    graph.propose_loop(0, 40, right(0), across, "across")
    wrong = right(1) + np.array([0.8, 0.0, 0.0])
    assert graph.propose_loop(1, 40, wrong, both, "wrong along").status == "closed"
    assert graph.pending is not None and graph.pending[6]
    r = graph.propose_loop(2, 40, right(2), both, "right")
    assert r.status == "rejected" and "disagree" in r.reason, r.reason
    assert graph.pending[4] == "right" and not graph.pending[6]  # the right one waits
    assert graph.loop_edges == 2


def test_mapper_closes_the_office_loop_and_keeps_tf_consistent():
    """The node's core with loop closure on, drifting odometry: the loop is
    found, the map agrees with the truth, and map -> odom -> base is the corrected pose."""
    cfg = from_params(M.MapperConfig, {"linearUpdate": 0.25, "angularUpdate": 0.25,
                                       "maxUrange": 3.9, "maxRange": 4.5, "lskip": 2,
                                       "srr": 0.03, "str": 0.05, "iterations": 8,
                                       "particles": 10, "loop_closure": True}.get)
    assert cfg.loop.enabled
    world = S.office_world()
    traj = S.waypoint_trajectory(S.office_loop_waypoints(), v=0.3, w=0.6, dt=0.4)
    rng = np.random.default_rng(5)
    odom = S.noisy_odometry(traj, rng, rot_bias=0.02)
    mapper = M.SlamMapper(cfg, seed=5)
    occupied = world[0] == OCCUPIED
    loops = []
    for k in range(traj.shape[0]):
        out = mapper.handle_scan(M.ScanInput(0.4 * k, S.simulate_scan(
            occupied, world[1], traj[k], MOUNT, SPEC, rng), SPEC.angle_min,
            SPEC.angle_increment, SPEC.range_min, SPEC.range_max), odom[k], MOUNT)
        if out.loop is not None and out.loop.status != "none":
            loops.append(out.loop)
            if out.loop.status == "closed":
                # TF stays consistent: map->odom composed with odometry = corrected pose
                np.testing.assert_allclose(P.compose(mapper.map_to_odom(), odom[k]),
                                           mapper.graph.poses[-1], atol=1e-9)
    assert [r for r in loops if r.status in ("closed", "kept")], [r.reason for r in loops]
    grid, info = mapper.occupancy()
    assert set(np.unique(grid)) <= {-1, 0, 100}
    assert G.map_agreement(grid, info, world[0], world[1])["accuracy"] > 0.95
    end = P.compose(mapper.map_to_odom(), odom[-1])
    assert math.hypot(end[0] - traj[-1, 0], end[1] - traj[-1, 1]) < 0.15


def test_loop_parameters_have_units_and_names():
    names = {p.name: p for p in parameters(M.MapperConfig)}
    for name in ("loop_closure", "loop_search_radius_m", "loop_min_travel_m",
                 "loop_check_every_m", "loop_window_m", "loop_window_rad", "loop_min_score",
                 "loop_max_spread_m", "loop_max_spread_rad", "loop_max_correction_m",
                 "loop_min_correction_m"):
        assert name in names
        assert "[" in names[name].doc or name == "loop_closure"


def test_scan_information_has_none_along_a_featureless_corridor():
    """ICP information of a corridor's two walls: position across and heading determined,
    none along it; a wall across the corridor adds it. A geometry edge there takes the
    position along the corridor from the odometry, the rest from the front end."""
    x = np.linspace(-3.0, 3.0, 241)
    walls = np.vstack([np.column_stack([x, np.full_like(x, 1.2)]),
                       np.column_stack([x[::-1], np.full_like(x, -1.2)])])
    info = PG.scan_information(walls, 0.05, 120)
    assert abs(info[0, 0]) < 1e-9 and info[1, 1] > 1e4 and info[2, 2] > 1e4
    end = np.column_stack([np.full(49, 3.0), np.linspace(-1.2, 1.2, 49)])
    closed = PG.scan_information(np.vstack([walls[:241], end, walls[241:]]), 0.05, 120)
    assert closed[0, 0] > 1e3
    graph = PG.PoseGraph(PG.LoopClosureConfig())
    graph._scan_info = info[None].repeat(2, axis=0)
    odom = np.array([0.25, 0.0, 0.0])
    graph._odom = np.vstack([np.zeros(3), odom])
    graph._odom_info = np.stack([np.eye(3), graph._odometry_information(odom)])
    front_end = np.array([0.31, 0.004, 0.002])  # 6 cm too far along, 4 mm across
    z, w = graph._geometry_edges(np.array([1]), front_end[None])
    assert abs(z[0, 0] - 0.25) < 0.002           # along: the odometry's
    assert abs(z[0, 1] - 0.004) < 0.001          # across and heading: the front end's
    assert abs(z[0, 2] - 0.002) < 0.0005
    c, s = math.cos(front_end[2]), math.sin(front_end[2])  # scan info into frame k-1
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(w[0].T @ w[0], rot @ info @ rot.T + graph._odom_info[1],
                               rtol=1e-9, atol=1e-6)
