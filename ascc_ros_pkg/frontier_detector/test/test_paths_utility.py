"""Unit tests of path lengths, the utility terms, scenario detection and goal selection."""

import heapq
import math

import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from frontier_detector.frontiers import FrontierParams, traversable_mask
from frontier_detector.goal_selection import STATUS_ALL_BLACKLISTED, PlannerParams, plan
from frontier_detector.paths import DC, DR, MOVES, block_size, build_graph, path_lengths
from frontier_detector.scenario import CORRIDOR, ROOM, ScenarioParams, classify
from frontier_detector.utility import (
    UtilityParams,
    cast_rays,
    entropy_weight,
    ray_offsets,
    score_candidates,
)

RES = 0.05


def lengths(grid, start_rc, k):
    trav = traversable_mask(grid, 0.0)
    g = build_graph(trav, k)
    return g, path_lengths(g, g.node(*start_rc), RES)


def _reference_lengths(graph, start):
    """Independent reference: Dijkstra on (steps, length) keys, one node at a time; the
    length is summed in float32 like path_lengths, so the two must agree exactly."""
    step = [np.float32(1.0)] * 4 + [np.float32(math.sqrt(2))] * 4
    best = {start: (0, np.float32(0.0))}
    heap = [(0, np.float32(0.0), start)]
    done = set()
    while heap:
        s, length, node = heapq.heappop(heap)
        if node in done:
            continue
        done.add(node)
        for d in range(8):
            if not MOVES[graph.allow[node], d]:
                continue
            nb = node + int(DR[d]) * graph.shape[1] + int(DC[d])
            key = (s + 1, np.float32(length + step[d]))
            if nb not in best or key < best[nb]:
                best[nb] = key
                heapq.heappush(heap, (key[0], key[1], nb))
    out = np.full(graph.allow.size, np.inf, np.float32)
    for node, (_, length) in best.items():
        out[node] = length
    return out * np.float32(graph.k * RES)


@pytest.mark.parametrize("seed", range(6))
def test_path_lengths_equal_a_lexicographic_dijkstra_on_random_maps(seed):
    """The vectorised breadth-first search (fewest steps, then shortest) against a plain
    reference on random cluttered masks, block sizes 1..5."""
    rng = np.random.default_rng(seed)
    h, w = (int(v) for v in rng.integers(30, 90, 2))
    k = int(rng.integers(1, 6))
    h, w = h - h % k + k, w - w % k + k
    grid = np.zeros((h, w), np.int8)
    grid[rng.random((h, w)) < 0.08] = OCCUPIED
    for _ in range(4):
        r, c = int(rng.integers(0, h)), int(rng.integers(0, w))
        grid[r, : int(rng.integers(0, w))] = OCCUPIED
        grid[: int(rng.integers(0, h)), c] = OCCUPIED
    grid[h // 2 - 2 * k: h // 2 + 2 * k, w // 2 - 2 * k: w // 2 + 2 * k] = FREE
    trav = traversable_mask(grid, 0.0)
    g = build_graph(trav, k)
    start = g.node(h // 2, w // 2)
    got = path_lengths(g, start, RES)
    want = _reference_lengths(g, start)
    assert np.isfinite(got).sum() > 10
    np.testing.assert_array_equal(got, want)


def _reference_allow(mask, k):
    """The move bits by their definition (paths.py's docstring), block by block."""
    hc, wc = mask.shape[0] // k, mask.shape[1] // k
    t = mask != 0

    def east(i, j):        # block (i, j) -> (i, j + 1)
        return 0 <= i < hc and 0 <= j < wc - 1 and bool(
            (t[i * k: i * k + k, j * k + k - 1] & t[i * k: i * k + k, j * k + k]).any())

    def south(i, j):       # block (i, j) -> (i + 1, j)
        return 0 <= i < hc - 1 and 0 <= j < wc and bool(
            (t[i * k + k - 1, j * k: j * k + k] & t[i * k + k, j * k: j * k + k]).any())

    allow = np.zeros((hc + 2, wc + 2), np.uint8)
    for i in range(hc):
        for j in range(wc):
            moves = [east(i, j), east(i, j - 1), south(i, j), south(i - 1, j),
                     (east(i, j) and south(i, j + 1)) or (south(i, j) and east(i + 1, j)),
                     (east(i, j - 1) and south(i, j - 1)) or (south(i, j) and east(i + 1, j - 1)),
                     (east(i, j) and south(i - 1, j + 1)) or (south(i - 1, j) and east(i - 1, j)),
                     (east(i, j - 1) and south(i - 1, j - 1))
                     or (south(i - 1, j) and east(i - 1, j - 1))]
            allow[i + 1, j + 1] = sum(1 << d for d, m in enumerate(moves) if m)
    return allow.ravel()


@pytest.mark.parametrize("seed", range(4))
def test_build_graph_equals_the_definition(seed):
    """Random masks of 1 x 1 to 9 x 9 blocks of 1..5 cells, sparse to nearly full."""
    rng = np.random.default_rng(seed)
    for _ in range(12):
        k = int(rng.integers(1, 6))
        h, w = (k * int(v) for v in rng.integers(1, 10, 2))
        mask = ((rng.random((h, w)) < rng.uniform(0.3, 0.95)) * 255).astype(np.uint8)
        g = build_graph(mask, k)
        assert g.shape == (h // k + 2, w // k + 2)
        assert np.array_equal(g.allow, _reference_allow(mask, k)), (k, h, w)


def test_build_graph_same_for_uint8_and_bool_masks():
    """build_graph's OpenCV reduction (uint8) and numpy's (other dtypes) give one graph."""
    rng = np.random.default_rng(3)
    trav = np.where(rng.random((60, 75)) < 0.7, 255, 0).astype(np.uint8)
    a = build_graph(trav, 5)
    b = build_graph(trav > 0, 5)
    np.testing.assert_array_equal(a.allow, b.allow)
    assert a.allow.any()


def test_block_size_is_capped_by_clearance():
    assert block_size(0.05, 0.18, 0.25) == 5          # 5 * 0.05 * sqrt 2 < 2 * 0.18
    assert block_size(0.05, 0.18, 1.0) == 5
    assert block_size(0.05, 0.30, 0.25) == 5
    assert block_size(0.05, 0.30, 1.0) == 8
    assert block_size(0.05, 0.0, 1.0) == 1


def test_open_space_gives_octile_distance():
    grid = np.zeros((100, 100), np.int8)
    g, d = lengths(grid, (0, 0), 1)
    assert d[g.node(0, 60)] == pytest.approx(60 * RES)
    assert d[g.node(40, 40)] == pytest.approx(40 * math.sqrt(2) * RES, rel=1e-5)
    # octile: 60 straight-ish + 30 diagonal cells
    assert d[g.node(30, 90)] == pytest.approx((60 + 30 * math.sqrt(2)) * RES, rel=1e-5)


def test_wall_forces_detour_and_blocks_completely():
    grid = np.zeros((60, 60), np.int8)
    grid[:50, 30] = OCCUPIED                           # wall with a gap at the bottom
    g, d = lengths(grid, (5, 25), 1)
    around = d[g.node(5, 35)]
    assert around > 2 * 10 * RES
    assert around == pytest.approx((2 * 45 + 10) * RES, rel=0.15)
    grid[:, 30] = OCCUPIED                             # closed wall
    g, d = lengths(grid, (5, 25), 1)
    assert np.isinf(d[g.node(5, 35)])


def test_coarse_blocks_do_not_leak_through_a_one_cell_wall():
    grid = np.zeros((100, 100), np.int8)
    grid[:, 52] = OCCUPIED
    grid[95:, 52] = FREE                               # gap far south
    trav = traversable_mask(grid, 0.18 / RES)
    k = block_size(RES, 0.18, 0.25)
    g = build_graph(trav, k)
    d = path_lengths(g, g.node(5, 45), RES)
    east = d[g.node(5, 60)]
    assert east > 4.0                                  # via the gap, ~ 2 x 4.5 m
    assert east == pytest.approx(2 * 4.6, rel=0.2)


def test_ray_casting_terms():
    p = UtilityParams(sensor_range_m=1.0, n_rays=72, loc_sectors=8)
    # Candidate in free space with unknown all around beyond 0.5 m.
    g = np.full((101, 101), UNKNOWN, np.int8)
    yy, xx = np.mgrid[:101, :101]
    g[(yy - 50) ** 2 + (xx - 50) ** 2 <= 10 ** 2] = FREE
    info, loc = cast_rays(g, RES, np.array([50]), np.array([50]), p)
    ring = (math.pi * 1.0 ** 2 - math.pi * 0.5 ** 2) / (math.pi * 1.0 ** 2)
    assert info[0] == pytest.approx(ring, abs=0.05)
    assert loc[0] == 0.0
    # Closed free room of radius 0.5 m: nothing unknown visible, walls on every side.
    g2 = g.copy()
    g2[((yy - 50) ** 2 + (xx - 50) ** 2 > 10 ** 2) & ((yy - 50) ** 2 + (xx - 50) ** 2 <= 13 ** 2)] \
        = OCCUPIED
    info2, loc2 = cast_rays(g2, RES, np.array([50]), np.array([50]), p)
    assert info2[0] == 0.0 and loc2[0] == 1.0
    # Wall on the east side only: two or three of eight sectors see it.
    g3 = g.copy()
    g3[:, 58] = OCCUPIED
    info3, loc3 = cast_rays(g3, RES, np.array([50]), np.array([50]), p)
    assert 0.1 < loc3[0] <= 3 / 8
    assert info3[0] < info[0]                          # the wall hides unknown cells


def test_ray_casting_near_the_map_edge():
    p = UtilityParams(sensor_range_m=1.0)
    g = np.full((30, 30), UNKNOWN, np.int8)
    g[0:3, 0:3] = FREE
    info, loc = cast_rays(g, RES, np.array([1]), np.array([1]), p)
    # On the map: x, y > -0.075 m around the cell centre, i.e. a quarter disc plus two
    # 0.075 m strips: (pi/4 + 2 * 0.075) / pi = 0.298 of the disc, less the 3 x 3 free cells.
    assert info[0] == pytest.approx(0.298 - 0.0225 / math.pi, abs=0.03)
    assert loc[0] == 0.0                               # the map edge is no landmark


def test_entropy_weight():
    p = UtilityParams(entropy_gain=0.5, entropy_ref=1.0)
    assert entropy_weight(None, p) == 1.0
    assert entropy_weight(float("nan"), p) == 1.0
    assert entropy_weight(0.5, p) == 1.0
    assert entropy_weight(3.0, p) == pytest.approx(2.0)


def test_score_prefers_gain_or_distance_as_weighted():
    g = np.full((200, 200), UNKNOWN, np.int8)
    g[90:110, :] = FREE                                # corridor of free cells
    g[:, 95:105] = FREE
    rows, cols = np.array([100, 100]), np.array([10, 150])
    path = np.array([20.0, 2.0])
    p = UtilityParams(w_loc=0.0)
    s = score_candidates(g, RES, rows, cols, path, np.array([10, 10]), p)
    assert s.best == 1                                 # same gain, shorter path wins
    assert s.nav[1] > s.nav[0]
    assert s.total[1] == pytest.approx(s.info[1] + s.nav[1])
    # A huge pose entropy makes distance matter more: wE grows, ranking kept.
    s2 = score_candidates(g, RES, rows, cols, path, np.array([10, 10]), p, entropy=4.0)
    assert s2.w_entropy == pytest.approx(3.0) and s2.best == 1
    # Unreachable and disallowed candidates are never chosen.
    s3 = score_candidates(g, RES, rows, cols, np.array([5.0, np.inf]), np.array([1, 1]), p)
    assert s3.best == 0
    s4 = score_candidates(g, RES, rows, cols, path, np.array([1, 1]), p,
                          allowed=np.array([True, False]))
    assert s4.best == 0
    s5 = score_candidates(g, RES, rows, cols, path, np.array([1, 1]), p,
                          allowed=np.array([False, False]))
    assert s5.best == -1


def test_information_gain_can_outweigh_distance():
    g = np.full((300, 300), UNKNOWN, np.int8)
    g[140:160, 0:300] = FREE
    g[139, :] = OCCUPIED
    g[160, :] = OCCUPIED
    g[100:139, 200:240] = FREE                         # an opening into unknown space ...
    g[139, 200:240] = FREE
    rows, cols = np.array([150, 145]), np.array([5, 220])
    # ... so candidate 1 sees more unknown than candidate 0 at the corridor's end.
    p = UtilityParams(w_info=5.0, w_nav=1.0, w_loc=0.0, distance_scale_m=20.0)
    s = score_candidates(g, RES, rows, cols, np.array([3.0, 6.0]), np.array([5, 5]), p)
    assert s.info[1] > s.info[0]
    assert s.best == 1
    n = score_candidates(g, RES, rows, cols, np.array([3.0, 6.0]), np.array([5, 5]), p,
                         strategy="nearest")
    assert n.best == 0


def test_nearest_ties_prefer_larger_cluster():
    g = np.zeros((10, 10), np.int8)
    s = score_candidates(g, RES, np.array([1, 2]), np.array([1, 2]), np.array([4.0, 4.0]),
                         np.array([3, 9]), UtilityParams(), strategy="nearest")
    assert s.best == 1


def test_unknown_strategy_is_rejected():
    g = np.zeros((10, 10), np.int8)
    with pytest.raises(ValueError):
        score_candidates(g, RES, np.array([1]), np.array([1]), np.array([1.0]),
                         np.array([1]), UtilityParams(), strategy="random")


def test_scenario_room_and_corridor():
    p = ScenarioParams()
    corridor = np.full((200, 200), UNKNOWN, np.int8)
    corridor[90:110, :] = FREE                         # 1 m wide
    corridor[89, :] = OCCUPIED
    corridor[110, :] = OCCUPIED
    sc = classify(corridor, RES, (100, 100), p)
    assert sc.name == CORRIDOR and sc.w_scenario == p.w_corridor
    assert sc.width_m == pytest.approx(1.05, abs=0.15)
    room = np.full((200, 200), OCCUPIED, np.int8)
    room[40:160, 40:160] = FREE                        # 6 m x 6 m
    sc = classify(room, RES, (100, 100), p)
    assert sc.name == ROOM and sc.w_scenario == p.w_room
    # Robot off the free space: treated as a room, no exception.
    assert classify(room, RES, (0, 0), p).name == ROOM


def test_plan_blacklist_and_world_coordinates():
    g = np.full((40, 200), FREE, np.int8)
    g[20:, :] = UNKNOWN
    info = GridInfo(RES, 200, 40, origin_x=-5.0, origin_y=2.0)
    robot = (-5.0 + 100 * RES, 2.0 + 5 * RES)
    pp = PlannerParams(frontier=FrontierParams(footprint_radius_m=0.18))
    first = plan(g, info, robot, pp)
    assert first.status == "ok" and first.goal_xy is not None
    gx, gy = first.goal_xy
    assert gy == pytest.approx(2.0 + 16.5 * RES)       # set back 4 cells, cell centre
    assert set(first.timings_ms) >= {"phase1", "phase2", "phase3", "utility", "total"}
    second = plan(g, info, robot, pp, blacklist_xy=[(gx, gy)])
    assert second.goal_xy is not None
    assert math.hypot(second.goal_xy[0] - gx, second.goal_xy[1] - gy) > 0.5
    everything = [tuple(xy) for xy in first.goals_xy]
    third = plan(g, info, robot, pp, blacklist_xy=everything)
    assert third.status == STATUS_ALL_BLACKLISTED and third.goal_xy is None


def test_min_info_gain_rule():
    g = np.full((200, 200), FREE, np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = OCCUPIED
    g[100:103, 100:103] = UNKNOWN                     # a 0.15 m x 0.15 m unseen pocket
    rows, cols = np.array([95]), np.array([95])
    p = UtilityParams(min_info_gain_m2=0.25)
    s = score_candidates(g, RES, rows, cols, np.array([1.0]), np.array([5]), p)
    assert s.info[0] * math.pi * p.sensor_range_m ** 2 < 0.25
    assert s.best == -1
    p0 = UtilityParams(min_info_gain_m2=0.0)
    assert score_candidates(g, RES, rows, cols, np.array([1.0]), np.array([5]), p0).best == 0
    # nearest ignores the rule (pure nearest frontier).
    assert score_candidates(g, RES, rows, cols, np.array([1.0]), np.array([5]), p,
                            strategy="nearest").best == 0


def _reference_rays(grid, rows, cols, params):
    """Independent reference of cast_rays: every sample looked up, one ray at a time."""
    dr, dc, area = ray_offsets(RES, params)
    n_rays, n_steps = dr.shape
    seen = np.zeros((rows.size, n_rays, n_steps), bool)
    hit = np.zeros((rows.size, n_rays), bool)
    for i, (r0, c0) in enumerate(zip(rows, cols)):
        for j in range(n_rays):
            vals = []
            for s in range(n_steps):
                r, c = r0 + dr[j, s], c0 + dc[j, s]
                inside = 0 <= r < grid.shape[0] and 0 <= c < grid.shape[1]
                vals.append(grid[r, c] if inside else None)
            stops = [s for s, v in enumerate(vals) if v is None or v == OCCUPIED]
            end = stops[0] if stops else n_steps
            seen[i, j, :end] = [v == UNKNOWN for v in vals[:end]]
            hit[i, j] = end < n_steps and vals[end] == OCCUPIED and not seen[i, j].any()
    info = (seen.astype(np.float32) @ area.astype(np.float32)).sum(axis=1) / (
        math.pi * params.sensor_range_m ** 2)
    starts = (np.arange(params.loc_sectors) * n_rays) // params.loc_sectors
    loc = np.logical_or.reduceat(hit, starts, axis=1).mean(axis=1)
    return np.minimum(info.astype(np.float64), 1.0), loc


@pytest.mark.parametrize("seed", range(3))
def test_cast_rays_equal_a_sample_by_sample_reference(seed):
    """Random clutter, candidates anywhere (at the map's edges too): the same U_I and U_L,
    bit for bit."""
    rng = np.random.default_rng(seed)
    g = rng.choice(np.array([FREE, OCCUPIED, UNKNOWN], np.int8), size=(45, 60),
                   p=[0.8, 0.04, 0.16])
    p = UtilityParams(sensor_range_m=0.8, n_rays=24, loc_sectors=6)
    rows = np.concatenate([rng.integers(0, 45, 12), [0, 44, 0]])
    cols = np.concatenate([rng.integers(0, 60, 12), [0, 59, 59]])
    info, loc = cast_rays(g, RES, rows, cols, p)
    want_info, want_loc = _reference_rays(g, rows, cols, p)
    assert np.array_equal(info, want_info) and np.array_equal(loc, want_loc)
    assert info.max() > 0.0 and loc.max() > 0.0
