"""map_quality on synthetic corridor loops whose map has a known distortion."""

import math

import cv2
import numpy as np
import pytest

from ascc_common import pose2d
from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_eval.map_quality import (
    QualityParams,
    best_placement,
    local_placements,
    measure,
    report_lines,
    write_overlay,
)

RES = 0.05
WIDTH_M = 2.4          # corridor width
WALL_M = 0.2
L, W = 30.0, 15.0      # the loop's outer sides
A = np.array([1.0, 1.0])


def loop(vertices, info):
    """A corridor loop along a polygon (world metres, in info's frame): free inside the
    polygon and within WIDTH_M of its boundary, walls WALL_M thick on both sides."""
    cells = np.round((np.asarray(vertices) - [info.origin_x, info.origin_y]) / RES - 0.5
                     ).astype(np.int32)
    inside = np.zeros(info.shape, np.uint8)
    cv2.fillPoly(inside, [cells], 1)
    r = int(round(WIDTH_M / RES))
    inner = cv2.erode(inside, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1,) * 2))
    t = int(round(WALL_M / RES))
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * t + 1,) * 2)
    grid = np.full(info.shape, UNKNOWN, np.int8)
    grid[(inside > 0) & (inner == 0)] = FREE
    grid[(cv2.dilate(inside, k) > 0) & (inside == 0)] = OCCUPIED
    grid[(inner > 0) & (cv2.erode(inner, k) == 0)] = OCCUPIED
    return grid


def plan_world():
    info = GridInfo(RES, 700, 400, origin_x=0.0, origin_y=0.0)
    rect = np.array([A, A + [L, 0], A + [L, W], A + [0, W]])
    return loop(rect, info), info, rect


def distorted_map(scale=1.02, rotate_deg=3.0, pose=(2.0, -1.0, 0.3)):
    """The loop with side A-B scaled by `scale` and the corner at B opened by rotate_deg,
    drawn in a map frame that sits at `pose` in the world."""
    b = A + [L * scale, 0.0]
    a_dir = math.radians(90.0 + rotate_deg)
    c = b + W * np.array([math.cos(a_dir), math.sin(a_dir)])
    d = A + [0.0, W]
    world = np.array([A, b, c, d])
    inv = pose2d.inverse(pose)
    local = pose2d.compose(inv, np.c_[world, np.zeros(4)])[:, :2]
    info = GridInfo(RES, 1100, 1100, origin_x=-20.0, origin_y=-30.0)
    return loop(local, info), info, world


def _sides(q):
    return [r for r in q.sides() if r["outline"] == _outer(q)]


def _outer(q):
    areas = [abs(np.cross(o.vertices, np.roll(o.vertices, -1, axis=0)).sum()) for o in q.outlines]
    assert q.outer_index() == int(np.argmax(areas))
    return int(np.argmax(areas))


def test_undistorted_map_measures_the_plan():
    plan, info, _ = plan_world()
    q = measure(plan, info, plan, info, plan, (A[0] + 1.2, A[1] + 7.0))
    sides = _sides(q)
    assert len(sides) == 4
    lengths = sorted(r["plan_m"] for r in sides)
    assert lengths[0] == pytest.approx(W, abs=0.15) and lengths[-1] == pytest.approx(L, abs=0.15)
    for r in sides:
        assert r["map_m"] == pytest.approx(r["plan_m"], abs=1e-6)
        assert r["plan_deg"] == pytest.approx(90.0, abs=0.05)
    assert q.agreement["accuracy"] == 1.0
    assert q.walls["seen_fraction"] == 1.0 and q.walls["exact"] == 1.0
    assert q.outer_side_errors_pct() == pytest.approx([0.0] * 4, abs=1e-6)


def test_scaled_side_and_rotated_corner_are_measured(tmp_path):
    plan, info, _ = plan_world()
    pose = (2.0, -1.0, 0.3)
    grid, minfo, world = distorted_map(pose=pose)
    q = measure(grid, minfo, plan, info, plan, (A[0] + 1.2, A[1] + 7.0), pose)
    sides = _sides(q)
    assert len(sides) == 4 and all(r["map_m"] is not None for r in sides)
    # The side along y = A[1] (A-B) is the one whose plan line is horizontal.
    outer = q.outlines[_outer(q)]
    k_ab = int(np.argmin([abs(ln.direction[1]) + abs(ln.point[1] - A[1]) for ln in
                          outer.plan_lines]))
    ab = sides[k_ab]
    assert ab["map_m"] / ab["plan_m"] == pytest.approx(1.02, abs=0.002)
    errors = q.outer_side_errors_pct()
    assert errors[k_ab] == pytest.approx(2.0, abs=0.2)
    assert errors == pytest.approx([r["error_pct"] for r in sides])
    # Every corner's map angle equals the drawn polygon's, the one at B is 3 deg off 90.
    diffs = sorted(abs(r["map_deg"] - r["plan_deg"]) for r in sides)
    assert diffs[-1] == pytest.approx(3.0, abs=0.2)
    # Sides not touched by the distortion keep their length: D-A.
    lengths = [r["map_m"] - r["plan_m"] for r in sides]
    assert min(abs(x) for x in lengths) < 0.05
    # Walls are off the plan where the loop was distorted, not everywhere.
    assert 0.3 < q.walls["within"] < 0.95
    text = "\n".join(report_lines(q))
    assert "diff_deg" in text
    png = tmp_path / "overlay.png"
    write_overlay(str(png), q, grid, minfo, plan, info, pose)
    img = cv2.imread(str(png))
    assert img is not None and max(img.shape[:2]) == 1600
    assert img.shape[0] / img.shape[1] == pytest.approx(plan.shape[0] / plan.shape[1], rel=0.01)
    # map walls drawn in red (BGR), plan sides in green
    assert np.any(np.all(img == (30, 30, 220), axis=2))


def test_unseen_side_is_not_measured():
    plan, info, _ = plan_world()
    grid = plan.copy()
    grid[:, int(20.0 / RES):] = UNKNOWN                     # east part never mapped
    q = measure(grid, info, plan, info, plan, (A[0] + 1.2, A[1] + 7.0))
    sides = _sides(q)
    assert any(r["map_m"] is None for r in sides)
    assert q.walls["seen_fraction"] < 0.9


@pytest.mark.parametrize("error", [(0.3, -0.2, 0.01), (-0.45, 0.1, -0.02)])
def test_best_placement_finds_a_map_frame_put_off(error):
    """A map of the right shape given at a wrong pose of its frame: the search moves it
    back to within a cell and a tenth of a degree of the pose it was drawn at (drawn
    turned, its cells match the plan's only to a cell), where it agrees at least as well
    as there, against a poor agreement at the given pose."""
    plan, info, _ = plan_world()
    pose = (2.0, -1.0, 0.3)
    grid, minfo, _ = distorted_map(scale=1.0, rotate_deg=0.0, pose=pose)
    at_pose = best_placement(grid, minfo, plan, info, pose,
                             QualityParams(placement_search_m=0.0, placement_search_rad=0.0))
    assert at_pose["offset"] == [0.0, 0.0, 0.0]
    given = tuple(np.add(pose, error))
    pl = best_placement(grid, minfo, plan, info, given)
    assert pl["pose"][:2] == pytest.approx(pose[:2], abs=RES + 1e-9)
    assert pl["pose"][2] == pytest.approx(pose[2], abs=math.radians(0.1))
    assert pl["offset"] == pytest.approx(np.subtract(pl["pose"], given).tolist())
    assert pl["agreed_share_given"] < 0.9 < at_pose["agreed_share"] <= pl["agreed_share"]


def test_best_placement_leaves_a_well_placed_map_and_keeps_to_its_bounds():
    plan, info, _ = plan_world()
    pl = best_placement(plan, info, plan, info)
    assert pl["offset"] == [0.0, 0.0, 0.0] and pl["agreed_share"] == 1.0
    # a frame 1.5 m off, searched within 0.5 m and 0.01 rad: it stops at the bounds
    p = QualityParams(placement_search_m=0.5, placement_search_rad=0.01)
    pl = best_placement(plan, info, plan, info, (1.5, 0.0, 0.0), p)
    assert abs(pl["offset"][0]) <= 0.5 + 1e-9 and abs(pl["offset"][1]) <= 0.5 + 1e-9
    assert abs(pl["offset"][2]) <= 0.01 + 1e-9
    assert pl["agreed_share"] >= pl["agreed_share_given"]


def test_measure_reports_the_placement_and_the_walls_there():
    plan, info, _ = plan_world()
    pose = (2.0, -1.0, 0.3)
    grid, minfo, _ = distorted_map(scale=1.0, rotate_deg=0.0, pose=pose)
    given = (pose[0] + 0.6, pose[1] - 0.4, pose[2])
    q = measure(grid, minfo, plan, info, plan, (A[0] + 1.2, A[1] + 7.0), given, place=True)
    assert q.walls["within"] < 0.5 < 0.95 < q.placement["walls"]["within"]
    text = "\n".join(report_lines(q))
    dx, dy, _ = q.placement["offset"]
    assert "best placement" in text and "(%+.3f, %+.3f) m" % (dx, dy) in text
    assert dx == pytest.approx(-0.6, abs=RES + 1e-9) and dy == pytest.approx(0.4, abs=RES + 1e-9)
    assert measure(grid, minfo, plan, info, plan, (A[0] + 1.2, A[1] + 7.0),
                   given).placement is None


def test_local_placements_show_where_a_side_mapped_too_long_moves_the_map(tmp_path):
    """The loop's long sides mapped 0.2 m too long, the map's frame at the plan's: the
    tiles of the west side lie in place, those of the east side 0.2 m east of theirs and,
    placed on their own, agree far better than where they are. measure() reports the
    tiles, the overlay draws them."""
    plan, info, _ = plan_world()
    grid, minfo, _ = distorted_map(scale=1.0 + 0.2 / L, rotate_deg=0.0, pose=(0.0, 0.0, 0.0))
    tiles = local_placements(grid, minfo, plan, info, tile_m=5.0)
    west = [t for t in tiles if t["centre"][0] < A[0] + WIDTH_M]
    east = [t for t in tiles if t["centre"][0] > A[0] + L - 1.0]     # the east side's own
    middle = [t for t in tiles if A[0] + 5.0 < t["centre"][0] < A[0] + L - 5.0]
    assert len(west) >= 3 and len(east) >= 3 and len(middle) >= 6
    for t in west:
        assert np.abs(t["displacement"]).max() <= RES + 1e-9
        assert t["share"] >= t["share_given"] > 0.95
    for t in east:
        assert t["displacement"][0] == pytest.approx(0.2, abs=RES + 1e-9)
        assert abs(t["displacement"][1]) <= RES + 1e-9
        assert t["share"] > 0.95 and t["share_given"] < 0.9
    for t in middle:    # a featureless corridor: along it the tile's place is not observable
        assert np.abs(t["displacement"]).max() <= RES + 1e-9
    q = measure(grid, minfo, plan, info, plan, (A[0] + 1.2, A[1] + 7.0), tile_m=5.0)
    assert [t["displacement"] for t in q.tiles] == [t["displacement"] for t in tiles]
    text = "\n".join(report_lines(q))
    assert "map-plan_x" in text and len(text.splitlines()) >= len(tiles) + 1
    png = tmp_path / "tiles.png"
    write_overlay(str(png), q, grid, minfo, plan, info, (0.0, 0.0, 0.0))
    assert png.stat().st_size > 0
