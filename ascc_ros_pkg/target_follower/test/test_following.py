"""The follower node's pure parts: odometry history and Detection checks (no master)."""
import math

import pytest

from ascc_common.params import from_params, parameters
from target_follower.following import (
    OdomHistory,
    TargetFollowerParams,
    observation_from_detection,
)
from target_follower.msg import Detection


def test_odom_history_interpolates_and_forgets():
    h = OdomHistory(keep_s=1.0)
    assert h.pose_at(0.0) is None and h.newest() is None
    h.add(0.0, (0.0, 0.0, 3.0))
    h.add(0.5, (1.0, 2.0, -3.0))  # yaw across the +-pi seam
    x, y, yaw = h.pose_at(0.25)
    assert (x, y) == pytest.approx((0.5, 1.0))
    assert abs(abs(yaw) - math.pi) < 0.01  # the short way round, not through 0
    assert h.pose_at(-1.0) == (0.0, 0.0, 3.0) and h.pose_at(9.0) == (1.0, 2.0, -3.0)
    h.add(0.4, (5.0, 5.0, 0.0))  # out of order: dropped
    assert h.newest() == (1.0, 2.0, -3.0)
    h.add(2.0, (3.0, 3.0, 0.0))
    assert h.stamps == [2.0]  # older than keep_s before the newest: forgotten


def detection(**fields):
    d = Detection(kind="shirt", bearing_rad=0.5, range_m=2.0,
                  range_source=Detection.RANGE_LASER, area_px=900.0, confidence=0.8)
    d.position.x, d.position.y = 2.0 * math.cos(0.5), 2.0 * math.sin(0.5)
    for k, v in fields.items():
        setattr(d, k, v)
    return d


def test_detections_become_observations():
    obs, why = observation_from_detection(detection())
    assert why == "" and obs.kind == "shirt"
    assert (obs.x_m, obs.y_m) == pytest.approx((2.0 * math.cos(0.5), 2.0 * math.sin(0.5)))
    d = detection()
    d.position.x = d.position.y = math.nan  # a range without a position: made from it
    obs, _ = observation_from_detection(d)
    assert math.hypot(obs.x_m, obs.y_m) == pytest.approx(2.0)
    obs, _ = observation_from_detection(detection(range_source=Detection.RANGE_NONE,
                                                  range_m=math.nan))
    assert not obs.has_position and obs.bearing_rad == pytest.approx(0.5)


@pytest.mark.parametrize("fields, words", [
    ({"bearing_rad": math.nan}, "non-finite bearing"),
    ({"bearing_rad": math.inf}, "non-finite bearing"),
    ({"kind": "ball"}, "unknown kind"),
    ({"range_m": math.nan}, "range_m"),
    ({"range_m": -1.0}, "range_m"),
])
def test_bad_detections_are_named(fields, words):
    obs, why = observation_from_detection(detection(**fields))
    assert obs is None and words in why


def test_node_parameters_are_flat_private_names():
    names = [p.name for p in parameters(TargetFollowerParams)]
    assert {"rate_hz", "distance_m", "kinds", "stop_distance_m"} <= set(names)
    assert len(names) == len(set(names))
    p = from_params(TargetFollowerParams, {"distance_m": 2.0, "kinds": "cone"}.get)
    assert p.follower.distance_m == 2.0 and p.tracker.kind_set() == ("cone",)
