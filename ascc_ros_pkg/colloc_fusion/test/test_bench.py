"""The benchmark's pure parts: random placements obey their rules; the offline replay."""
import math
import os

import numpy as np
import pytest

from ascc_sim.world import load_world
from colloc_fusion.bench import (
    ROBOTS,
    PlacementRules,
    beats_counts,
    best_on_average,
    error_split,
    pooled_error_correlation,
    random_placement,
    replay_errors,
)
from colloc_fusion.estimate import TargetEstimate

WORLD = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "ascc_sim",
                     "worlds", "three_robots.yaml")


def test_random_placements_follow_the_rules():
    world = load_world(WORLD)
    rules = PlacementRules()
    rng = np.random.default_rng(7)
    for _ in range(5):
        p = random_placement(world.grid, rng, (0.3, 0.3, 8.2, 6.7), rules)
        assert world.grid.disc_contact(*p.cone, rules.cone_clearance_m) is None
        assert set(p.robots) == set(ROBOTS)
        for name, (x, y, yaw) in p.robots.items():
            d = math.hypot(p.cone[0] - x, p.cone[1] - y)
            assert rules.range_m[0] <= d <= rules.range_m[1]
            off = math.remainder(math.atan2(p.cone[1] - y, p.cone[0] - x) - yaw, 2 * math.pi)
            assert abs(off) <= rules.max_heading_offset_rad + 1e-9
            assert world.grid.disc_contact(x, y, rules.robot_clearance_m) is None
            for other, (ox, oy, _) in p.robots.items():
                if other != name:
                    assert math.hypot(ox - x, oy - y) >= rules.min_separation_m


def test_replay_errors():
    truth = (1.0, 1.0)
    ests = []
    for k in range(20):
        t = 10.0 + 0.5 * k
        ests.append(TargetEstimate("robotA", 1.1, 1.0, np.eye(2) * 0.01, t))
        ests.append(TargetEstimate("robotB", 0.9, 1.0, np.eye(2) * 0.01, t))
        if k < 10:
            ests.append(TargetEstimate("robotC", 1.0, 1.3, np.eye(2) * 0.04, t))
    out = replay_errors(ests, truth, 10.0, 19.5)
    assert np.allclose(out["robotA"], 0.1) and len(out["robotC"]) == 10
    for method in ("thesis", "information", "ci"):
        assert len(out[method]) == 20 and max(out[method]) < 0.1
    # robotC gone after 14.5 s: A and B alone fuse to the truth
    assert math.isclose(out["thesis"][-1], 0.0, abs_tol=1e-9)


def test_error_split_into_pose_and_measurement_shares():
    # robot at (0, 0) facing +x, the target truly at (2, 0); amcl says (0, 0.1) and a
    # heading of +0.05 rad, and the measurement (range 2.02 ahead) is 2 cm long
    yaw = 0.05
    m = np.array([2.02, 0.0])
    e = np.array([0.0, 0.1]) + [math.cos(yaw) * m[0], math.sin(yaw) * m[0]]
    ests = [TargetEstimate("robotA", e[0], e[1], np.eye(2) * 0.01, t) for t in (5.0, 6.0)]
    ests.append(TargetEstimate("robotA", 9.0, 9.0, np.eye(2) * 0.01, 20.0))  # outside t1
    split = error_split(ests, {"robotA": [[1.0, 0.0, 0.1, yaw]], "robotB": []},
                        {"robotA": (0.0, 0.0, 0.0)}, (2.0, 0.0), 4.0, 10.0)
    assert set(split) == {"robotA"}
    s = split["robotA"]
    assert s["measurement"] == pytest.approx(0.02)  # from the true pose: (2.02, 0)
    assert s["pose"] == pytest.approx(math.hypot(e[0] - 2.02, e[1]))
    assert s["total"] == pytest.approx(math.hypot(e[0] - 2.0, e[1]))
    assert s["pose_xy"] == pytest.approx(0.1) and s["pose_yaw"] == pytest.approx(yaw)
    # no pose estimate before the target's stamp: nothing to split
    assert error_split(ests, {"robotA": [[7.0, 0.0, 0.1, yaw]]},
                       {"robotA": (0.0, 0.0, 0.0)}, (2.0, 0.0), 4.0, 6.5) == {}


def test_replay_reports_the_robot_the_gate_left_out():
    truth = (1.0, 1.0)
    ests = []
    for k in range(10):
        t = 10.0 + 0.5 * k
        ests.append(TargetEstimate("robotA", 1.01, 1.0, np.eye(2) * 4e-4, t))
        ests.append(TargetEstimate("robotB", 0.99, 1.0, np.eye(2) * 4e-4, t))
        ests.append(TargetEstimate("robotC", 2.4, 1.0, np.eye(2) * 4e-4, t))  # 1.4 m off
    left = {}
    out = replay_errors(ests, truth, 10.0, 14.5, variants={
        "thesis": {"method": "thesis"},
        "thesis+gate": {"method": "thesis", "gate_chi2": 13.8}}, left_out=left)
    assert set(left) == {"thesis+gate"} and set(left["thesis+gate"]) == {"robotC"}
    assert len(left["thesis+gate"]["robotC"]) == len(out["thesis+gate"]) == 10
    assert "inconsistent" in left["thesis+gate"]["robotC"][0]
    assert max(out["thesis+gate"]) < 1e-9 and min(out["thesis"]) > 0.4


def test_beats_counts_three_readings():
    rows = [  # per-trial errors [m]
        {"robotA": 0.010, "robotB": 0.020, "robotC": 0.030, "fused": 0.005},  # all three
        {"robotA": 0.004, "robotB": 0.020, "robotC": 0.030, "fused": 0.010},  # A, median
        {"robotA": 0.010, "robotB": 0.002, "robotC": 0.030, "fused": 0.008},  # A, median
        {"robotA": 0.010, "robotB": 0.005, "robotC": 0.008, "fused": 0.020},  # none
        {"robotA": None, "robotB": 0.005, "robotC": 0.008, "fused": 0.006},   # median
        {"robotA": 0.010, "robotB": 0.005, "robotC": 0.008},  # no fusion: not counted
    ]
    c = beats_counts(rows, ["fused"], advance_robot="robotA")["fused"]
    each = c.pop("each_robot")
    assert c == {"trials": 5, "per_trial_best": 1, "median_robot": 4,
                 "advance_robot": 2, "advance_trials": 4}
    assert each == {"robotA": [2, 4], "robotB": [2, 5], "robotC": [4, 5]}
    assert "advance_robot" not in beats_counts(rows, ["fused"])["fused"]
    # robotB: mean 0.0095 over 6 trials; robotA 0.0088 over 5; robotC 0.0227
    assert best_on_average(rows) == "robotA"
    assert best_on_average(rows, ("robotB", "robotC")) == "robotB"


def test_pooled_error_correlation():
    rng = np.random.default_rng(8)
    indep = [{r: rng.normal(0.0, 0.01, 2) for r in ROBOTS} for _ in range(3000)]
    assert abs(pooled_error_correlation(indep)) < 0.05
    shared = []
    for _ in range(3000):  # a common error of the same size as each robot's own
        c = rng.normal(0.0, 0.01, 2)
        shared.append({r: c + rng.normal(0.0, 0.01, 2) for r in ROBOTS})
    assert pooled_error_correlation(shared) == pytest.approx(0.5, abs=0.05)
    same = [{r: v for r in ROBOTS} for v in rng.normal(0.0, 0.01, (10, 2))]
    assert pooled_error_correlation(same) == pytest.approx(1.0)
    assert pooled_error_correlation(indep[:1]) is None
    assert pooled_error_correlation([{"robotA": (0.0, 0.0)}] * 5) is None
