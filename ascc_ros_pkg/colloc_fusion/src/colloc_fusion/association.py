"""Which robots' estimates are fused: checks, clock offsets and association by stamps.

Every estimate is checked before fusion (``check_estimate``): its frame, a finite mean,
and a symmetric positive-definite covariance with finite entries; a failure is a reason
naming the robot. Estimates are associated by their stamps (``associate``): the newest
estimate of each robot is used when its stamp lies within ``window_s`` of the newest
stamp among all robots and not more than ``future_tolerance_s`` ahead of the receiver's
clock; the others are left out, each with the reason.

Clock skew (``ClockOffsets``): for each robot, the offset of its clock from the
receiver's is estimated as max(stamp - receipt time) over the last ``samples`` messages.
A message's stamp - receipt time is the offset minus the transport delay, and the delay
is never negative, so the maximum is the offset less the smallest delay seen: a
lower bound, tight when some message travelled fast. A robot whose |offset| exceeds
``max_offset_s`` is refused with a message saying so.
"""
from __future__ import annotations

import collections
import math
from typing import Deque, Dict, List, Optional, Tuple

import numpy as np

from .estimate import TargetEstimate
from .fusion import information_fuse


def check_estimate(est: TargetEstimate, frame_id: str = "map") -> Optional[str]:
    """Why ``est`` cannot be fused (a message naming the robot), or None."""
    who = "robot %s" % (est.robot or "?")
    if est.frame_id.lstrip("/") != frame_id.lstrip("/"):
        return "%s: estimate in frame %r, expected %r" % (who, est.frame_id, frame_id)
    if not (math.isfinite(est.x) and math.isfinite(est.y)):
        return "%s: position (%r, %r) is not finite" % (who, est.x, est.y)
    if not math.isfinite(est.stamp_s):
        return "%s: stamp %r is not finite" % (who, est.stamp_s)
    cov = np.asarray(est.cov, dtype=float)
    if cov.shape != (2, 2) or not np.isfinite(cov).all():
        return "%s: covariance %s is not a finite 2x2 matrix" % (who, cov.tolist())
    if cov[0, 0] <= 0.0 or cov[1, 1] <= 0.0:
        return "%s: variances (%g, %g) m^2 must be positive" % (who, cov[0, 0], cov[1, 1])
    if abs(cov[0, 1] - cov[1, 0]) > 1e-9 * max(1.0, abs(cov[0, 1])):
        return "%s: covariance is not symmetric" % who
    if cov[0, 0] * cov[1, 1] - cov[0, 1] * cov[1, 0] <= 0.0:
        return "%s: covariance is not positive definite" % who
    return None


class ClockOffsets:
    """Each robot's clock offset [s] (its clock minus the receiver's, a lower bound: see
    the module's doc) from the last ``samples`` (stamp, receipt time) pairs."""

    def __init__(self, samples: int = 50, max_offset_s: float = 0.5):
        self.samples = samples
        self.max_offset_s = max_offset_s
        self._d: Dict[str, Deque[float]] = {}

    def add(self, robot: str, stamp_s: float, received_s: float) -> None:
        if math.isfinite(stamp_s) and math.isfinite(received_s):
            self._d.setdefault(robot, collections.deque(maxlen=self.samples)).append(
                stamp_s - received_s)

    def offset(self, robot: str) -> Optional[float]:
        d = self._d.get(robot)
        return max(d) if d else None

    def offsets(self) -> Dict[str, float]:
        return {r: max(d) for r, d in self._d.items() if d}

    def refusal(self, robot: str) -> Optional[str]:
        """Why ``robot`` is refused for its clock (None: its offset is within bound)."""
        off = self.offset(robot)
        if off is not None and abs(off) > self.max_offset_s:
            return "robot %s: clock offset %+.3f s is beyond the bound of %.3f s: " \
                "estimate refused (synchronise its clock, e.g. chrony)" \
                % (robot, off, self.max_offset_s)
        return None

    def forget(self, robot: str) -> None:
        self._d.pop(robot, None)


def associate(latest: Dict[str, TargetEstimate], now_s: float, window_s: float,
              future_tolerance_s: float = 0.1, frame_id: str = "map",
              expected: Tuple[str, ...] = (),
              clocks: Optional[ClockOffsets] = None
              ) -> Tuple[List[TargetEstimate], Dict[str, str]]:
    """The estimates to fuse from each robot's newest one, and the robots left out with
    why (bad, refused for its clock, from the future, stale, or, for the ``expected``
    robots, missing). Sorted by robot name."""
    left: Dict[str, str] = {}
    ok: List[TargetEstimate] = []
    for robot in sorted(latest):
        est = latest[robot]
        reason = check_estimate(est, frame_id) or (clocks.refusal(robot) if clocks else None)
        if reason is None and est.stamp_s > now_s + future_tolerance_s:
            reason = "robot %s: stamp %.3f s is %.3f s in the future (clock skew?)" \
                % (robot, est.stamp_s, est.stamp_s - now_s)
        if reason is None and est.stamp_s < now_s - window_s:
            reason = "robot %s: newest estimate is %.3f s old (window %.3f s): stale" \
                % (robot, now_s - est.stamp_s, window_s)
        if reason:
            left[robot] = reason
        else:
            ok.append(est)
    if ok:  # associate around the newest stamp: all within one window of it
        newest = max(ok, key=lambda e: e.stamp_s)
        for e in list(ok):
            if e.stamp_s < newest.stamp_s - window_s:
                left[e.robot] = "robot %s: estimate %.3f s older than robot %s's newest " \
                    "(window %.3f s)" % (e.robot, newest.stamp_s - e.stamp_s, newest.robot,
                                         window_s)
                ok.remove(e)
    for robot in expected:
        if robot not in latest:
            left[robot] = "robot %s: no estimate received" % robot
    return ok, left


def _mahalanobis2(est: TargetEstimate, others: List[TargetEstimate]) -> float:
    """Squared Mahalanobis distance of ``est`` to the information fusion of ``others``,
    with covariance P_est + P_others."""
    mean, cov = information_fuse([o.mean for o in others], [o.cov for o in others])
    d = est.mean - mean
    return float(d @ np.linalg.solve(cov + np.asarray(est.cov, dtype=float), d))


def consistency_gate(estimates: List[TargetEstimate], chi2_max: float,
                     suspects: Optional[Dict[str, str]] = None
                     ) -> Tuple[List[TargetEstimate], Dict[str, str]]:
    """Leave out, one at a time, the estimate that disagrees most with the others while it
    disagrees beyond ``chi2_max``: the squared Mahalanobis distance between an estimate and
    the information fusion of the others, with covariance P_i + P_others (13.8: the 99.9 %
    quantile of chi-square with 2 degrees of freedom). Needs three estimates or more: of
    two that disagree, neither can be blamed by this test, unless exactly one of them is
    in ``suspects`` (robot -> why: a robot an earlier vote of three left out, see
    ``FusionCore``), which is then left out. ``chi2_max`` <= 0: no gate."""
    kept = list(estimates)
    left: Dict[str, str] = {}
    if chi2_max > 0.0 and len(kept) == 2 and suspects:
        blamed = [e for e in kept if e.robot in suspects]
        if len(blamed) == 1:
            e = blamed[0]
            other = kept[1] if e is kept[0] else kept[0]
            d2 = _mahalanobis2(e, [other])
            if d2 > chi2_max:
                kept.remove(e)
                left[e.robot] = "robot %s: inconsistent with robot %s (Mahalanobis d^2 " \
                    "%.1f > %.1f) and %s: left out" % (e.robot, other.robot, d2, chi2_max,
                                                      suspects[e.robot])
        return kept, left
    while chi2_max > 0.0 and len(kept) >= 3:
        worst, worst_d2 = None, -1.0
        for e in kept:
            d2 = _mahalanobis2(e, [o for o in kept if o is not e])
            if d2 > worst_d2:
                worst, worst_d2 = e, d2
        if worst is None or worst_d2 <= chi2_max:
            break
        kept.remove(worst)
        left[worst.robot] = "robot %s: inconsistent with the others (Mahalanobis d^2 %.1f " \
            "> %.1f): left out" % (worst.robot, worst_d2, chi2_max)
    return kept, left
