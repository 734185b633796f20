"""The fusion node's core without ROS: robots left out and back, bad estimates refused
with the robot's name, clock refusal, status, ellipses; the nodes' parameters."""
import math

import numpy as np
import pytest

from ascc_common.params import ParamError, from_params
from colloc_fusion.estimate import TargetEstimate, pick_detection
from colloc_fusion.fuser import FusionCore, ellipse
from colloc_fusion.node_params import EstimatorParams, FusionParams


def est(robot, stamp, x=1.0, y=2.0, var=0.01, frame="map"):
    return TargetEstimate(robot, x, y, np.eye(2) * var, stamp, frame)


def core(**kw):
    return FusionCore(from_params(FusionParams, kw.get))


def test_three_two_three_robots():
    c = core(window_s=1.0)
    for t in (10.0, 10.5):
        for r in ("robotA", "robotB", "robotC"):
            assert c.add(est(r, t, x=1.0 + 0.1 * "ABC".index(r[-1])), t + 0.05) is None
    fused, left = c.step(10.6)
    assert fused.robots == ["robotA", "robotB", "robotC"] and left == {}
    assert math.isclose(fused.x, 1.1)
    for r in ("robotA", "robotC"):  # robotB silent from 10.5 on
        c.add(est(r, 11.0), 11.05)
    fused, left = c.step(11.45)
    assert fused.robots == ["robotA", "robotB", "robotC"]  # 0.95 s: within the window
    for t in (11.5, 12.0):
        for r in ("robotA", "robotC"):
            c.add(est(r, t), t + 0.05)
    fused, left = c.step(12.05)
    assert fused.robots == ["robotA", "robotC"] and "stale" in left["robotB"]
    status = c.status(12.05, fused, left)
    assert status["robots"] == ["robotA", "robotC"] and "robotB" in status["left_out"]
    assert set(status["clock_offsets_s"]) == {"robotA", "robotB", "robotC"}
    c.add(est("robotB", 12.4), 12.45)  # back
    fused, _ = c.step(12.5)
    assert fused.robots == ["robotA", "robotB", "robotC"]


def test_no_estimate_at_all():
    fused, left = core().step(5.0)
    assert fused is None and set(left) == {"robotA", "robotB", "robotC"}
    assert "no estimate" in left["robotA"]


@pytest.mark.parametrize("bad, what", [
    (est("robotB", 1.0, var=0.0), "positive"),
    (est("robotB", 1.0, var=float("nan")), "finite"),
    (est("robotB", 1.0, x=float("nan")), "not finite"),
    (est("robotB", 1.0, frame="robotB/odom"), "frame"),
])
def test_bad_estimate_refused_naming_the_robot_and_older_good_kept(bad, what):
    c = core()
    assert c.add(est("robotB", 0.9), 0.95) is None
    reason = c.add(bad, 1.05)
    assert "robotB" in reason and what in reason
    fused, _ = c.step(1.1)
    assert fused.robots == ["robotB"] and np.isfinite([fused.x, fused.y]).all()


def test_unknown_robot_and_skewed_clock():
    c = core(max_clock_offset_s=0.5)
    assert "robotZ" in c.add(est("robotZ", 1.0), 1.0)
    c.add(est("robotA", 10.0), 10.05)
    c.add(est("robotC", 7.0), 10.05)  # 3 s behind
    c.add(est("robotB", 12.0), 10.05)  # 2 s ahead
    fused, left = c.step(10.1)
    assert fused.robots == ["robotA"]
    assert "clock offset" in left["robotC"] and "clock offset" in left["robotB"]


@pytest.mark.parametrize("method", ["thesis", "information", "ci"])
def test_every_method_through_the_core(method):
    c = core(method=method)
    c.add(TargetEstimate("robotA", 1.0, 0.0, np.array([[0.04, 0.01], [0.01, 0.01]]), 1.0),
          1.0)
    c.add(TargetEstimate("robotB", 1.2, 0.1, np.array([[0.01, 0.0], [0.0, 0.04]]), 1.0),
          1.0)
    fused, _ = c.step(1.0)
    assert 1.0 <= fused.x <= 1.2 and 0.0 <= fused.y <= 0.1
    assert np.all(np.linalg.eigvalsh(fused.cov) > 0)


def test_ellipse_axes_and_angle():
    major, minor, angle = ellipse(np.diag([0.04, 0.01]), 2.0)
    assert math.isclose(major, 0.8) and math.isclose(minor, 0.4)
    assert math.isclose(abs(math.cos(angle)), 1.0, abs_tol=1e-9)
    r = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    _, _, angle = ellipse(r @ np.diag([0.09, 0.01]) @ r.T, 1.0)
    assert math.isclose(math.remainder(angle - 0.5, math.pi), 0.0, abs_tol=1e-9)


def test_params_defaults_and_bad_values():
    p = from_params(FusionParams, {}.get)
    assert p.robot_list() == ["robotA", "robotB", "robotC"] and p.truth_xy_m is None
    assert from_params(FusionParams, {"robots": "a,b"}.get).robot_list() == ["a", "b"]
    for bad in ({"robots": " "}, {"method": "mean"}, {"window_s": 0.0},
                {"truth_xy_m": [1.0]}):
        with pytest.raises(ParamError):
            from_params(FusionParams, bad.get)
    e = from_params(EstimatorParams, {}.get)
    assert e.kind == "cone" and e.laser_only
    with pytest.raises(ParamError):
        from_params(EstimatorParams, {"range_sigma_m": 0.0}.get)


class Det:
    def __init__(self, kind, source):
        self.kind, self.range_source = kind, source


def test_pick_detection_laser_first_kind_only():
    dets = [Det("shirt", 1), Det("cone", 2), Det("cone", 1)]
    assert pick_detection(dets, "cone", True, 1, 2) is dets[2]
    assert pick_detection(dets, "cone", False, 1, 2) is dets[1]
    assert pick_detection(dets[:2], "cone", True, 1, 2) is None
    assert pick_detection([], "cone", False, 1, 2) is None


def test_core_gate_reports_the_inconsistent_robot():
    c = core(gate_chi2=13.8)
    for r, x in (("robotA", 1.0), ("robotB", 1.05), ("robotC", 2.5)):
        c.add(est(r, 1.0, x=x), 1.0)
    fused, left = c.step(1.0)
    assert fused.robots == ["robotA", "robotB"] and "inconsistent" in left["robotC"]
    assert "robotC" in c.status(1.0, fused, left)["left_out"]


def test_core_gate_memory_keeps_a_blamed_robot_out_of_two():
    """robotC, left out by a vote of three, stays out while only robotA and robotC are in
    the window and disagree, for gate_memory_s; after it, of two neither can be blamed."""
    c = core(gate_chi2=13.8, gate_memory_s=5.0, window_s=1.0)
    for r, x in (("robotA", 1.0), ("robotB", 1.05), ("robotC", 2.5)):
        c.add(est(r, 1.0, x=x), 1.0)
    fused, left = c.step(1.0)
    assert fused.robots == ["robotA", "robotB"] and "robotC" in left
    for t in (2.5, 5.5):  # robotB silent: stale from 2.0 on
        c.add(est("robotA", t, x=1.0), t)
        c.add(est("robotC", t, x=2.5), t)
        fused, left = c.step(t)
        assert fused.robots == ["robotA"], t
        assert "inconsistent with robot robotA" in left["robotC"] and "ago" in left["robotC"]
        assert "stale" in left["robotB"]
    c.add(est("robotA", 6.5, x=1.0), 6.5)
    c.add(est("robotC", 6.5, x=2.5), 6.5)
    fused, left = c.step(6.5)  # 5.5 s after the vote: the memory is over
    assert fused.robots == ["robotA", "robotC"] and "robotC" not in left


def test_core_gate_memory_needs_disagreement_and_is_cleared_by_a_vote():
    c = core(gate_chi2=13.8, gate_memory_s=30.0, window_s=1.0)
    for r, x in (("robotA", 1.0), ("robotB", 1.05), ("robotC", 2.5)):
        c.add(est(r, 1.0, x=x), 1.0)
    c.step(1.0)
    c.add(est("robotA", 2.5, x=1.0), 2.5)
    c.add(est("robotC", 2.5, x=1.02), 2.5)  # back in place: agrees with robotA
    fused, left = c.step(2.5)
    assert fused.robots == ["robotA", "robotC"]
    for r, x in (("robotA", 1.0), ("robotB", 1.05), ("robotC", 1.02)):
        c.add(est(r, 3.0, x=x), 3.0)
    fused, _ = c.step(3.0)  # a vote of three keeps robotC: no longer a suspect
    assert fused.robots == ["robotA", "robotB", "robotC"] and c.blamed == {}
    c.add(est("robotA", 4.5, x=1.0), 4.5)
    c.add(est("robotC", 4.5, x=2.5), 4.5)
    fused, left = c.step(4.5)  # off again, but only two: neither can be blamed
    assert fused.robots == ["robotA", "robotC"]


def test_core_no_gate_no_memory():
    c = core(gate_chi2=0.0, gate_memory_s=30.0)
    for r, x in (("robotA", 1.0), ("robotB", 1.05), ("robotC", 2.5)):
        c.add(est(r, 1.0, x=x), 1.0)
    fused, left = c.step(1.0)
    assert fused.robots == ["robotA", "robotB", "robotC"] and c.blamed == {}
