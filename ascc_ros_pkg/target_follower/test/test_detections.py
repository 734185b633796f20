"""Geometry: blob -> bearing, range (laser or size) and position in base_link."""
import math

import numpy as np
import pytest

from ascc_common.camera_model import PanoramicCamera
from target_follower import synthetic as S
from target_follower.cli import make_detector
from target_follower.detections import (
    RANGE_LASER,
    RANGE_NONE,
    RANGE_SIZE,
    SHAPES,
    Scan,
    cut_off,
    locate,
    size_range,
)

CAM = PanoramicCamera()


def scan_with_circle(centre, radius, laser_pose=(0.1, 0.0, 0.0), wall_m=4.0):
    """A 360-degree scan from ``laser_pose`` (base_link) seeing a circle (base_link)."""
    a = -math.pi + 0.005 * np.arange(1257)
    lx, ly, lyaw = laser_pose
    d = np.stack([np.cos(a + lyaw), np.sin(a + lyaw)], axis=1)
    c = np.asarray(centre) - [lx, ly]
    along = d @ c
    perp2 = c @ c - along ** 2
    hit = (along > 0) & (perp2 < radius ** 2)
    r = np.full(a.size, wall_m)
    r[hit] = along[hit] - np.sqrt(radius ** 2 - perp2[hit])
    return Scan(r, float(a[0]), 0.005, 0.02, 5.6, laser_pose)


def cone_blob(bearing, range_m):
    img = np.full((CAM.height_px, CAM.width_px, 3), 110, np.uint8)
    S.draw_cone(img, CAM, bearing, range_m)
    (blob,) = make_detector("cone", strip_height_px=CAM.strip_height_px).detect(img)[:1]
    return blob


@pytest.mark.parametrize("bearing", [0.3, -1.0, 2.6, -2.9])
def test_cone_range_from_floor_contact(bearing):
    loc = locate(CAM, cone_blob(bearing, 2.0), SHAPES["cone"])
    assert loc.range_source == RANGE_SIZE
    assert abs(math.degrees(math.remainder(loc.bearing_rad - bearing, 2 * math.pi))) < 2.0
    assert abs(loc.range_m - 2.0) < 0.2
    assert math.hypot(loc.x_m - 2 * math.cos(bearing), loc.y_m - 2 * math.sin(bearing)) < 0.2


def test_laser_range_when_a_beam_hits_the_target():
    b, r = 0.5, 1.6
    centre = (r * math.cos(b), r * math.sin(b))
    scan = scan_with_circle(centre, 0.1, laser_pose=(0.1, 0.05, 0.3))
    loc = locate(CAM, cone_blob(b, r), SHAPES["cone"], scan)
    assert loc.range_source == RANGE_LASER
    assert abs(loc.range_m - (r - 0.1)) < 0.05


def test_laser_range_is_the_target_not_the_wall_behind_it():
    """A real Hokuyo sees a person's legs (two ~6 cm posts), here 0.3 m in front of a
    wall: within the ray's radius the wall has more hits than the legs; the range is the
    legs' (the nearest group of hits), not the median of both."""
    b, r = 0.6, 1.3
    u = np.array([math.cos(b), math.sin(b)])
    n = np.array([-u[1], u[0]])
    a = -math.pi + 0.005 * np.arange(1257)
    d = np.stack([np.cos(a), np.sin(a)], axis=1)
    ranges = np.full(a.size, 9.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        wall = (r + 0.3) / (d @ u)  # a wall across the ray, 0.3 m behind the legs
    ranges = np.where((wall > 0) & (wall < ranges), wall, ranges)
    for side in (-0.1, 0.1):  # two legs, radius 6 cm, 0.2 m apart
        c = r * u + side * n
        along = d @ c
        perp2 = c @ c - along ** 2
        hit = (along > 0) & (perp2 < 0.06 ** 2)
        ranges[hit] = np.minimum(ranges[hit], along[hit] - np.sqrt(0.06 ** 2 - perp2[hit]))
    scan = Scan(ranges, float(a[0]), 0.005, 0.02, 5.6, (0.0, 0.0, 0.0))
    img = np.full((CAM.height_px, CAM.width_px, 3), 110, np.uint8)
    S.draw_person(img, CAM, b, r + 0.06)
    (shirt,) = make_detector("shirt", strip_height_px=CAM.strip_height_px).detect(img)[:1]
    loc = locate(CAM, shirt, SHAPES["shirt"], scan)
    assert loc.range_source == RANGE_LASER
    assert abs(loc.range_m - (r - 0.06)) < 0.06, loc.range_m


def test_laser_ignored_when_it_hits_something_else():
    """A wall 4 m away behind the cone's bearing, nothing at the cone: size range."""
    scan = scan_with_circle((9.0, 9.0), 0.1)
    loc = locate(CAM, cone_blob(0.5, 1.6), SHAPES["cone"], scan)
    assert loc.range_source == RANGE_SIZE


def test_nan_and_inf_beams_ignored():
    b, r = -0.7, 1.3
    scan = scan_with_circle((r * math.cos(b), r * math.sin(b)), 0.1)
    scan.ranges[::3] = np.nan
    scan.ranges[1::3] = np.inf
    loc = locate(CAM, cone_blob(b, r), SHAPES["cone"], scan)
    assert loc.range_source == RANGE_LASER and math.isfinite(loc.range_m)


def test_shirt_range_from_extent():
    img = np.full((CAM.height_px, CAM.width_px, 3), 110, np.uint8)
    S.draw_person(img, CAM, 1.0, 2.5)
    blob = make_detector("shirt", strip_height_px=CAM.strip_height_px).detect(img)[0]
    loc = locate(CAM, blob, SHAPES["shirt"])
    assert loc.range_source == RANGE_SIZE and abs(loc.range_m - 2.5) < 0.3


def test_no_range_above_the_horizon():
    blob = cone_blob(0.2, 2.0)
    blob.bbox = (blob.bbox[0], 10, blob.bbox[2], 20)  # bottom edge above the horizon
    loc = locate(CAM, blob, SHAPES["cone"])
    assert loc.range_source == RANGE_NONE and math.isnan(loc.range_m)


def test_nan_beams_raise_no_runtime_warning():
    import warnings

    scan = scan_with_circle((1.0, 0.3), 0.1)
    scan.ranges[::3] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert scan.points_in_base().shape[1] == 2


@pytest.mark.parametrize("turn_rad", [0.25, -0.3])
def test_laser_range_of_a_turning_robot_uses_the_pictures_time(turn_rad):
    """The picture is taken with the target at bearing b; by the scan's stamp the robot has
    turned by turn_rad (and driven 0.05 m): in the scan the target lies at about
    b - turn_rad. Uncorrected, the camera's ray misses it (range from the size only);
    with the motion the range is the laser's, and the position the picture's."""
    from ascc_common.pose2d import compose, inverse, transform_points
    from target_follower.detections import motion_between
    b, r, radius = 0.4, 1.5, 0.12
    centre = np.array([[r * math.cos(b), r * math.sin(b)]])  # base_link, picture time
    picture, at_scan = (2.0, 1.0, 0.3), compose((2.0, 1.0, 0.3), (0.05, 0.0, turn_rad))
    motion = motion_between(picture, at_scan)
    seen = transform_points(inverse(motion), centre)[0]  # the target at the scan's time
    laser = (0.1, 0.0, 0.0)
    scan = scan_with_circle(seen, radius, laser_pose=laser)
    blob = cone_blob(b, r)
    plain = locate(CAM, blob, SHAPES["cone"], scan)
    assert plain.range_source != RANGE_LASER
    fixed = locate(CAM, blob, SHAPES["cone"], Scan(scan.ranges, scan.angle_min,
                                                   scan.angle_increment, scan.range_min,
                                                   scan.range_max, laser, motion))
    assert fixed.range_source == RANGE_LASER
    assert abs(fixed.range_m - (r - radius)) < 0.05
    assert math.hypot(fixed.x_m - (r - radius) * math.cos(b),
                      fixed.y_m - (r - radius) * math.sin(b)) < 0.06


def test_motion_between_is_identity_when_standing_still():
    from target_follower.detections import motion_between
    assert motion_between((1.0, 2.0, 3.0), (1.0, 2.0, 3.0)) == pytest.approx((0, 0, 0))


@pytest.mark.parametrize("range_m", [0.8, 1.0])
def test_a_shirt_cut_off_by_the_picture_takes_the_lasers_nearer_range(range_m):
    """Nearer than ~1.35 m the shirt's top leaves the picture: its extent is short and the
    size estimate too long (an upper bound). The laser's hits on the person, well below
    that estimate, give the range; the wall 2 m behind the ray does not."""
    b = 0.3
    img = np.full((CAM.height_px, CAM.width_px, 3), 110, np.uint8)
    S.draw_person(img, CAM, b, range_m)
    (shirt,) = make_detector("shirt", strip_height_px=CAM.strip_height_px).detect(img)[:1]
    assert cut_off(CAM, shirt)
    est = size_range(CAM, shirt, SHAPES["shirt"])
    assert est > range_m + 0.3  # the estimate alone is off by more than the follower's band
    centre = (range_m + 0.2) * np.array([math.cos(b), math.sin(b)])
    scan = scan_with_circle(centre, 0.2, laser_pose=(0.0, 0.0, 0.0), wall_m=range_m + 2.0)
    loc = locate(CAM, shirt, SHAPES["shirt"], scan)
    assert loc.range_source == RANGE_LASER
    assert abs(loc.range_m - range_m) < 0.06, (loc.range_m, est)


def test_a_whole_shirt_is_not_cut_off():
    img = np.full((CAM.height_px, CAM.width_px, 3), 110, np.uint8)
    S.draw_person(img, CAM, -0.4, 2.0)
    (shirt,) = make_detector("shirt", strip_height_px=CAM.strip_height_px).detect(img)[:1]
    assert not cut_off(CAM, shirt)


@pytest.mark.parametrize("y, cut", [(0, True), (1, False), (373, False), (374, True),
                                    (384, True), (385, False), (757, False), (758, True)])
def test_cut_off_is_touching_an_edge_row_of_the_blobs_strip(y, cut):
    """10-row boxes in the double panorama (two strips of 384 rows): cut off when the box's
    first or last row is its strip's first or last."""
    from target_follower.color_detector import Blob
    assert cut_off(CAM, Blob("shirt", 5.0, y + 5.0, (0, y, 10, 10), 100.0, 1.0)) == cut
