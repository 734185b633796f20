"""Unit tests of coverage and the writers (the thresholding rule and map_server files are
tested in ascc_common)."""

import math
import os

import cv2
import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_common.params import ParamError, from_params
from ascc_eval.report import (
    ExplorationRecord,
    LaserGeometry,
    MonitorParams,
    SeenArea,
    coverage,
    path_length,
    reachable_area,
    time_to_coverage,
    write_coverage_plot,
    write_map_png,
)


def two_rooms():
    t = np.full((40, 80), OCCUPIED, np.int8)
    t[1:-1, 1:39] = FREE                               # west room
    t[1:-1, 41:-1] = FREE                              # east room
    t[15:25, 39:41] = FREE                             # door 0.5 m
    return t, GridInfo(0.05, 80, 40)


def test_reachable_area_and_coverage():
    t, info = two_rooms()
    start = (0.5, 1.0)
    reach = reachable_area(t, info, start, clearance_m=0.0)
    assert reach.sum() == np.count_nonzero(t == FREE)
    # A door narrower than the footprint cuts the east room off.
    t_narrow = t.copy()
    t_narrow[15:25, 39:41] = OCCUPIED
    t_narrow[19:22, 39:41] = FREE                      # 0.15 m
    reach_n = reachable_area(t_narrow, info, start, clearance_m=0.18)
    assert not reach_n[:, 42:].any() and reach_n[:, :39].any()
    # Explored map: west room known, east room unknown -> coverage = west share.
    explored = np.full_like(t, UNKNOWN)
    explored[:, :40] = t[:, :40]
    reach = reachable_area(t, info, start, clearance_m=0.18)
    west = np.count_nonzero(reach[:, :40])
    assert coverage(explored, info, t, info, start, 0.18) == pytest.approx(west / reach.sum())
    assert coverage(t, info, t, info, start) == pytest.approx(1.0)
    # Explored map at another origin/resolution still lines up with the truth.
    coarse = cv2.resize(t, (40, 20), interpolation=cv2.INTER_NEAREST)
    c = coverage(coarse, GridInfo(0.1, 40, 20), t, info, start, 0.18)
    assert c > 0.95
    assert coverage(explored, info, t, info, (50.0, 50.0)) == 0.0   # start off the map


def seen_at(area, x, y):
    ix, iy = area.info.world_to_cell(x, y)
    return area.known[iy, ix] != UNKNOWN


def test_seen_area_field_of_view_walls_and_range():
    t, info = two_rooms()
    reach = reachable_area(t, info, (0.5, 1.0), clearance_m=0.0)
    area = SeenArea(t, info, reach, LaserGeometry(4.0, math.radians(240.0), 0.0))
    assert area.coverage() == 0.0
    assert area.add(0.5, 1.0, 0.0)                      # in the west room, facing the door
    assert seen_at(area, 1.5, 1.0) and seen_at(area, 1.0, 1.8)
    assert not seen_at(area, 0.1, 1.0)                  # behind it: outside the 240 deg
    assert seen_at(area, 3.0, 1.0)                      # east room, through the door
    assert not seen_at(area, 3.0, 0.1)                  # east room, behind the wall
    c1 = area.coverage()
    assert 0.3 < c1 < 0.8
    assert not area.add(0.52, 1.0, 0.05)                # hardly moved: no cast
    assert area.casts == 1
    assert area.add(0.5, 1.0, math.pi)                  # turned round: sees behind
    assert seen_at(area, 0.1, 1.0) and area.coverage() > c1
    # Range: a 1 m laser at the same pose does not reach the east room.
    short = SeenArea(t, info, reach, LaserGeometry(1.0, math.radians(240.0), 0.0))
    short.add(0.5, 1.0, 0.0)
    assert seen_at(short, 1.4, 1.0) and not seen_at(short, 3.0, 1.0)
    # The mount: 0.3 m ahead of the robot's centre the laser sees past a wall's end.
    t2 = t.copy()
    t2[10:30, 16] = OCCUPIED                             # wall at x = 0.8 m, y 0.5..1.5
    ahead = SeenArea(t2, info, reach, LaserGeometry(4.0, math.radians(240.0), 0.0))
    ahead.add(0.5, 1.0, 0.0)
    assert not seen_at(ahead, 1.2, 1.0)
    mounted = SeenArea(t2, info, reach, LaserGeometry(4.0, math.radians(240.0), 0.45))
    mounted.add(0.5, 1.0, 0.0)
    assert seen_at(mounted, 1.2, 1.0)


def test_exploration_record_seen_coverage(tmp_path):
    t, info = two_rooms()
    rec = ExplorationRecord(t, info, (0.5, 1.0), 0.0, label="seen")
    rec.add_pose(0.0, 0.5, 1.0, 0.0)                    # no laser yet: not cast
    rec.add_map(0.0, np.full_like(t, UNKNOWN), info)
    assert rec.summary()["seen_coverage"] is None
    rec.set_laser(LaserGeometry(4.0, math.radians(240.0), 0.0))
    for i, x in enumerate(np.linspace(0.5, 3.5, 13)):   # drive east through the door
        rec.add_pose(1.0 + i, x, 1.0, 0.0)
        rec.add_map(1.0 + i, np.full_like(t, UNKNOWN), info)
    s = rec.write(str(tmp_path))
    assert s["final_coverage"] == 0.0                    # the map stayed empty: not seen
    assert 0.5 < s["seen_coverage"] < 1.0                # the west room's back corners
    times, seen = rec.seen_curve()
    assert len(times) == 13 and all(b >= a for a, b in zip(seen, seen[1:]))
    assert s["time_to_seen_coverage_s"]["0.99"] is None


def test_path_length_and_time_to_coverage():
    assert path_length([(0, 0), (3, 4), (3, 5)]) == pytest.approx(6.0)
    assert path_length([(1, 1)]) == 0.0
    t = [0, 10, 20, 30]
    c = [0.2, 0.91, 0.96, 0.97]
    assert time_to_coverage(t, c) == {0.90: 10.0, 0.95: 20.0, 0.99: None}


def test_writers_make_png_files(tmp_path):
    t, info = two_rooms()
    p1 = str(tmp_path / "map.png")
    write_map_png(p1, t, info, path_xy=[(0.5, 1.0), (1.0, 1.0), (3.0, 1.0)],
                  goals_xy=[(1.0, 1.0), (3.0, 1.0)], candidates_xy=[(2.0, 1.5)],
                  robot_xy=(3.0, 1.0), title="test")
    p2 = str(tmp_path / "cov.png")
    write_coverage_plot(p2, {"utility": ([0, 5, 10], [0.1, 0.5, 0.96]),
                             "nearest": ([0, 5, 12], [0.1, 0.4, 0.95])})
    for p in (p1, p2):
        img = cv2.imread(p)
        assert img is not None and img.shape[0] > 100 and os.path.getsize(p) > 1000
        assert img.std() > 10                          # not a blank canvas


def test_compose_and_exploration_record(tmp_path):
    from ascc_eval.report import ExplorationRecord, compose

    t, info = two_rooms()
    # A map frame sitting at (1, 0.5) rotated by 90 deg inside the truth frame.
    moved = compose((1.0, 0.5, math.pi / 2), GridInfo(0.05, 80, 40, 0.2, 0.0, 0.0))
    assert (moved.origin_x, moved.origin_y) == pytest.approx((1.0, 0.7))
    assert moved.origin_yaw == pytest.approx(math.pi / 2)
    rec = ExplorationRecord(t, info, (0.5, 1.0), 0.18, label="unit")
    half = np.full_like(t, UNKNOWN)
    half[:, :40] = t[:, :40]
    c1 = rec.add_map(10.0, half, info)
    c2 = rec.add_map(25.0, t, info)
    assert 0.3 < c1 < 0.7 and c2 == pytest.approx(1.0)
    for i, x in enumerate(np.linspace(0.5, 3.0, 6)):
        rec.add_pose(10.0 + i, x, 1.0)
    rec.add_goal(3.0, 1.0)
    rec.add_bump()
    s = rec.write(str(tmp_path))
    assert s["final_coverage"] == pytest.approx(1.0)
    assert s["path_m"] == pytest.approx(2.5)
    assert s["time_to_coverage_s"] == {"0.90": 15.0, "0.95": 15.0, "0.99": 15.0}
    assert s["goals"] == 1 and s["bumps"] == 1
    for name in ("unit.json", "unit_map.png", "unit_coverage.png", "unit_explored.yaml",
                 "unit_explored.pgm"):
        assert (tmp_path / name).stat().st_size > 100


def test_monitor_output_dir_falls_back_to_out_dir():
    assert from_params(MonitorParams, {}.get).output_directory() == ""
    assert from_params(MonitorParams, {"out_dir": "old"}.get).output_directory() == "old"
    both = {"out_dir": "old", "output_dir": "new"}
    assert from_params(MonitorParams, both.get).output_directory() == "new"
    assert from_params(MonitorParams, {"out_dir": "old", "output_dir": ""}.get) \
        .output_directory() == ""


def test_monitor_map_pose_is_three_numbers_or_unset():
    assert from_params(MonitorParams, {}.get).map_pose_in_truth is None
    pose = from_params(MonitorParams, {"map_pose_in_truth": [1, 2.5, "0.5"]}.get)
    assert pose.map_pose_in_truth == [1.0, 2.5, 0.5]
    with pytest.raises(ParamError, match="parameter ~map_pose_in_truth: expected list of 3"):
        from_params(MonitorParams, {"~map_pose_in_truth": [1.0, 2.0]}.get, "~")
