"""Target identity on scripted sequences: crossing targets, a bigger distractor, occlusion,
the robot's own motion (no master)."""
import math

import numpy as np
import pytest

from ascc_common.params import ParamError, from_params
from ascc_common.pose2d import relative
from target_follower.tracker import Observation, Tracker, TrackerParams

DT = 0.1  # [s] between camera frames


def seen(robot, world_xy, kind="cone", area=2000.0, confidence=0.8, with_range=True):
    """The Observation of a target at ``world_xy`` (odom) from the robot pose ``robot``."""
    x, y, _ = relative(robot, (world_xy[0], world_xy[1], 0.0))
    b = math.atan2(y, x)
    return Observation.at(kind, b, math.hypot(x, y) if with_range else math.nan, area,
                          confidence)


def tracker(**overrides):
    return Tracker(from_params(TrackerParams, overrides.get))


@pytest.mark.parametrize("robot_moves", [False, True])
def test_crossing_targets_keep_their_identity(robot_moves):
    """Two cones cross in front of the robot: it keeps the one it took first, though the
    other is bigger and more confident, also while the robot drives and turns."""
    trk = tracker(kinds="cone")
    followed_id = None
    for k in range(41):
        t = k * DT
        robot = (0.2 * t, 0.0, 0.3 * math.sin(t)) if robot_moves else (0.0, 0.0, 0.0)
        a = (3.0, 1.0 - 0.5 * t)   # the followed cone, moving right
        b = (3.2, -1.0 + 0.5 * t)  # a bigger one moving left; they cross at t = 2 s
        obs = [seen(robot, a, area=1500.0, confidence=0.7)]
        if k > 0:
            obs.append(seen(robot, b, area=4000.0, confidence=0.9))
        track = trk.update(t, robot, obs[::-1] if k % 2 else obs)
        followed_id = followed_id or track.id
        assert track.id == followed_id
        assert np.hypot(*(track.pos - a)) < 0.15, (t, track.pos, a)
    aim = trk.aim(t, robot)
    x, y, _ = relative(robot, (a[0], a[1], 0.0))
    assert aim.bearing_rad == pytest.approx(math.atan2(y, x), abs=0.05)
    assert trk.track.vel == pytest.approx([0.0, -0.5], abs=0.1)


def test_a_bigger_distractor_appearing_does_not_steal_the_track():
    trk = tracker(kinds="shirt,cone")
    robot = (0.0, 0.0, 0.0)
    for k in range(30):
        t = k * DT
        person = (1.5 + 0.3 * t, 0.2)
        obs = [seen(robot, person, kind="shirt", area=3000.0, confidence=0.6)]
        if k >= 10:  # a large shirt and a large cone appear elsewhere
            obs += [seen(robot, (2.0, -1.5), kind="shirt", area=20000.0, confidence=0.95),
                    seen(robot, (person[0] + 0.2, 0.2), kind="cone", area=20000.0,
                         confidence=0.95)]
        track = trk.update(t, robot, obs)
        assert track.id == 1 and track.kind == "shirt"
        assert np.hypot(*(track.pos - person)) < 0.1


def test_hidden_for_a_few_frames_then_found_again():
    trk = tracker(kinds="shirt", track_timeout_s=1.0)
    robot = (0.0, 0.0, 0.0)
    for k in range(30):
        t = k * DT
        person = (2.0, -1.0 + 0.4 * t)
        hidden = 10 <= k < 17  # 0.7 s behind something
        obs = [] if hidden else [seen(robot, person, kind="shirt")]
        if k >= 5:
            obs.append(seen(robot, (2.0, 1.5), kind="shirt", area=9000.0))  # another shirt
        track = trk.update(t, robot, obs)
        assert track is not None and track.id == 1, t
        aim = trk.aim(t, robot)
        # while hidden, the prediction keeps up with the walking person
        assert np.hypot(aim.range_m * math.cos(aim.bearing_rad) - person[0],
                        aim.range_m * math.sin(aim.bearing_rad) - person[1]) < 0.15, t


def test_lost_after_the_timeout_then_the_best_is_acquired():
    trk = tracker(kinds="shirt", track_timeout_s=1.0)
    robot = (0.0, 0.0, 0.0)
    trk.update(0.0, robot, [seen(robot, (2.0, 0.0), kind="shirt")])
    assert trk.aim(0.9, robot) is not None
    assert trk.aim(1.05, robot) is None and trk.track is None
    track = trk.update(1.2, robot, [
        seen(robot, (1.0, 1.0), kind="shirt", area=900.0, confidence=0.5),
        seen(robot, (3.0, 0.0), kind="shirt", area=400.0, confidence=0.9),
        seen(robot, (1.0, -1.0), kind="cone", area=9000.0, confidence=1.0),  # not followed
        seen(robot, (1.0, -1.0), kind="shirt", area=9000.0, confidence=0.2)])  # too unsure
    assert track.id == 2 and track.pos == pytest.approx([3.0, 0.0])
    assert tracker(kinds="shirt").update(0.0, robot, [seen(robot, (1, 1), "cone")]) is None


def test_the_robot_turning_does_not_move_a_standing_target():
    trk = tracker(kinds="cone")
    target = (2.0, 0.5)
    for k in range(20):
        robot = (0.05 * k, 0.0, 0.15 * k)  # turning 1.5 rad/s, creeping forward
        trk.update(k * DT, robot, [seen(robot, target)])
    assert trk.track.pos == pytest.approx(target, abs=1e-6)
    assert np.hypot(*trk.track.vel) < 1e-6
    robot = (1.0, 0.0, math.pi / 2)
    aim = trk.aim(2.0, robot)
    assert aim.bearing_rad == pytest.approx(math.atan2(-1.0, 0.5), abs=1e-6)
    assert aim.range_m == pytest.approx(math.hypot(1.0, 0.5), abs=1e-6)


def test_bearing_only_detections_are_tracked_by_direction():
    trk = tracker(kinds="logo", gate_bearing_rad=0.2)
    robot = (0.0, 0.0, 0.0)
    trk.update(0.0, robot, [seen(robot, (2.0, 0.5), kind="logo", with_range=False)])
    assert not trk.track.has_position
    robot = (0.0, 0.0, 0.5)  # the robot turned: the logo's odom direction stays
    track = trk.update(0.1, robot, [
        seen(robot, (2.0, 0.52), kind="logo", with_range=False),
        seen(robot, (1.0, -1.0), kind="logo", area=99999.0, with_range=False)])
    assert track.direction_rad == pytest.approx(math.atan2(0.52, 2.0))
    aim = trk.aim(0.1, robot)
    assert aim.bearing_rad == pytest.approx(math.atan2(0.52, 2.0) - 0.5)
    assert math.isnan(aim.range_m)
    # a later detection with a range gives the track a position
    track = trk.update(0.2, robot, [seen(robot, (2.0, 0.52), kind="logo")])
    assert track.pos == pytest.approx([2.0, 0.52])


def test_bad_detections_and_old_frames_are_ignored():
    trk = tracker(kinds="cone")
    robot = (0.0, 0.0, 0.0)
    assert trk.update(0.0, robot, [Observation("cone", math.nan, 1.0, 0.0)]) is None
    trk.update(1.0, robot, [seen(robot, (2.0, 0.0))])
    track = trk.update(0.5, robot, [seen(robot, (2.0, 1.0))])  # older frame: ignored
    assert track.pos == pytest.approx([2.0, 0.0]) and track.t_s == 1.0
    with pytest.raises(ParamError, match="kinds"):
        from_params(TrackerParams, {"kinds": "cone,ball"}.get)


def test_aim_gives_the_target_speed_along_the_line_of_sight():
    """A target walking straight away at 0.3 m/s, seen from a robot turned 90 deg: the aim's
    range rate is +0.3 m/s (away); walking across, its velocity's share along the line of
    sight (0.3 x / r)."""
    for heading in (0.0, math.pi / 2):
        trk = tracker(kinds="shirt")
        robot = (0.0, 0.0, math.pi / 2)  # facing +y
        for k in range(30):
            t = k * DT
            d = 0.3 * t
            xy = (d * math.sin(heading), 2.0 + d * math.cos(heading))
            trk.update(t, robot, [seen(robot, xy, kind="shirt")])
        aim = trk.aim(t, robot)
        expected = 0.3 * (xy[0] * math.sin(heading) + xy[1] * math.cos(heading)) / math.hypot(*xy)
        assert aim.range_rate_mps == pytest.approx(expected, abs=0.05)


def test_innovation_is_the_distance_of_the_measurement_from_the_prediction():
    trk = tracker(kinds="cone")
    robot = (0.0, 0.0, 0.0)
    track = trk.update(0.0, robot, [seen(robot, (2.0, 0.0))])
    assert math.isnan(track.innovation_m)  # a new track has no prediction
    for k in range(1, 20):  # walking at 0.3 m/s: the filter learns the velocity
        track = trk.update(k * DT, robot, [seen(robot, (2.0 + 0.03 * k, 0.0))])
    assert track.innovation_m < 0.03
    track = trk.update(2.0, robot, [seen(robot, (2.6 + 0.3, 0.0))])  # 0.3 m too far
    assert track.innovation_m == pytest.approx(0.3, abs=0.05)
    assert track.seen[0] == pytest.approx(2.9)
