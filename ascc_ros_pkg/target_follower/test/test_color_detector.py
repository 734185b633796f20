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
