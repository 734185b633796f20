"""The parameters of the nodes target_estimator and fusion (read with
ascc_common.params.from_params; the README's tables list them)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional

from ascc_common.params import param

from .fusion import CI_CRITERIA, METHODS


@dataclass
class EstimatorParams:
    """target_estimator: one robot's target estimate in map (eq. 3.6-3.7)."""

    robot: str = param("", "robot name in the estimates (empty: the node's namespace)")
    kind: str = param("cone", "the Detection kind to localise")
    map_frame: str = param("map", "frame of amcl_pose and of the estimates")
    base_frame: str = param("base_link", "frame_id the Target messages must have "
                                         "(robotA/base_link in a namespace)")
    laser_only: bool = param(True, "use only laser ranges (false: also the size estimate)")
    range_sigma_m: float = param(0.03, "[m] standard deviation of a laser range", gt=0.0)
    size_range_sigma_frac: float = param(0.15, "[1] standard deviation of a size range, as "
                                               "a fraction of it", gt=0.0)
    bearing_sigma_rad: float = param(0.02, "[rad] standard deviation of the bearing",
                                     gt=0.0)
    range_offset_m: float = param(0.0, "[m] added to the range: from the target's surface "
                                       "the laser hits to its centre", ge=0.0)
    max_pose_age_s: float = param(0.0, "[s] a pose older than the target frame by more is "
                                       "not used (0: any age; amcl publishes only after "
                                       "the robot moved)", ge=0.0)
    nomotion_updates: int = param(0, "[1] amcl no-motion updates to request, one per "
                                      "nomotion_period_s, from the start (a standing robot's "
                                      "amcl updates only on request)", ge=0)
    nomotion_period_s: float = param(1.0, "[s] between the no-motion update requests",
                                     gt=0.0)


@dataclass
class FusionParams:
    """fusion: the robots' estimates fused (eq. 3.1-3.5 or a covariance fusion)."""

    robots: str = param("robotA robotB robotC", "the robots (space or comma separated)")
    topic_prefix: str = param("", "before <robot>/<estimate_topic>: '' relative to the "
                                  "node's namespace, '/' global (a fusion in a robot's "
                                  "namespace)")
    estimate_topic: str = param("target_estimate", "each robot's estimate topic")
    method: str = param("thesis", "thesis | information | ci", choices=METHODS)
    ci_criterion: str = param("trace", "ci: minimise the trace or det", choices=CI_CRITERIA)
    window_s: float = param(1.0, "[s] estimates are fused when within this of the newest "
                                 "and of now", gt=0.0)
    rate_hz: float = param(2.0, "[Hz] fusion rate", gt=0.0)
    future_tolerance_s: float = param(0.2, "[s] a stamp further ahead of now is refused",
                                      ge=0.0)
    max_clock_offset_s: float = param(0.5, "[s] a robot whose clock offset is beyond is "
                                           "refused", gt=0.0)
    clock_samples: int = param(50, "[1] messages per robot in the clock offset estimate",
                               ge=1)
    gate_chi2: float = param(0.0, "[1] with 3+ robots, leave out one whose squared "
                                  "Mahalanobis distance to the others exceeds this (13.8: "
                                  "99.9 % for 2 dof; 0: no gate, as the thesis)", ge=0.0)
    gate_memory_s: float = param(10.0, "[s] a robot the gate left out of three or more "
                                       "stays out this long of a fusion of two it "
                                       "disagrees with (beyond gate_chi2); 0: no memory",
                                 ge=0.0)
    map_frame: str = param("map", "frame of the estimates and of the fused target")
    ellipse_sigma: float = param(2.0, "[1] the drawn ellipses' size in standard deviations",
                                 gt=0.0)
    truth_xy_m: Optional[List[float]] = param(None, "[m] the target's true position in map, "
                                                    "drawn only (unset: not drawn)", length=2)

    def robot_list(self) -> List[str]:
        names = [r for r in self.robots.replace(",", " ").split() if r]
        if not names:
            raise ValueError("~robots: %r names no robot" % self.robots)
        return names

    def validate(self) -> None:
        self.robot_list()
