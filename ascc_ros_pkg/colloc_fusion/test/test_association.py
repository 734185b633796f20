"""Bad estimates rejected with a reason naming the robot; association by stamps within a
window; stale, future and missing robots left out and reported; clock offsets."""
import numpy as np
import pytest

from colloc_fusion.association import ClockOffsets, associate, check_estimate
from colloc_fusion.estimate import TargetEstimate

NAN = float("nan")


def est(robot, stamp=10.0, x=1.0, y=2.0, cov=((0.01, 0.0), (0.0, 0.02)), frame="map"):
    return TargetEstimate(robot, x, y, np.array(cov, dtype=float), stamp, frame)


@pytest.mark.parametrize("bad, what", [
    (est("robotB", cov=((0.0, 0.0), (0.0, 0.02))), "positive"),
    (est("robotB", cov=((-0.01, 0.0), (0.0, 0.02))), "positive"),
    (est("robotB", cov=((NAN, 0.0), (0.0, 0.02))), "finite"),
    (est("robotB", cov=((0.01, 0.02), (0.02, 0.01))), "positive definite"),
    (est("robotB", cov=((0.01, 0.001), (0.0, 0.01))), "symmetric"),
    (est("robotB", x=NAN), "not finite"),
    (est("robotB", frame="robotB/odom"), "frame"),
    (est("robotB", stamp=NAN), "stamp"),
])
def test_bad_estimates_rejected_naming_the_robot(bad, what):
    reason = check_estimate(bad)
    assert reason is not None and "robotB" in reason and what in reason


def test_good_estimate_and_leading_slash_frame():
    assert check_estimate(est("robotA")) is None
    assert check_estimate(est("robotA", frame="/map")) is None


def test_associate_leaves_out_stale_future_bad_and_missing():
    latest = {"robotA": est("robotA", 10.0), "robotB": est("robotB", 8.0),
              "robotC": est("robotC", 10.5)}
    ok, left = associate(latest, now_s=10.2, window_s=1.0,
                         expected=("robotA", "robotB", "robotC", "robotD"))
    assert [e.robot for e in ok] == ["robotA"]
    assert "stale" in left["robotB"] and "future" in left["robotC"]
    assert "no estimate" in left["robotD"]
    latest["robotC"] = est("robotC", 10.1, x=NAN)
    ok, left = associate(latest, now_s=10.2, window_s=3.0)
    assert [e.robot for e in ok] == ["robotA", "robotB"] and "robotC" in left


def test_associate_within_one_window_of_the_newest():
    latest = {"robotA": est("robotA", 10.0), "robotB": est("robotB", 9.75),
              "robotC": est("robotC", 9.2)}
    ok, left = associate(latest, now_s=10.0, window_s=0.5)
    assert [e.robot for e in ok] == ["robotA", "robotB"]
    assert "robotC" in left["robotC"]


def test_clock_offsets_lower_bound_and_refusal():
    clocks = ClockOffsets(samples=20, max_offset_s=0.5)
    rng = np.random.default_rng(0)
    for k in range(20):
        t = 100.0 + k
        clocks.add("robotA", t - 0.02 - rng.uniform(0.0, 0.05), t)  # in sync, 20-70 ms delay
        clocks.add("robotB", t + 2.0 - 0.02 - rng.uniform(0.0, 0.05), t)  # 2 s ahead
        clocks.add("robotC", t - 3.0, t)  # 3 s behind
    assert -0.03 < clocks.offset("robotA") <= 0.0
    assert 1.95 < clocks.offset("robotB") <= 2.0
    assert clocks.refusal("robotA") is None
    msg = clocks.refusal("robotB")
    assert "robotB" in msg and "clock offset" in msg and "refused" in msg
    assert "robotC" in clocks.refusal("robotC")
    assert clocks.offset("nobody") is None and clocks.refusal("nobody") is None
    latest = {r: est(r, 120.0) for r in ("robotA", "robotB")}
    ok, left = associate(latest, 120.0, 1.0, clocks=clocks)
    assert [e.robot for e in ok] == ["robotA"] and "clock offset" in left["robotB"]


def test_consistency_gate_leaves_out_the_outlier_only():
    from colloc_fusion.association import consistency_gate
    ests = [est("robotA", x=1.0, y=2.0), est("robotB", x=1.05, y=2.0),
            est("robotC", x=2.2, y=2.0)]  # robotC 1.2 m off, sigma 0.1-0.14 m
    kept, left = consistency_gate(ests, 13.8)
    assert [e.robot for e in kept] == ["robotA", "robotB"]
    assert "robotC" in left["robotC"] and "inconsistent" in left["robotC"]
    kept, left = consistency_gate(ests, 0.0)  # off
    assert len(kept) == 3 and left == {}
    kept, left = consistency_gate(ests[:2] + [est("robotC", x=1.1, y=2.05)], 13.8)
    assert len(kept) == 3 and left == {}  # all agree within their covariances
    kept, left = consistency_gate([ests[0], ests[2]], 13.8)
    assert len(kept) == 2  # of two, neither can be blamed
