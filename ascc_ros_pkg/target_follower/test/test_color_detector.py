"""Colour detector (cone, shirt) on synthetic double panoramas with known bearings."""
import math

import numpy as np
import pytest
import yaml

from ascc_common.camera_model import PanoramicCamera
from ascc_common.params import from_params, parameters, tree_getter
from target_follower import synthetic as S
from target_follower.cli import config_path, make_detector
from target_follower.color_detector import ColorDetector, ColorParams

CAM = PanoramicCamera()


def bearing_error_deg(blob, truth):
    b, _ = CAM.pixel_to_ray(blob.u, blob.v)
    return abs(math.degrees(math.remainder(float(b) - truth, 2 * math.pi)))


def test_cone_yaml_is_the_dataclass_default():
    with open(config_path("cone")) as f:
        tree = yaml.safe_load(f)
    assert from_params(ColorParams, tree_getter(tree)) == ColorParams()
    assert set(tree) == {p.name for p in parameters(ColorParams)}


@pytest.mark.parametrize("kind", ["cone", "shirt"])
def test_bearing_within_2_deg(kind):
    det = make_detector(kind, strip_height_px=CAM.strip_height_px)
    for seed in range(20):
        scene = S.random_scene(kind, 300 + seed, CAM, jpeg_quality=85)
        blobs = det.detect(scene.image)
        assert blobs, "seed %d: no %s" % (300 + seed, kind)
        assert bearing_error_deg(blobs[0], scene.targets[0].bearing_rad) < 2.0, seed


@pytest.mark.parametrize("gain, wb", [(0.6, (1, 1, 1)), (1.4, (1, 1, 1)),
                                      (1.0, (1.25, 1.0, 0.75)), (1.0, (0.75, 1.0, 1.25)),
                                      (0.7, (1.2, 1.1, 0.8)), (1.3, (0.8, 0.9, 1.2))])
def test_cone_survives_gain_and_white_balance(gain, wb):
    rng = np.random.default_rng(5)
    img = S.background(CAM, rng)
    placed = S.draw_cone(img, CAM, -0.4, 2.0)
    img = S.photometric(img, rng, gain=gain, wb_bgr=wb)
    blobs = make_detector("cone", strip_height_px=CAM.strip_height_px).detect(img)
    assert blobs and bearing_error_deg(blobs[0], placed.bearing_rad) < 2.0


@pytest.mark.parametrize("kind", ["cone", "shirt"])
def test_implausible_orange_things_are_not_targets(kind):
    """Pipes, specks, a hollow frame, brown, beige, red: one kind per scene."""
    det = make_detector(kind, strip_height_px=CAM.strip_height_px)
    rng = np.random.default_rng(11)
    img = S.background(CAM, rng, clutter=0)
    cv = S.cv2
    cv.rectangle(img, (100, 100), (400, 105), S.CONE_BGR, -1)  # horizontal pipe
    cv.rectangle(img, (500, 60), (505, 300), S.CONE_BGR, -1)  # vertical pipe
    for i in range(12):  # specks
        cv.circle(img, (700 + 11 * i, 120 + 7 * (i % 3)), 3, S.CONE_BGR, -1)
    cv.rectangle(img, (100, 450), (240, 590), S.SHIRT_BGR, 4)  # hollow frame
    cv.rectangle(img, (350, 450), (470, 540), (15, 35, 60), -1)  # brown wood
    cv.rectangle(img, (550, 450), (650, 570), (150, 190, 225), -1)  # beige
    cv.rectangle(img, (750, 450), (840, 540), (30, 20, 200), -1)  # red box
    img = S.photometric(img, rng, gain=1.2)
    assert det.detect(img) == []


def test_target_free_scenes_give_nothing():
    det = make_detector("cone", strip_height_px=CAM.strip_height_px)
    found = sum(bool(det.detect(S.random_scene(None, 700 + s, CAM, with_distractors=False)
                                .image)) for s in range(20))
    assert found == 0


def test_blobs_do_not_cross_the_strip_boundary():
    """Orange touching both sides of the front/rear boundary: two blobs, one per strip."""
    img = np.full((CAM.height_px, CAM.width_px, 3), 120, np.uint8)
    S.cv2.rectangle(img, (300, 330), (340, 383), S.CONE_BGR, -1)
    S.cv2.rectangle(img, (300, 384), (340, 437), S.CONE_BGR, -1)
    params = ColorParams(min_aspect=0.5, max_fill=1.0)
    blobs = ColorDetector("cone", params, CAM.strip_height_px).detect(img)
    assert len(blobs) == 2
    assert sorted(b.v < CAM.strip_height_px for b in blobs) == [False, True]


def double_panorama_with(kind, bearing, range_m, seed):
    """A 1024 x 768 double panorama with one ``kind`` at ``bearing``, drawn on one 360 deg
    strip (so a target on a seam is whole) that is then cut into the two strips: its
    column c is the double panorama's unwrapped column c - 512 (+90 deg at column 0). Not
    near 180 deg, the ends of that strip."""
    cam360 = PanoramicCamera(width_px=2 * CAM.width_px, height_px=CAM.strip_height_px,
                             layout="panorama", mount_z_m=CAM.mount_z_m)
    rng = np.random.default_rng(seed)
    img = S.background(cam360, rng, clutter=10)
    draw = S.draw_cone if kind == "cone" else S.draw_person
    draw(img, cam360, bearing, range_m)
    img = S.photometric(img, rng, gain=1.1)
    unwrapped = np.roll(img, -CAM.width_px // 2, axis=1)
    return np.vstack([unwrapped[:, :CAM.width_px], unwrapped[:, CAM.width_px:]])


@pytest.mark.parametrize("kind", ["cone", "shirt"])
@pytest.mark.parametrize("bearing_deg", [-90.0, 90.0, -88.5, 91.0, 0.0, 150.0])
def test_a_target_on_a_strip_seam_is_one_blob(kind, bearing_deg):
    """At +-90 deg a target lies half at the end of one strip and half at the start of
    the other: one blob, at the right bearing (each half alone failed the shape limits
    or gave two bearings)."""
    det = make_detector(kind, strip_height_px=CAM.strip_height_px)
    for k, range_m in enumerate([1.2, 2.5]):
        img = double_panorama_with(kind, math.radians(bearing_deg), range_m, 40 + k)
        blobs = det.detect(img)
        assert len(blobs) == 1, (range_m, [b.to_json() for b in blobs])
        b = blobs[0]
        assert bearing_error_deg(b, math.radians(bearing_deg)) < 2.0, (range_m, b.to_json())
        x, y, w, h = b.bbox
        assert 0 <= x and x + w <= CAM.width_px and w > 0  # the part in its strip
        strip = int(b.v // CAM.strip_height_px)
        assert strip * CAM.strip_height_px <= y and y + h <= (strip + 1) * CAM.strip_height_px


def test_wrap_joins_the_ends_of_a_single_360_strip():
    cam360 = PanoramicCamera(width_px=2048, height_px=384, layout="panorama")
    img = np.full((384, 2048, 3), 120, np.uint8)
    S.draw_cone(img, cam360, 0.0, 1.5)
    img = np.roll(img, 1024, axis=1)  # the cone at 180 deg: half at each end
    params = from_params(ColorParams, tree_getter({}))
    halves = ColorDetector("cone", params, 0, wrap=False).detect(img)
    (blob,) = ColorDetector("cone", params, 0, wrap=True).detect(img)
    assert blob.area_px > 1.6 * max([h.area_px for h in halves] + [1.0])
    b, _ = cam360.pixel_to_ray(blob.u, blob.v)
    assert abs(math.degrees(math.remainder(float(b) - math.pi, 2 * math.pi))) < 2.0


def test_bad_images_and_kinds_raise():
    det = make_detector("cone")
    with pytest.raises(ValueError):
        det.detect(np.zeros((10, 10), np.uint8))
    with pytest.raises(ValueError):
        ColorDetector("logo", ColorParams())
    with pytest.raises(ValueError):
        ColorDetector("cone", ColorParams(min_area_px=10.0, max_area_px=5.0))


def test_heldout_sizes_and_backgrounds():
    """Seeds and ranges never used while tuning (far cones 3.0-3.6 m, near shirts)."""
    cone = make_detector("cone", strip_height_px=CAM.strip_height_px)
    shirt = make_detector("shirt", strip_height_px=CAM.strip_height_px)
    for seed in range(200000, 200010):
        sc = S.random_scene("cone", seed, CAM, range_m=(3.0, 3.6), jpeg_quality=75)
        blobs = cone.detect(sc.image)
        assert blobs and bearing_error_deg(blobs[0], sc.targets[0].bearing_rad) < 2.0, seed
        sc = S.random_scene("shirt", seed, CAM, range_m=(0.9, 1.2), jpeg_quality=75)
        blobs = shirt.detect(sc.image)
        assert blobs and bearing_error_deg(blobs[0], sc.targets[0].bearing_rad) < 2.0, seed
