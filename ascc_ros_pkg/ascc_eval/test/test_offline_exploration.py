"""Whole-loop exploration without ROS (offline.py's idealised robot) on synthetic offices:
coverage, no goal in a wall, the loop ends by itself, and the path helpers."""

import numpy as np
import pytest

from ascc_common.grid import GridInfo
from ascc_eval import offline
from ascc_eval.report import path_length
from frontier_detector.synthetic import first_free_cell_near, office_building

RES = 0.05


@pytest.fixture(scope="module")
def office():
    truth = office_building(14.0, RES, seed=7, rooms_between_halls=2)
    info = GridInfo(RES, truth.shape[1], truth.shape[0])
    r, c = first_free_cell_near(truth, 30, 140)
    return truth, info, info.cell_to_world(c, r)


@pytest.mark.parametrize("strategy", ["utility", "nearest"])
def test_explores_synthetic_office(office, strategy):
    truth, info, start = office
    run = offline.run(truth, info, start, strategy)
    assert run.status == "done"
    assert run.bad_goals == 0
    assert run.coverage[-1] >= 0.95
    assert run.coverage[0] < 0.5                       # it really had something to explore
    assert np.all(np.diff(run.coverage) >= -1e-9)      # coverage never drops
    assert run.path_m == pytest.approx(path_length(run.trajectory), rel=1e-6)
    assert len(run.goals_xy) == run.goals


def test_backtracked_path_avoids_walls(office):
    truth, info, start = office
    run = offline.run(truth, info, start, "utility",
                      offline.OfflineParams(max_goals=3))
    cells = [info.world_to_cell(x, y) for x, y in run.trajectory]
    assert all(truth[iy, ix] == 0 for ix, iy in cells)
