"""Logo detector: ORB + RANSAC homography, plausibility checks, motion-blur compensation."""
import math

import numpy as np
import pytest

from ascc_common.camera_model import PanoramicCamera
from target_follower import synthetic as S
from target_follower.cli import DEFAULT_TEMPLATE
from target_follower.logo_detector import LogoDetector, LogoParams, load_template

CAM = PanoramicCamera()
TEMPLATE = load_template(DEFAULT_TEMPLATE)
BLUR_087 = CAM.blur_length_px(0.87, 0.1)  # 0.87 rad/s x 0.1 s exposure: ~28 px


@pytest.fixture(scope="module")
def det():
    return LogoDetector(TEMPLATE, LogoParams())


def hits(det, seeds, blur_px, compensate=True):
    n = 0
    for seed in seeds:
        sc = S.random_scene("logo", seed, CAM, template=TEMPLATE, blur_px=blur_px,
                            jpeg_quality=80)
        found = det.detect(sc.image, blur_px if compensate else 0.0)
        if found:
            b, _ = CAM.pixel_to_ray(found[0].u, found[0].v)
            n += abs(math.degrees(math.remainder(float(b) - sc.targets[0].bearing_rad,
                                                 2 * math.pi))) < 2.0
    return n


def test_logo_found_still(det):
    assert hits(det, range(400, 410), 0.0) >= 9


def test_logo_found_under_fast_rotation_blur(det):
    """0.87 rad/s: the thesis's SURF found 26 %; with the blurred templates most are found,
    and clearly more than without the compensation."""
    seeds = range(500, 512)
    with_comp = hits(det, seeds, BLUR_087)
    without = hits(det, seeds, BLUR_087, compensate=False)
    assert with_comp >= 9
    assert with_comp > without + 3


def test_no_logo_nothing(det):
    for seed in range(600, 615):
        blur = (0.0, 8.5, 17.0, BLUR_087)[seed % 4]
        sc = S.random_scene(None, seed, CAM, blur_px=blur, jpeg_quality=80)
        assert det.detect(sc.image, blur) == [], seed


def test_blob_fields(det):
    sc = S.random_scene("logo", 401, CAM, template=TEMPLATE)
    (blob,) = det.detect(sc.image)
    assert blob.kind == "logo" and 0 < blob.score < 1 and blob.quad.shape == (4, 2)
    x, y, w, h = blob.bbox
    tx, ty, tw, th = sc.targets[0].bbox
    assert abs(x - tx) < 8 and abs(y - ty) < 8 and abs(w - tw) < 10 and abs(h - th) < 10


@pytest.mark.parametrize("quad", [
    [[0, 0], [100, 0], [0, 130], [100, 130]],  # twisted (not convex)
    [[0, 0], [10, 0], [10, 13], [0, 13]],  # too small
    [[100, 0], [0, 0], [0, 130], [100, 130]],  # mirrored
    [[0, 0], [300, 0], [300, 130], [0, 130]],  # aspect far from the template's
    [[0, 0], [100, 40], [100, 90], [0, 130]],  # strong perspective
])
def test_implausible_fits_are_rejected(det, quad):
    assert not det.plausible(np.array(quad, float), np.eye(3))


def test_plausible_fit_accepted(det):
    assert det.plausible(np.array([[0, 0], [100, 0], [100, 133], [0, 133]], float), np.eye(3))


def test_bad_template(tmp_path):
    with pytest.raises(ValueError, match="missing.png"):
        load_template(str(tmp_path / "missing.png"))
    empty = tmp_path / "empty.png"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="empty.png"):
        load_template(str(empty))


def double_panorama_with_logo(bearing, range_m, seed):
    """A 1024 x 768 double panorama with the logo at ``bearing``, drawn on one 360 deg strip
    (whole across a seam) then cut into the two strips: that strip's column c is the
    double panorama's unwrapped column c - 512 (+90 deg at column 0)."""
    cam360 = PanoramicCamera(width_px=2 * CAM.width_px, height_px=CAM.strip_height_px,
                             layout="panorama", mount_z_m=CAM.mount_z_m)
    rng = np.random.default_rng(seed)
    img = S.background(cam360, rng, clutter=10)
    S.draw_logo(img, cam360, bearing, range_m, TEMPLATE)
    img = S.photometric(img, rng, gain=1.1)
    unwrapped = np.roll(img, -CAM.width_px // 2, axis=1)
    return np.vstack([unwrapped[:, :CAM.width_px], unwrapped[:, CAM.width_px:]])


@pytest.mark.parametrize("bearing_deg", [-90.0, 90.0, 0.0, 150.0])
def test_a_logo_on_a_strip_seam_is_found_whole(bearing_deg):
    """At +-90 deg the poster is half at the end of one strip, half at the start of the
    other: found at the right bearing once the strips are joined, and not without."""
    joined = LogoDetector(TEMPLATE, LogoParams(), CAM.strip_height_px)
    apart = LogoDetector(TEMPLATE, LogoParams())
    found_apart = 0
    for k, range_m in enumerate([1.2, 1.7]):  # the default template levels' range
        img = double_panorama_with_logo(math.radians(bearing_deg), range_m, 70 + k)
        (b,) = joined.detect(img)
        u, v = b.u, b.v
        bearing, _ = CAM.pixel_to_ray(u, v)
        err = math.degrees(math.remainder(float(bearing) - math.radians(bearing_deg),
                                          2 * math.pi))
        assert abs(err) < 2.0, (range_m, b.to_json())
        x, y, w, h = b.bbox
        assert 0 <= x and x + w <= CAM.width_px and w > 0
        strip = int(v // CAM.strip_height_px)
        assert strip * CAM.strip_height_px <= y and y + h <= (strip + 1) * CAM.strip_height_px
        found_apart += len(apart.detect(img))
    if abs(bearing_deg) == 90.0:
        assert found_apart == 0  # each half alone is not a plausible logo
