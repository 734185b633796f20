"""The Table 2.1 benchmark's pure parts (ascc_eval.detection_bench): the scenes (built
from ascc_sim's worlds, the target where the renderer draws it) and a frame's scoring."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from ascc_common.camera_model import PanoramicCamera
from ascc_eval import detection_bench as B
from ascc_sim.camera_render import CameraRenderer

CAM = PanoramicCamera()


def targets(world):
    return [o for o in world.objects
            if o.type == "cone" or (o.type == "poster" and o.kind == B.LOGO_NAME)]


def test_office_scenes_one_metre_and_the_poster_in_view():
    scenes = B.office_scenes(CAM)
    for kind, sc in scenes.items():
        assert sc.kind == kind
        assert sc.distance_m == pytest.approx(1.0)
    lo, hi = B.poster_center_range(CAM, 1.0)
    logo = scenes["logo"]
    assert lo <= logo.center_height_m <= hi
    # the poster's top edge is below the highest point seen at its distance
    top = logo.center_height_m + B.POSTER_HEIGHT_M / 2.0
    assert top < CAM.mount_z_m + math.tan(CAM.vfov_rad / 2.0) * logo.distance_m
    with pytest.raises(ValueError):
        B.office_scenes(CAM, distance_m=0.6)  # a 0.8 m poster cannot fit at 0.6 m


def test_build_world_swaps_the_targets():
    sc = B.office_scenes(CAM)["cone"]
    with_target = B.build_world(sc)
    without = B.build_world(sc, with_target=False)
    (cone,) = targets(with_target)
    assert (cone.pose.x, cone.pose.y) == pytest.approx(sc.target_xy)
    assert targets(without) == []
    assert len(with_target.objects) == len(without.objects) + 1
    assert with_target.robots[0].pose[:2] == pytest.approx(sc.robot_xy)
    logo = B.office_scenes(CAM)["logo"]
    (poster,) = targets(B.build_world(logo))
    assert poster.center_height_m == pytest.approx(logo.center_height_m)


def test_true_bearing_follows_the_robot_yaw():
    sc = B.office_scenes(CAM)["cone"]  # the cone due east of the robot
    assert B.true_bearing(CAM, sc, 0.0) == pytest.approx(0.0)
    assert B.true_bearing(CAM, sc, math.pi / 2.0) == pytest.approx(-math.pi / 2.0)
    assert B.true_bearing(CAM, sc, -2.0) == pytest.approx(2.0)


@pytest.mark.parametrize("yaw", [0.3, -1.0, 2.5])
def test_the_renderer_draws_the_cone_at_the_true_bearing(yaw):
    sc = B.office_scenes(CAM)["cone"]
    img = CameraRenderer(B.build_world(sc), CAM).render(sc.robot_xy[0], sc.robot_xy[1], yaw)
    b = B.true_bearing(CAM, sc, yaw)
    hsv_orange = (img[..., 2].astype(int) > 180) & (img[..., 0].astype(int) < 80)
    u, v, inside = CAM.ray_to_pixel(b, -0.3)  # below the horizon: the cone's body
    assert inside
    column = hsv_orange[:, int(u)]
    assert column.any(), "no orange in the column of the true bearing"
    rows, cols = np.nonzero(hsv_orange)
    bearings, _ = CAM.pixel_to_ray(cols + 0.5, rows + 0.5)
    centre = math.atan2(np.mean(np.sin(bearings)), np.mean(np.cos(bearings)))
    assert abs(math.remainder(centre - b, 2 * math.pi)) < math.radians(1.0)


def test_in_view_excludes_the_strip_cuts():
    half = math.radians(7.0)
    assert B.in_view(CAM, 0.0, half, 0.0)
    assert B.in_view(CAM, math.pi, half, 0.0)  # the rear strip's centre
    assert not B.in_view(CAM, math.pi / 2.0, half, 0.0)
    assert not B.in_view(CAM, -math.pi / 2.0 + math.radians(7.5), half, 0.0)
    assert B.in_view(CAM, -math.pi / 2.0 + math.radians(9.0), half, 0.0)
    # blur widens the target: half of it counts on each side
    assert not B.in_view(CAM, -math.pi / 2.0 + math.radians(9.0), half, math.radians(4.0))


def det_at(bearing):
    u, v, _ = CAM.ray_to_pixel(bearing, 0.0)
    return SimpleNamespace(u=float(u), v=float(v))


def test_score_frame():
    tol = math.radians(3.0)
    b = math.radians(40.0)
    s = B.score_frame(CAM, [det_at(b + math.radians(10)), det_at(b + math.radians(1))], b, tol)
    assert s.detected and s.stray == 1
    assert s.error_rad == pytest.approx(math.radians(1.0), abs=1e-6)
    s = B.score_frame(CAM, [det_at(b + math.radians(4))], b, tol)
    assert not s.detected and s.stray == 1
    s = B.score_frame(CAM, [], b, tol)
    assert not s.detected and s.stray == 0
    s = B.score_frame(CAM, [det_at(b), det_at(-b)], None, tol)  # no target: all false
    assert not s.detected and s.stray == 2
    # across the +-180 deg wrap (rear strip)
    s = B.score_frame(CAM, [det_at(math.radians(179.0))], math.radians(-179.0), tol)
    assert s.detected


def test_random_scenes_are_free_and_fit():
    scenes = B.random_scenes(CAM, ["lab", "apartment"], ["cone", "logo"], 2, seed=3)
    assert len(scenes) == 8
    for sc in scenes:
        assert 0.8 - 0.02 <= sc.distance_m <= 2.0
        world = B.build_world(sc)  # validated: the robot overlaps nothing
        assert len(targets(world)) == 1
        if sc.kind == "logo":
            lo, hi = B.poster_center_range(CAM, sc.distance_m)
            assert lo <= sc.center_height_m <= hi
            # the poster faces the robot
            facing = math.atan2(sc.robot_xy[1] - sc.target_xy[1],
                                sc.robot_xy[0] - sc.target_xy[0])
            assert abs(math.remainder(facing - sc.target_yaw, 2 * math.pi)) < 1e-6
    again = B.random_scenes(CAM, ["lab", "apartment"], ["cone", "logo"], 2, seed=3)
    assert again == scenes


def test_random_posters_hang_on_walls_and_are_drawn():
    """A poster is never placed on a furniture face (seed 12346 once put one on the lab's
    glass cabinet, where the renderer hides it: a target not in view), and the renderer
    draws every poster of the scenes."""
    scenes = B.random_scenes(CAM, ["lab"], ["cone", "logo"], 2, seed=12346)
    for sc in (s for s in scenes if s.kind == "logo"):
        with_poster = CameraRenderer(B.build_world(sc), CAM, {}).render(*sc.robot_xy, sc.yaw0)
        without = CameraRenderer(B.build_world(sc, with_target=False), CAM, {}).render(
            *sc.robot_xy, sc.yaw0)
        assert np.any(with_poster != without, axis=2).sum() > 500, sc.name
