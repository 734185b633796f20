"""Tests of the global planner (pure code, no ROS master)."""

import heapq

import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_navigation import planner as pln
from ascc_navigation import synthetic as syn


def _reference_dijkstra(costmap: pln.Costmap, goal):
    """Textbook heapq Dijkstra on the same 8-connected integer step costs."""
    rows, cols = costmap.shape
    dist = np.full((rows, cols), pln.INF, dtype=np.int64)
    dist[goal] = 0
    heap = [(0, goal)]
    while heap:
        d, (r, c) = heapq.heappop(heap)
        if d > dist[r, c]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                nr, nc = r + dr, c + dc
                if (dr or dc) and 0 <= nr < rows and 0 <= nc < cols:
                    # the move (nr, nc) -> (r, c) costs entering (r, c); lethal cells
                    # cannot be entered (but a robot standing in one may leave it)
                    if costmap.lethal[r, c]:
                        continue
                    unit = pln.DIAG if dr and dc else pln.UNIT
                    step = int(np.round(unit * costmap.weight[r, c]))
                    if d + step < dist[nr, nc]:
                        dist[nr, nc] = d + step
                        heapq.heappush(heap, (d + step, (nr, nc)))
    return dist


@pytest.mark.parametrize("shape", [(30, 45), (45, 30)])  # wide and tall (transposed) grids
def test_cost_to_goal_equals_dijkstra(shape):
    rng = np.random.default_rng(shape[0])
    grid = np.where(rng.random(shape) < 0.08, OCCUPIED, FREE).astype(np.int8)
    grid[rng.random(shape) < 0.1] = UNKNOWN
    info = GridInfo(0.1, shape[1], shape[0])
    params = pln.PlannerParams(robot_radius=0.05, footprint_padding=0.0, inflation_radius=0.3,
                               resolution=0.1)
    costmap = pln.Costmap(grid, info, params)
    free = np.argwhere(~costmap.lethal)
    goal = tuple(int(v) for v in free[len(free) // 2])
    dist, rounds = pln.cost_to_goal(costmap, goal)
    ref = _reference_dijkstra(costmap, goal)
    reachable = ref < pln.INF
    assert reachable.sum() > 0.5 * (~costmap.lethal).sum()
    assert np.array_equal(dist[reachable], ref[reachable])
    assert np.all(dist[~reachable] >= pln.LETHAL)  # unreachable stays unreachable
    assert rounds < 50


@pytest.fixture(scope="module")
def office():
    return syn.office_world()


def test_path_is_clear_of_obstacles_and_ends_at_the_goal(office):
    grid, info = office
    params = pln.PlannerParams()
    costmap = pln.Costmap(grid, info, params)
    start, goal = (2.0, 2.0), (8.0, 8.4)  # from the south corridor into a north room
    result = pln.plan(costmap, start, goal)
    assert result.ok, result.reason
    assert result.path[0] == pytest.approx(start) and result.path[-1] == pytest.approx(goal)
    steps = np.hypot(*np.diff(result.path[1:-1], axis=0).T)  # ends: exact start and goal
    assert steps.max() <= costmap.resolution * np.sqrt(2) + 1e-9  # connected 8-neighbours
    # every path point keeps the robot's radius from the true map's obstacles
    occ = np.argwhere(grid == OCCUPIED)
    ox, oy = info.cell_to_world(occ[:, 1], occ[:, 0])
    for p in result.path[1:-1]:
        d = np.min(np.hypot(ox - p[0], oy - p[1])) - info.resolution / 2
        assert d > params.robot_radius
    length = pln.path_length(result.path)
    assert np.hypot(goal[0] - start[0], goal[1] - start[1]) < length < 25.0
    assert result.cost >= length  # inflation and unknown only add cost


def test_unreachable_off_map_and_in_obstacle_goals(office):
    grid, info = office
    sealed = grid.copy()
    sealed[int(8.0 / 0.05):int(8.1 / 0.05), int(12.8 / 0.05):] = OCCUPIED  # closet walls
    sealed[int(8.0 / 0.05):, int(12.8 / 0.05):int(12.9 / 0.05)] = OCCUPIED
    costmap = pln.Costmap(sealed, info)
    r = pln.plan(costmap, (2.0, 2.0), (13.4, 9.0))
    assert not r.ok and r.failure == pln.UNREACHABLE and "not reachable" in r.reason
    r = pln.plan(costmap, (2.0, 2.0), (20.0, 3.0))
    assert not r.ok and r.failure == pln.INVALID_GOAL and "outside the map" in r.reason
    r = pln.plan(costmap, (2.0, 2.0), (7.0, 4.2))  # middle of the central block
    assert not r.ok and r.failure == pln.INVALID_GOAL and "obstacle" in r.reason
    r = pln.plan(costmap, (-3.0, 2.0), (3.0, 2.0))
    assert not r.ok and r.failure == pln.INVALID_START


def test_goal_next_to_a_wall_moves_within_tolerance(office):
    grid, info = office
    params = pln.PlannerParams(default_tolerance=0.3)
    costmap = pln.Costmap(grid, info, params)
    goal = (2.0, 0.2)  # 10 cm from the south wall: inside the inflated zone
    assert not costmap.is_free_at(goal)
    r = pln.plan(costmap, (2.0, 2.0), goal)
    assert r.ok
    assert np.hypot(*(r.path[-1] - goal)) <= 0.3 + costmap.resolution
    assert costmap.is_free_at(r.path[-1])


def test_start_inside_the_inflated_zone_can_leave_it(office):
    grid, info = office
    costmap = pln.Costmap(grid, info)
    start = (2.0, 0.3)  # 20 cm from the wall: lethal for a 0.17 m robot plus one cell
    assert not costmap.is_free_at(start)
    r = pln.plan(costmap, start, (2.0, 2.5))
    assert r.ok, r.reason


def test_unknown_space_is_allowed_only_when_asked():
    grid = np.full((40, 60), UNKNOWN, np.int8)
    grid[:, :20] = FREE
    grid[:, 40:] = FREE
    info = GridInfo(0.1, 60, 40)
    start, goal = (0.5, 2.0), (5.5, 2.0)
    assert pln.plan(pln.Costmap(grid, info, pln.PlannerParams(allow_unknown=True)),
                    start, goal).ok
    r = pln.plan(pln.Costmap(grid, info, pln.PlannerParams(allow_unknown=False)), start, goal)
    assert not r.ok


def test_unknown_costs_more_than_free():
    grid = np.zeros((40, 60), np.int8)
    grid[5:25, 10:50] = UNKNOWN  # straight line crosses unknown; a free detour exists below
    info = GridInfo(0.1, 60, 40)
    params = pln.PlannerParams(unknown_cost=3.0)
    r = pln.plan(pln.Costmap(grid, info, params), (0.5, 1.5), (5.5, 1.5))
    assert r.ok
    rows = ((r.path[:, 1]) / 0.1).astype(int)
    cols = ((r.path[:, 0]) / 0.1).astype(int)
    assert not np.any(grid[rows, cols] == UNKNOWN)


def test_marked_obstacles_block_a_corridor(office):
    grid, info = office
    start, goal = (2.0, 2.0), (12.0, 2.0)
    plain = pln.plan(pln.Costmap(grid, info), start, goal)
    assert plain.ok and plain.path[:, 1].max() < 3.0  # along the south corridor
    wall = np.column_stack([np.full(60, 8.0), np.linspace(0.1, 3.0, 60)])
    detour = pln.plan(pln.Costmap(grid, info, obstacles=wall), start, goal)
    assert detour.ok and detour.path[:, 1].max() > 5.5  # around the central block's north
    assert pln.path_length(detour.path) > pln.path_length(plain.path) + 5.0


def test_costmap_keeps_thin_walls_on_a_coarse_grid():
    grid = np.zeros((100, 100), np.int8)
    grid[:, 50] = OCCUPIED  # one 5 cm cell thick wall, no gap
    info = GridInfo(0.05, 100, 100)
    costmap = pln.Costmap(grid, info, pln.PlannerParams(resolution=0.2))
    assert costmap.factor == 4
    assert not pln.plan(costmap, (1.0, 2.5), (4.0, 2.5)).ok


def test_costmap_rejects_mismatched_grid():
    with pytest.raises(ValueError):
        pln.Costmap(np.zeros((10, 10), np.int8), GridInfo(0.05, 12, 10))


def test_footprint_padding_closes_narrow_passages():
    grid = np.full((60, 80), OCCUPIED, np.int8)
    grid[10:50, 2:30] = FREE  # two rooms joined by a 0.6 m wide, 1 m long passage
    grid[10:50, 50:78] = FREE
    grid[27:39, 30:50] = FREE  # rows 27..38: 12 cells x 0.05 m = 0.6 m
    info = GridInfo(0.05, 80, 60)
    start, goal = (0.5, 1.5), (3.5, 1.5)
    # needs 2 x (0.17 + padding + 1.2 cells) of free width
    assert pln.plan(pln.Costmap(grid, info, pln.PlannerParams(footprint_padding=0.0)),
                    start, goal).ok
    assert not pln.plan(pln.Costmap(grid, info, pln.PlannerParams(footprint_padding=0.1)),
                        start, goal).ok


# -- the lean costmap and planner (issue 24): same results as building / searching it all --

def _reference_costmap(grid, info, params):
    """lethal and weight by the original full-grid recipe: uncapped distance transform of
    the whole map, pooled per planning cell."""
    import cv2
    occupied = grid >= pln.OCCUPIED_MIN
    clear = cv2.distanceTransform((~occupied).astype(np.uint8), cv2.DIST_L2,
                                  cv2.DIST_MASK_PRECISE) * info.resolution
    f = max(1, int(round(params.resolution / info.resolution)))
    rows, cols = -(-grid.shape[0] // f), -(-grid.shape[1] // f)
    pad = ((0, rows * f - grid.shape[0]), (0, cols * f - grid.shape[1]))
    clear = np.pad(clear, pad, constant_values=np.inf).reshape(rows, f, cols, f).min(axis=(1, 3))
    unknown = np.pad(grid < 0, pad, constant_values=True).reshape(rows, f, cols, f).all(axis=(1, 3))
    lethal = clear < (params.robot_radius + params.footprint_padding
                      + info.resolution * (0.5 + np.sqrt(0.5)))
    d = np.maximum(clear - params.robot_radius, 0.0)
    infl = np.where(clear < params.inflation_radius,
                    params.inflation_weight * np.exp(-params.cost_scaling_factor * d), 0.0)
    return lethal, 1.0 + infl + params.unknown_cost * unknown


def _random_map(rng, shape):
    """Rooms of free space with random walls, blobs and unknown patches."""
    grid = np.full(shape, FREE, dtype=np.int8)
    for _ in range(12):
        r, c = rng.integers(0, shape[0]), rng.integers(0, shape[1])
        h, w = rng.integers(1, 8), rng.integers(1, 40)
        grid[r:r + h, c:c + w] = OCCUPIED if rng.random() < 0.6 else UNKNOWN
    return grid


def _edit(rng, grid):
    """A map update: a few random boxes of cells set to free / occupied / unknown."""
    grid = grid.copy()
    for _ in range(rng.integers(1, 4)):
        r, c = rng.integers(0, grid.shape[0]), rng.integers(0, grid.shape[1])
        h, w = rng.integers(1, 15), rng.integers(1, 15)
        grid[r:r + h, c:c + w] = rng.choice([FREE, OCCUPIED, UNKNOWN])
    return grid


def _assert_same_costmap(a, b):
    for name in ("clearance", "unknown", "occupied", "lethal", "weight"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


@pytest.mark.parametrize("map_res", [0.05, 0.1])
def test_capped_costmap_equals_the_full_recipe(map_res):
    rng = np.random.default_rng(7)
    grid = _random_map(rng, (121, 203))  # odd sizes: padded planning cells
    info = GridInfo(map_res, 203, 121, -3.0, 2.0)
    params = pln.PlannerParams()
    costmap = pln.Costmap(grid, info, params)
    lethal, weight = _reference_costmap(grid, info, params)
    assert lethal.any() and (weight > 1.0).any() and (~lethal).any()
    assert np.array_equal(costmap.lethal, lethal)
    assert np.array_equal(costmap.weight, weight)


@pytest.mark.parametrize("map_res", [0.05, 0.1])
def test_incremental_costmap_equals_rebuilding_it(map_res):
    rng = np.random.default_rng(11)
    params = pln.PlannerParams()
    grid = _random_map(rng, (121, 203))
    info = GridInfo(map_res, 203, 121, -3.0, 2.0)
    costmap = pln.Costmap(grid, info, params)
    for _ in range(25):
        grid = _edit(rng, grid)
        costmap = costmap.updated(grid, info)
        _assert_same_costmap(costmap, pln.Costmap(grid, info, params))
    # an unchanged map and one changed on its border (partial planning cells)
    _assert_same_costmap(costmap.updated(grid, info), pln.Costmap(grid, info, params))
    grid = grid.copy()
    grid[-1, -3:] = OCCUPIED
    _assert_same_costmap(costmap.updated(grid, info), pln.Costmap(grid, info, params))


def test_incremental_costmap_of_a_grown_map_equals_rebuilding_it():
    """The mapper grows its map by whole cells on any side; new cells may hold walls."""
    rng = np.random.default_rng(5)
    params = pln.PlannerParams()
    grid = _random_map(rng, (81, 101))
    info = GridInfo(0.05, 101, 81, 0.0, 0.0)
    costmap = pln.Costmap(grid, info, params)
    for left, bottom, right, top in ((4, 0, 0, 0), (0, 6, 3, 0), (2, 2, 2, 2), (0, 0, 7, 5),
                                     (3, 0, 0, 0)):  # the last: not planning-cell aligned
        info = info.grown(left, bottom, right, top)
        bigger = np.full(info.shape, UNKNOWN, dtype=np.int8)
        bigger[bottom:bottom + grid.shape[0], left:left + grid.shape[1]] = grid
        bigger[:bottom + 2, :] = np.where(rng.random((bottom + 2, info.width)) < 0.1,
                                          OCCUPIED, FREE)
        grid = _edit(rng, bigger)
        costmap = costmap.updated(grid, info)
        _assert_same_costmap(costmap, pln.Costmap(grid, info, params))


def test_incremental_costmap_does_not_see_later_edits_of_the_callers_array():
    params = pln.PlannerParams()
    grid = np.full((40, 40), FREE, dtype=np.int8)
    info = GridInfo(0.05, 40, 40)
    costmap = pln.Costmap(grid, info, params)
    grid[20, 20] = OCCUPIED  # edited in place, then given again
    _assert_same_costmap(costmap.updated(grid, info), pln.Costmap(grid, info, params))


def _plan_on_whole_grid(costmap, start_xy, goal_xy):
    """The path the planner made before it searched in windows: cost-to-goal of every cell."""
    start, goal = costmap.to_cell(start_xy), costmap.to_cell(goal_xy)
    dist, _ = pln.cost_to_goal(costmap, goal)
    if dist[start] >= pln.LETHAL:
        return None, None
    return pln.descend(dist, costmap, start, goal), int(dist[start])


@pytest.mark.parametrize("world", ["office", "random"])
def test_windowed_search_gives_the_whole_grid_plan(world, office):
    rng = np.random.default_rng(3)
    if world == "office":
        grid, info = office
    else:
        grid = _random_map(rng, (160, 400))
        info = GridInfo(0.05, 400, 160)
    costmap = pln.Costmap(grid, info, pln.PlannerParams())
    free = np.argwhere(~costmap.lethal)
    grown = 0
    for _ in range(30):
        a, b = free[rng.integers(len(free), size=2)]
        start_xy, goal_xy = costmap.to_world([a[0]], [a[1]])[0], costmap.to_world([b[0]], [b[1]])[0]
        cells, cost = _plan_on_whole_grid(costmap, start_xy, goal_xy)
        start, goal = tuple(a), tuple(b)
        dist, window, (r0, c0), _ = pln.windowed_cost_to_goal(costmap, start, goal)
        r_0, r_1, c_0, c_1 = _first_window(costmap, start, goal)
        grown += window.lethal.shape != (r_1 - r_0, c_1 - c_0)
        if cells is None:
            assert dist[start[0] - r0, start[1] - c0] >= pln.LETHAL
            continue
        assert int(dist[start[0] - r0, start[1] - c0]) == cost
        got = pln.descend(dist, window, (start[0] - r0, start[1] - c0),
                          (goal[0] - r0, goal[1] - c0)) + (r0, c0)
        assert np.array_equal(got, cells)
        result = pln.plan(costmap, start_xy, goal_xy)
        assert result.ok and result.cost == pytest.approx(cost / pln.UNIT * costmap.resolution)
    if world == "office":  # some searches had to grow their window round the block
        assert grown > 0


def _first_window(costmap, start, goal):
    rows, cols = costmap.shape
    m = pln.WINDOW_MARGIN
    return (max(min(start[0], goal[0]) - m, 0), min(max(start[0], goal[0]) + m + 1, rows),
            max(min(start[1], goal[1]) - m, 0), min(max(start[1], goal[1]) + m + 1, cols))


def test_a_goal_far_along_a_corridor_is_searched_near_the_corridor():
    """A goal 42 m along a straight corridor in a wide map (the corridor world's last goal
    of an exploration): the window stays a few metres round the corridor instead of
    spanning the map, and the plan is the whole grid's."""
    grid = np.full((400, 1000), OCCUPIED, dtype=np.int8)  # 20 m x 50 m at 0.05 m
    grid[195:243, 20:980] = FREE  # a 2.4 m wide corridor, 48 m long
    grid[150:195, 600:640] = FREE  # a side room off it
    info = GridInfo(0.05, 1000, 400)
    costmap = pln.Costmap(grid, info, pln.PlannerParams())
    start_xy, goal_xy = (2.5, 10.9), (44.5, 11.2)
    start, goal = costmap.to_cell(start_xy), costmap.to_cell(goal_xy)
    dist, window, (r0, c0), _ = pln.windowed_cost_to_goal(costmap, start, goal)
    assert window.lethal.shape[0] * costmap.resolution <= 8.0  # rows: not the map's 20 m
    cells, cost = _plan_on_whole_grid(costmap, start_xy, goal_xy)
    assert int(dist[start[0] - r0, start[1] - c0]) == cost
    got = pln.descend(dist, window, (start[0] - r0, start[1] - c0),
                      (goal[0] - r0, goal[1] - c0)) + (r0, c0)
    assert np.array_equal(got, cells)


def test_a_detour_outside_the_first_window_is_found():
    """A wall between start and goal whose only gap is far away: the window must grow."""
    grid = np.full((300, 120), FREE, dtype=np.int8)
    grid[150:152, :] = OCCUPIED
    grid[150:152, 110:118] = FREE  # the gap, 10 m to the side at 0.1 m
    info = GridInfo(0.1, 120, 300)
    costmap = pln.Costmap(grid, info, pln.PlannerParams())
    result = pln.plan(costmap, (0.5, 13.0), (0.5, 17.0))
    cells, cost = _plan_on_whole_grid(costmap, (0.5, 13.0), (0.5, 17.0))
    assert result.ok and cells is not None
    assert result.cost == pytest.approx(cost / pln.UNIT * costmap.resolution)
    assert result.path[:, 0].max() > 11.0  # through the gap
    assert pln.path_length(result.path) > 20.0
