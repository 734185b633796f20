"""The panoramic camera model: pixel <-> ray round trips, layouts, ranges, blur."""
import math

import numpy as np
import pytest

from ascc_common.camera_model import PanoramicCamera
from ascc_common.params import ParamError, from_params


def test_defaults_are_the_thesis_resolution_with_square_pixels():
    cam = PanoramicCamera()
    assert (cam.width_px, cam.height_px, cam.strips) == (1024, 768, 2)
    assert cam.px_per_rad == pytest.approx(1024 / math.pi)
    assert math.degrees(cam.vfov_rad) == pytest.approx(67.5)


def test_front_centre_column_looks_forward_and_left_is_positive():
    cam = PanoramicCamera()
    b, e = cam.pixel_to_ray(512.0, 192.0)
    assert b == pytest.approx(0.0) and e == pytest.approx(0.0)
    b_left, _ = cam.pixel_to_ray(0.0, 100.0)
    assert b_left == pytest.approx(math.pi / 2)
    b_up, e_up = cam.pixel_to_ray(512.0, 0.0)
    assert e_up == pytest.approx(cam.vfov_rad / 2)


def test_rear_strip_continues_the_clockwise_sweep():
    cam = PanoramicCamera()
    b, _ = cam.pixel_to_ray(np.array([0.0, 512.0, 1023.999]), np.array([400.0] * 3))
    assert b[0] == pytest.approx(-math.pi / 2)
    assert abs(b[1]) == pytest.approx(math.pi)
    assert b[2] == pytest.approx(math.pi / 2, abs=1e-4)


@pytest.mark.parametrize("layout,height", [("double_panorama", 768), ("panorama", 256)])
def test_pixel_ray_round_trip_over_the_whole_image(layout, height):
    cam = PanoramicCamera(layout=layout, height_px=height)
    rng = np.random.default_rng(1)
    u = rng.uniform(0, cam.width_px, 2000)
    v = rng.uniform(0, cam.height_px, 2000)
    b, e = cam.pixel_to_ray(u, v)
    u2, v2, inside = cam.ray_to_pixel(b, e)
    assert inside.all()
    assert np.allclose(u2, u, atol=1e-6) and np.allclose(v2, v, atol=1e-6)


def test_rays_outside_the_view_are_flagged():
    cam = PanoramicCamera()
    _, _, inside = cam.ray_to_pixel([0.0, 0.0, 1.0], [0.0, 1.0, -1.0])
    assert inside.tolist() == [True, False, False]
    narrow = PanoramicCamera(layout="panorama", hfov_rad=math.pi / 2, height_px=256)
    _, _, inside = narrow.ray_to_pixel([0.0, 1.0, -1.0], [0.0, 0.0, 0.0])
    assert inside.tolist() == [True, False, False]


def test_column_bearings_match_pixel_centres():
    cam = PanoramicCamera()
    cols = cam.column_bearings(1)
    b, _ = cam.pixel_to_ray(np.arange(1024) + 0.5, np.full(1024, 500.0))
    assert np.allclose(np.cos(cols), np.cos(b)) and np.allclose(np.sin(cols), np.sin(b))
    rows = cam.row_elevations()
    _, e = cam.pixel_to_ray(np.full(384, 10.0), np.arange(384) + 0.5)
    assert np.allclose(rows, e)


def test_ranges_from_floor_contact_and_extent():
    cam = PanoramicCamera(mount_z_m=0.5)
    assert cam.range_from_floor_contact(-math.atan2(0.5, 2.0)) == pytest.approx(2.0)
    assert np.isinf(cam.range_from_floor_contact(0.1))
    top, bottom = math.atan2(1.0, 3.0), math.atan2(-0.2, 3.0)
    assert cam.range_from_extent(top, bottom, 1.2) == pytest.approx(3.0)


def test_mount_offset_and_yaw_move_points_into_base_link():
    cam = PanoramicCamera(mount_x_m=0.1, mount_yaw_rad=math.pi / 2)
    x, y = cam.point_in_base(0.0, 2.0)
    assert (x, y) == (pytest.approx(0.1), pytest.approx(2.0))
    assert cam.base_bearing(math.pi) == pytest.approx(-math.pi / 2)


def test_blur_length_scales_with_rate_and_exposure():
    cam = PanoramicCamera()
    assert cam.blur_length_px(0.5, 0.04) == pytest.approx(0.02 * 1024 / math.pi)
    assert cam.blur_length_px(-0.5, 0.04) == cam.blur_length_px(0.5, 0.04)


def test_parameters_are_checked():
    with pytest.raises(ParamError, match="layout"):
        from_params(PanoramicCamera, {"layout": "fisheye"}.get)
    with pytest.raises(ParamError, match="height_px"):
        from_params(PanoramicCamera, {"height_px": 767}.get)
