"""The fusion node's core without ROS: every robot's newest estimate, the clock offsets,
association and fusion at a given time, and the status it reports."""
from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from .association import ClockOffsets, associate, check_estimate, consistency_gate
from .estimate import TargetEstimate
from .fusion import Fused, FusionError, fuse
from .node_params import FusionParams


class FusionCore:
    """Feed it ``add(estimate, received_s)``; ``step(now_s)`` fuses."""

    def __init__(self, params: FusionParams):
        self.p = params
        self.robots = tuple(params.robot_list())
        self.latest: Dict[str, TargetEstimate] = {}
        self.clocks = ClockOffsets(params.clock_samples, params.max_clock_offset_s)
        # robot -> time [s] the gate last left it out by a vote of three or more: such a
        # robot stays out, for gate_memory_s, of a fusion of two that it disagrees with
        self.blamed: Dict[str, Tuple[float, int]] = {}

    def add(self, est: TargetEstimate, received_s: float) -> Optional[str]:
        """Store ``est`` as its robot's newest; a reason naming the robot when it is bad
        (then it is not stored, and an older good one is kept until it goes stale)."""
        if est.robot not in self.robots:
            return "robot %s: not one of %s; ignored" % (est.robot, ", ".join(self.robots))
        reason = check_estimate(est, self.p.map_frame)
        if reason:
            return reason
        self.clocks.add(est.robot, est.stamp_s, received_s)
        self.latest[est.robot] = est
        return None

    def step(self, now_s: float) -> Tuple[Optional[Fused], Dict[str, str]]:
        """The fusion at ``now_s`` (None when no robot's estimate is usable) and the robots
        left out with why."""
        ok, left = associate(self.latest, now_s, self.p.window_s, self.p.future_tolerance_s,
                             self.p.map_frame, self.robots, self.clocks)
        suspects = {r: "the gate left it out of %d robots %.1f s ago" % (n, now_s - t)
                    for r, (t, n) in self.blamed.items()
                    if 0.0 <= now_s - t <= self.p.gate_memory_s}
        voters = len(ok)
        ok, inconsistent = consistency_gate(ok, self.p.gate_chi2, suspects)
        if voters >= 3:  # a vote: remember who it left out, clear those it kept
            for e in ok:
                self.blamed.pop(e.robot, None)
            for r in inconsistent:
                self.blamed[r] = (now_s, voters)
        left.update(inconsistent)
        if not ok:
            return None, left
        try:
            return fuse(ok, self.p.method, self.p.ci_criterion, left), left
        except FusionError as err:
            left = dict(left, fusion=str(err))
            return None, left

    def status(self, now_s: float, fused: Optional[Fused], left: Dict[str, str]) -> dict:
        """The JSON-able status: method, robots fused, left out with why, clock offsets."""
        out = {"stamp": now_s, "method": self.p.method,
               "robots": fused.robots if fused else [], "left_out": left,
               "clock_offsets_s": {r: round(v, 4) for r, v in self.clocks.offsets().items()}}
        if fused:
            out.update(x=fused.x, y=fused.y, cov=np.asarray(fused.cov).tolist(),
                       weights=fused.weights)
        return out


def ellipse(cov, n_sigma: float) -> Tuple[float, float, float]:
    """The ``n_sigma`` uncertainty ellipse of a 2x2 covariance: full lengths of the major
    and minor axes [m] and the major axis's angle [rad]."""
    vals, vecs = np.linalg.eigh(np.asarray(cov, dtype=float))
    vals = np.clip(vals, 0.0, None)
    major = vecs[:, 1]
    return (2.0 * n_sigma * float(np.sqrt(vals[1])), 2.0 * n_sigma * float(np.sqrt(vals[0])),
            float(np.arctan2(major[1], major[0])))
