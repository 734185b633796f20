"""Unit tests of the three phases on hand-made grids with known answers (no ROS master)."""

import cv2
import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN
from frontier_detector.frontiers import (
    STATUS_EMPTY_MAP,
    STATUS_NO_FRONTIERS,
    STATUS_OK,
    STATUS_ROBOT_BLOCKED,
    STATUS_ROBOT_OUTSIDE,
    FrontierParams,
    filtering,
    find_frontiers,
    grouping,
    label_cells,
    phase1_mask,
    preliminary_generation,
    traversable_mask,
)
from frontier_detector.paths import block_size

RES = 0.05


def fp(**kw):
    """The parameters the known answers below were worked out for (0.18 m footprint)."""
    kw.setdefault("footprint_radius_m", 0.18)
    return FrontierParams(**kw)


def room_with_door(door_rows=(25, 45)):
    """4 m x 3 m walled room (cols 0..79) with a door in its east wall; unknown beyond."""
    g = np.full((60, 120), UNKNOWN, np.int8)
    g[:, :80] = FREE
    g[0, :80] = OCCUPIED
    g[-1, :80] = OCCUPIED
    g[:, 0] = OCCUPIED
    g[:, 79] = OCCUPIED
    g[door_rows[0]: door_rows[1], 79] = FREE
    return g


def cells(rc):
    return {(int(r), int(c)) for r, c in rc}


def test_phase1_free_cells_next_to_unknown():
    g = np.full((7, 7), FREE, np.int8)
    g[3, 3] = UNKNOWN
    g[0, 0] = OCCUPIED
    m = phase1_mask(g, 1)
    expected = {(r, c) for r in (2, 3, 4) for c in (2, 3, 4)} - {(3, 3)}
    assert cells(np.argwhere(m)) == expected
    # A larger neighbourhood reaches two cells away, but never unknown or occupied cells.
    m2 = phase1_mask(g, 2)
    assert len(np.argwhere(m2)) == 5 * 5 - 1
    assert m2[3, 3] == 0


def test_phase1_map_edge_is_not_a_frontier():
    g = np.zeros((5, 5), np.int8)
    assert not phase1_mask(g, 1).any()


def test_door_frontier_all_phases():
    g = room_with_door()
    r = find_frontiers(g, RES, (30, 20), fp())
    assert r.status == STATUS_OK
    # Phase 1: exactly the 20 free door cells see the unknown side.
    assert cells(r.phase1_rc) == {(row, 79) for row in range(25, 45)}
    # Phase 2: cells closer than 0.18 m (3.6 cells) to the jambs (rows 24, 45) are dropped.
    assert cells(r.phase2_rc) == {(row, 79) for row in range(28, 42)}
    # Phase 3: one cluster of the 14 cells; its goal faces the middle of the door, set back
    # into the room so the footprint (3.6 cells) clears the unknown side (col >= 80) too.
    assert r.n_candidates == 1
    assert r.cluster_cells[0] == 14
    assert abs(r.goals_rc[0][0] - 34.5) <= 0.5 and r.goals_rc[0][1] == 76
    assert np.all(r.phase2_cluster == 0)
    assert set(r.timings_ms) == {"phase1", "phase2", "phase3"}


def test_narrow_gap_is_dropped_as_too_small():
    g = room_with_door(door_rows=(30, 35))             # 0.25 m gap: 5 cells
    r = find_frontiers(g, RES, (30, 20), fp(min_frontier_size_m=0.35))
    assert len(r.phase1_rc) == 5
    assert len(r.phase2_rc) == 0
    assert r.status == STATUS_NO_FRONTIERS
    # With the size rule relaxed the gap is still too narrow for the footprint.
    r = find_frontiers(g, RES, (30, 20), fp(min_frontier_size_m=0.1))
    assert len(r.phase2_rc) == 0


def test_unreachable_frontier_is_dropped():
    g = room_with_door()
    g[:, 40] = OCCUPIED                                # wall splits the room
    r = find_frontiers(g, RES, (30, 20), fp())               # robot in the west half
    assert len(r.phase1_rc) == 20
    assert r.status == STATUS_NO_FRONTIERS
    r = find_frontiers(g, RES, (30, 60), fp())               # east half: door reachable
    assert r.status == STATUS_OK and r.n_candidates == 1


def test_no_leak_through_thin_wall_when_door_is_far():
    # Two rooms separated by a one-cell wall with a door at its far end: the path from the
    # robot to the frontier must go around through the door, not through the wall.
    g = np.full((100, 100), FREE, np.int8)
    g[0, :] = g[-1, :] = g[:, 0] = g[:, -1] = OCCUPIED
    g[:, 50] = OCCUPIED
    g[85:95, 50] = FREE                                # door near the south end
    g[5:15, 99] = FREE                                 # opening to the unknown, east room
    g = np.concatenate([g, np.full((100, 20), UNKNOWN, np.int8)], axis=1)
    r = find_frontiers(g, RES, (10, 45), fp())               # robot by the wall, west room
    assert r.status == STATUS_OK
    goal = r.goals_rc[0]
    path = r.path_length_m(goal[:1], goal[1:])[0]
    straight = np.hypot(goal[0] - 10, goal[1] - 45) * RES
    via_door = (np.hypot(90 - 10, 50 - 45) + np.hypot(goal[0] - 90, goal[1] - 50)) * RES
    assert path > 2.0 * straight
    assert path == pytest.approx(via_door, rel=0.2)


def test_long_frontier_is_split_into_clusters():
    g = np.full((40, 200), FREE, np.int8)
    g[20:, :] = UNKNOWN                                # 10 m long straight frontier
    r = find_frontiers(g, RES, (5, 100), fp(cluster_size_m=2.0))
    assert r.status == STATUS_OK
    assert len(r.phase1_rc) == 200
    # Cells within the footprint radius of nothing are all kept (no obstacles at all).
    assert len(r.phase2_rc) == 200
    assert r.n_candidates == 5
    assert r.cluster_cells.sum() == 200
    assert np.all(r.cluster_cells <= 2.0 / RES)
    goals_c = np.sort(r.goals_rc[:, 1])
    assert np.all(np.diff(goals_c) >= 30)              # well separated
    assert np.all(r.goals_rc[:, 0] == 16)              # 4 cells (>= 3.6) from the unknown


def test_two_segments_give_separate_clusters():
    g = np.full((40, 100), FREE, np.int8)
    g[20:, :] = UNKNOWN
    g[15:, 48:52] = OCCUPIED                           # pillar splits the frontier
    r = find_frontiers(g, RES, (5, 20), fp())
    assert r.status == STATUS_OK
    left = r.goals_rc[:, 1] < 48
    right = r.goals_rc[:, 1] > 52
    assert left.any() and right.any() and np.all(left | right)


def test_bad_inputs_give_status_not_exceptions():
    g = room_with_door()
    assert find_frontiers(np.zeros((0, 0), np.int8), RES, (0, 0)).status == STATUS_EMPTY_MAP
    unknown = np.full((30, 30), UNKNOWN, np.int8)
    assert find_frontiers(unknown, RES, (3, 3), fp()).status == STATUS_EMPTY_MAP
    assert find_frontiers(g, RES, (-1, 5), fp()).status == STATUS_ROBOT_OUTSIDE
    assert find_frontiers(g, RES, (30, 500), fp()).status == STATUS_ROBOT_OUTSIDE
    # Robot inside a wall block far from free space.
    blocked = g.copy()
    blocked[:, :30] = OCCUPIED
    r = find_frontiers(blocked, RES, (30, 5), fp())
    assert r.status == STATUS_ROBOT_BLOCKED and r.robot_rc is None
    assert r.n_candidates == 0
    # Robot on an unknown cell next to the known area is snapped into free space.
    r = find_frontiers(g, RES, (30, 81), fp(robot_snap_radius_m=0.5))
    assert r.status == STATUS_OK and r.robot_rc is not None


def test_robot_snap_respects_radius():
    g = room_with_door()
    r = find_frontiers(g, RES, (30, 110), fp(robot_snap_radius_m=0.5))
    assert r.status == STATUS_ROBOT_BLOCKED


def test_traversable_mask_clearance():
    g = np.zeros((21, 21), np.int8)
    g[10, 10] = OCCUPIED
    t = traversable_mask(g, 3.0)
    rr, cc = np.nonzero(t == 0)
    d = np.hypot(rr - 10, cc - 10)
    assert d.max() < 3.0 + 1e-9                        # only cells closer than 3 blocked
    assert t[10, 13] and t[13, 10] and not t[10, 12]


def test_goals_are_traversable_and_reachable_on_synthetic_office():
    from frontier_detector.synthetic import (
        first_free_cell_near,
        office_building,
        partially_explored,
    )

    truth = office_building(30.0, RES, seed=4)
    robot = first_free_cell_near(truth, 300, 300)
    g = partially_explored(truth, robot, 200, seed=4, unknown_rooms=5)
    r = find_frontiers(g, RES, robot, fp())
    assert r.status == STATUS_OK and r.n_candidates > 3
    trav = traversable_mask(g, 0.18 / RES)
    assert np.all(trav[r.goals_rc[:, 0], r.goals_rc[:, 1]] > 0)
    # The footprint around every goal lies in known space (no unknown within 0.18 m).
    unknown = np.argwhere(g == UNKNOWN)
    for gr, gc in r.goals_rc:
        assert np.hypot(unknown[:, 0] - gr, unknown[:, 1] - gc).min() >= 0.18 / RES
    assert np.all(g[r.goals_rc[:, 0], r.goals_rc[:, 1]] == FREE)
    assert np.all(np.isfinite(r.path_length_m(r.goals_rc[:, 0], r.goals_rc[:, 1])))
    # Every goal must be connected to the robot through traversable cells (flood fill).
    mask = np.zeros((g.shape[0] + 2, g.shape[1] + 2), np.uint8)
    cv2.floodFill(trav, mask, (r.robot_rc[1], r.robot_rc[0]), 0, 0, 0,
                  8 | cv2.FLOODFILL_MASK_ONLY | (255 << 8))
    assert np.all(mask[1:-1, 1:-1][r.goals_rc[:, 0], r.goals_rc[:, 1]] > 0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sparse_helpers_match_opencv(seed):
    rng = np.random.default_rng(seed)
    m = ((rng.random((96, 128)) < 0.08) * 255).astype(np.uint8)
    rr, cc = np.nonzero(m)
    labels = label_cells(rr, cc)
    n, cv_labels = cv2.connectedComponents(m, connectivity=8)
    assert labels.max() + 1 == n - 1
    # Same partition: a one-to-one map between the two labelings.
    pairs = set(zip(labels.tolist(), cv_labels[rr, cc].tolist()))
    assert len(pairs) == n - 1


def test_unreachable_segment_gets_a_view_point():
    # A 0.3 m gap: its frontier cells are all closer than the footprint radius to a jamb,
    # so no cell is reachable; the cluster is looked at from inside the room instead.
    g = room_with_door(door_rows=(28, 34))
    r = find_frontiers(g, RES, (30, 20), fp(min_frontier_size_m=0.3))
    assert len(r.phase2_rc) == 0
    assert cells(r.unreachable_rc) == {(row, 79) for row in range(28, 34)}
    assert r.status == STATUS_OK and r.n_candidates == 1 and r.observe_only.tolist() == [True]
    gr, gc = r.goals_rc[0]
    # Straight line of sight from the view point to the gap, within 2.5 m, safe cell.
    assert np.hypot(gr - 30.5, gc - 79) <= 2.5 / RES
    line = np.linspace(0.0, 1.0, 200)
    lr = np.rint(gr + (30.5 - gr) * line).astype(int)
    lc = np.rint(gc + (79 - gc) * line).astype(int)
    assert not np.any(g[lr, lc] == OCCUPIED)
    assert traversable_mask(g, 0.18 / RES)[gr, gc] > 0
    assert np.isfinite(r.path_length_m(r.goals_rc[:, 0], r.goals_rc[:, 1])[0])
    # Switched off: nothing left.
    off = find_frontiers(g, RES, (30, 20), fp(min_frontier_size_m=0.3, observe_range_m=0.0))
    assert off.status == STATUS_NO_FRONTIERS and len(off.unreachable_rc) == 0


@pytest.mark.parametrize("radius", [0.0, 1.0, 2.5, 3.6, 6.0 - 1e-6, 7.3])
def test_dilate_disk_equals_disc_kernel(radius):
    from frontier_detector.frontiers import dilate_disk, disk_kernel

    rng = np.random.default_rng(int(radius * 10))
    m = ((rng.random((80, 90)) < 0.02) * 255).astype(np.uint8)
    ref = cv2.dilate(m, disk_kernel(radius), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    assert np.array_equal(dilate_disk(m, radius), ref)


def test_cluster_without_safe_goal_nearby_gets_a_view_point():
    g = room_with_door()
    # With a 1-cell search radius no cell near the door's centroid is 3.6 cells from the
    # unknown side: the cluster falls back to a view point (nearest along rays, col 76).
    r = find_frontiers(g, RES, (30, 20), fp(goal_search_radius_m=0.05))
    assert r.n_candidates == 1 and r.observe_only.tolist() == [True]
    gr, gc = r.goals_rc[0]
    assert gc == 76 and abs(gr - 34.5) <= 1.0
    off = find_frontiers(g, RES, (30, 20), fp(goal_search_radius_m=0.05, observe_range_m=0.0))
    assert off.n_candidates == 0 and off.status == STATUS_NO_FRONTIERS


def _door_phases(p, g=None):
    """Phases 1 and 2 as find_frontiers runs them, on the room with a door, robot (30, 20)."""
    g = room_with_door() if g is None else g
    radius = p.footprint_radius_m / RES
    k = block_size(RES, p.footprint_radius_m, p.path_resolution_m)
    tile = k * max(1, int(round(16 / k)))
    margin = p.neighbourhood_cells + int(np.ceil(radius)) + 1
    pre = preliminary_generation(g, p.neighbourhood_cells, margin, tile)
    r0, c0 = pre.window[:2]
    filt = filtering(pre, (30 - r0, 20 - c0), RES, p, k)
    return g, pre, filt, r0, c0, k


def test_preliminary_generation_finds_door_cells_and_one_segment():
    g, pre, _, r0, c0, _ = _door_phases(fp())
    assert pre.sub.shape == (pre.window[2], pre.window[3])
    got = cells(np.stack([pre.rows + r0, pre.cols + c0], axis=1))
    assert got == cells(np.argwhere(phase1_mask(g, 1)))
    assert {c for _, c in got} == {79}                       # the door column only
    assert set(pre.segment.tolist()) == {0}
    assert preliminary_generation(np.full((9, 9), UNKNOWN, np.int8), 1, 4, 4) is None


def test_filtering_keeps_long_reachable_cells_with_clearance():
    p = fp()
    _, pre, filt, r0, c0, k = _door_phases(p)
    assert filt.robot == (30 - r0, 20 - c0)
    # 0.18 m footprint (3.6 cells): of door rows 25..44, those clear of the jambs survive.
    assert set((pre.rows[filt.keep] + r0).tolist()) == set(range(28, 42))
    assert filt.reachable(pre.rows[filt.keep], pre.cols[filt.keep]).all()
    assert not filt.far.any()
    blocked = room_with_door()
    blocked[:, 70:72] = OCCUPIED                              # wall between robot and door
    _, pre_b, filt_b, _, _, _ = _door_phases(p, blocked)
    assert not filt_b.keep.any() and filt_b.far.any()        # long enough, out of reach
    assert filtering(pre_b, (0, 0), RES, fp(robot_snap_radius_m=0.0), k) is None


def test_grouping_gives_one_reachable_goal_per_cluster():
    p = fp()
    g, pre, filt, r0, c0, _ = _door_phases(p)
    groups = grouping(pre, filt, RES, p)
    assert groups.goals.shape == (1, 2) and not groups.observe_only.any()
    assert groups.cluster_cells.tolist() == [14]
    assert groups.goals[0, 1] + c0 == 76                      # set back from the unknown
    assert (groups.phase2_cluster == 0).all()
    assert filt.reachable(groups.goals[:, 0], groups.goals[:, 1]).all()
    assert abs(groups.centroids[0, 0] + r0 - 34.5) < 1e-9
    whole = find_frontiers(g, RES, (30, 20), p)
    assert np.array_equal(whole.goals_rc, groups.goals + [r0, c0])


@pytest.mark.parametrize("band", [1, 3, 7, 64])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_known_window_is_the_bounding_box_of_known_cells(seed, band, monkeypatch):
    from frontier_detector import frontiers
    from frontier_detector.frontiers import known_window
    monkeypatch.setattr(frontiers, "KNOWN_SCAN_ROWS", band)     # bands read inwards
    rng = np.random.default_rng(seed)
    g = np.full((70, 90), UNKNOWN, np.int8)
    r0, c0 = rng.integers(0, 40), rng.integers(0, 50)
    patch = rng.choice(np.array([FREE, OCCUPIED, UNKNOWN], np.int8), size=(20, 30))
    patch[0, 0] = patch[-1, -1] = FREE                        # the box's corners are known
    g[r0: r0 + 20, c0: c0 + 30] = patch
    x, y, w, h = cv2.boundingRect((g != UNKNOWN).astype(np.uint8))
    for margin in (0, 3, 60):
        rr0, cc0 = max(0, y - margin), max(0, x - margin)
        rr1, cc1 = min(70, y + h + margin), min(90, x + w + margin)
        assert known_window(g, margin) == (rr0, cc0, rr1 - rr0, cc1 - cc0)
    assert known_window(np.full((5, 5), UNKNOWN, np.int8), 2) is None
    one = np.full((9, 11), UNKNOWN, np.int8)
    one[4, 6] = OCCUPIED                                      # a single known cell
    assert known_window(one, 0) == (4, 6, 1, 1)


@pytest.mark.parametrize("seed", [1, 2, 5])    # maps with view points
def test_grouping_same_goals_with_patches_or_whole_window(seed, monkeypatch):
    """The unknown-near test on patches and on the whole window are two ways to the same
    answer (which one runs depends on NEAR_FULL_FRACTION): identical goals."""
    import frontier_detector.frontiers as fr
    from frontier_detector.synthetic import (
        first_free_cell_near,
        office_building,
        partially_explored,
    )
    truth = office_building(25.0, RES, seed=seed)
    n = truth.shape[0]
    robot = first_free_cell_near(truth, n // 2, n // 2)
    g = partially_explored(truth, robot, 0.35 * n, seed=seed, unknown_rooms=6, room_cells=60)
    p = FrontierParams()
    out = []
    for fraction in (0.0, 1e9):
        monkeypatch.setattr(fr, "NEAR_FULL_FRACTION", fraction)
        out.append(find_frontiers(g, RES, robot, p))
    a, b = out
    assert a.status == STATUS_OK and a.n_candidates > 3
    assert a.observe_only.any()                               # view points searched too
    for name in ("goals_rc", "centroids_rc", "cluster_cells", "observe_only", "phase2_cluster"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_patches_equal_slices_of_a_zero_padded_image():
    from frontier_detector.frontiers import patches

    rng = np.random.default_rng(3)
    img = rng.integers(1, 255, (23, 31)).astype(np.uint8)
    half = 4
    padded = np.zeros((23 + 2 * half, 31 + 2 * half), np.uint8)
    padded[half:-half, half:-half] = img
    # Inside, on every edge and corner, and patches wholly outside.
    centres = np.array([[10, 15], [0, 0], [22, 30], [2, 29], [21, 1], [11, 0], [-3, 5],
                        [-20, -20], [30, 40]])
    got = patches(img, centres, half)
    assert got.shape == (len(centres), 9, 9)
    for (r, c), p in zip(centres, got):
        want = np.zeros((9, 9), np.uint8)
        for i in range(9):
            for j in range(9):
                rr, cc = r - half + i, c - half + j
                if 0 <= rr < 23 and 0 <= cc < 31:
                    want[i, j] = img[rr, cc]
        assert np.array_equal(p, want), (r, c)
    # All inside: the strided fast path alone.
    assert np.array_equal(patches(img, centres[:1], half)[0], padded[10:19, 15:24])


@pytest.mark.parametrize("strip_cells", [720_000, 300, 1])
def test_phase1_cells_by_strips_equal_the_phase1_mask(strip_cells, monkeypatch):
    from frontier_detector import frontiers
    from frontier_detector.frontiers import phase1_cells

    monkeypatch.setattr(frontiers, "PHASE1_STRIP_CELLS", strip_cells)
    rng = np.random.default_rng(strip_cells)
    # OFF_MAP: the padding of windows that stick out of the grid.
    g = rng.choice(np.array([FREE, OCCUPIED, UNKNOWN, frontiers.OFF_MAP], np.int8),
                   size=(61, 47), p=[0.6, 0.1, 0.25, 0.05])
    for n in (1, 2):
        rr, cc = phase1_cells(g, n)
        r2, c2 = np.nonzero(phase1_mask(g, n))
        assert rr.size > 0 and np.array_equal(rr, r2) and np.array_equal(cc, c2)


def test_unique_inverse_equals_numpy_unique():
    from frontier_detector.frontiers import _unique_inverse

    rng = np.random.default_rng(5)
    for values in (rng.integers(0, 40, 300), np.array([7]), np.zeros(0, np.int64),
                   np.array([3, 3, 0, 12, 3])):
        u, inv = _unique_inverse(values)
        u2, inv2 = np.unique(values, return_inverse=True)
        assert np.array_equal(u, u2) and np.array_equal(inv, inv2)
