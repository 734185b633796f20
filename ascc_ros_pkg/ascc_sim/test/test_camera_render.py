"""The simulated Q24 camera on known answers: where a cone, a shirt and a poster appear
in the panorama (through the shared camera model), occlusion, the poster's texture after
un-warping, the motion blur's length, and determinism for a seed."""
import math

import cv2
import numpy as np
import pytest

from ascc_common.camera_model import PanoramicCamera
from ascc_sim.camera_effects import CameraEffects, CameraEffectsParams, motion_blur
from ascc_sim.camera_render import Body, CameraRenderer, poster_texture
from ascc_sim.world import load_world
from ascc_sim.worldgen import Canvas

ROBOT = (5.0, 5.0, 0.4)  # x, y, yaw in the 10 m x 10 m test room


def make_world(tmp_path, objects=""):
    canvas = Canvas(10.0, 10.0, 0.05)
    canvas.room(0.2, 0.2, 9.8, 9.8)
    canvas.block(6.8, 2.0, 7.0, 4.0)  # a short wall to hide things behind
    canvas.save(str(tmp_path), "room")
    text = ("name: room\nmap: room.yaml\nrobots:\n  - {name: r, pose: [%g, %g, %g]}\n"
            "objects:\n%s" % (ROBOT + (objects or "  []\n",)))
    path = tmp_path / "room_world.yaml"
    path.write_text(text)
    return load_world(str(path))


def at(bearing_deg, range_m):
    """Map point at a bearing (base_link) and range from the test robot."""
    a = ROBOT[2] + math.radians(bearing_deg)
    return ROBOT[0] + range_m * math.cos(a), ROBOT[1] + range_m * math.sin(a)


def orange_mask(img):
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    return cv2.inRange(hsv, (5, 200, 150), (22, 255, 255)) > 0


def centroid_bearings(cam, mask):
    """Bearing (base_link) of the mask's centroid in each strip that holds any of it."""
    out = []
    sh = cam.strip_height_px
    for s in range(cam.strips):
        v, u = np.nonzero(mask[s * sh:(s + 1) * sh])
        if len(u) == 0:
            continue
        b, _ = cam.pixel_to_ray(u.mean() + 0.5, v.mean() + 0.5 + s * sh)
        out.append(float(cam.base_bearing(b)))
    return out


def angle_diff_deg(a, b):
    return abs(math.degrees(math.remainder(a - b, 2.0 * math.pi)))


@pytest.mark.parametrize("bearing_deg, range_m", [(0.0, 1.5), (35.0, 2.0), (-70.0, 1.2),
                                                   (150.0, 1.8), (-120.0, 2.5)])
def test_cone_appears_at_its_bearing(tmp_path, bearing_deg, range_m):
    x, y = at(bearing_deg, range_m)
    world = make_world(tmp_path, "  - {name: c, type: cone, pose: [%.4f, %.4f]}\n" % (x, y))
    cam = PanoramicCamera()
    img = CameraRenderer(world, cam).render(*ROBOT)
    mask = orange_mask(img)
    rear = abs(bearing_deg) > 90.0
    sh = cam.strip_height_px
    assert mask[sh:].any() == rear and mask[:sh].any() != rear  # the right strip only
    (found,) = centroid_bearings(cam, mask)
    assert angle_diff_deg(found, math.radians(bearing_deg)) < 2.0
    # The silhouette is a triangle: wide at the bottom, narrow at the top.
    v, u = np.nonzero(mask)
    rows = np.unique(v)
    widths = [np.count_nonzero(v == r) for r in rows]
    assert widths[-1] > 3 * max(1, widths[0])


def test_cone_at_the_strip_seam_shows_in_both_strips(tmp_path):
    x, y = at(90.0, 1.5)  # the top strip's left edge, the bottom strip's right edge
    world = make_world(tmp_path, "  - {name: c, type: cone, pose: [%.4f, %.4f]}\n" % (x, y))
    cam = PanoramicCamera()
    mask = orange_mask(CameraRenderer(world, cam).render(*ROBOT))
    sh = cam.strip_height_px
    assert mask[:sh, :20].any() and mask[sh:, -20:].any()
    assert not mask[:, 40:-40].any()


def test_shirt_appears_at_the_person_bearing_and_not_through_walls(tmp_path):
    world = make_world(tmp_path)
    cam = PanoramicCamera()
    r = CameraRenderer(world, cam)
    x, y = at(-50.0, 2.0)
    img = r.render(*ROBOT, people=[Body(x, y, 0.2, 1.75, (1.0, 0.45, 0.0))])
    mask = orange_mask(img)
    (found,) = centroid_bearings(cam, mask)
    assert angle_diff_deg(found, math.radians(-50.0)) < 2.0
    # trousers (dark) below the shirt, in the shirt's columns
    v, u = np.nonzero(mask)
    below = img[v.max() + 5:v.max() + 40, int(u.mean())]
    assert below.mean() < 80
    # behind the short wall at x 6.8-7.0: not drawn
    hidden = r.render(*ROBOT, people=[Body(8.0, 3.0, 0.2, 1.75, (1.0, 0.45, 0.0))])
    assert not orange_mask(hidden).any()
    # and a grey shirt is no orange
    grey = r.render(*ROBOT, people=[Body(x, y, 0.2, 1.75, (0.5, 0.5, 0.5))])
    assert not orange_mask(grey).any()


def test_the_wall_shows_above_low_furniture(tmp_path):
    x, y = at(0.0, 2.0)
    world = make_world(tmp_path, "  - {name: d, type: furniture, kind: desk, pose: [%.4f, "
                                 "%.4f, 0.4], size_m: [0.6, 1.0], height_m: 0.4, "
                                 "color: blue}\n" % (x, y))
    cam = PanoramicCamera()
    img = CameraRenderer(world, cam).render(*ROBOT)
    u = cam.width_px // 2  # bearing 0, top strip
    col = img[:cam.strip_height_px, u].astype(int)
    blue = (col[:, 0] > col[:, 2] + 60)
    rows = np.nonzero(blue)[0]
    assert len(rows) > 10
    # below the camera, the desk shows its front face and its top up to the far edge
    _, v_top, _ = cam.ray_to_pixel(0.0, math.atan2(0.4 - cam.mount_z_m, 2.3))
    _, v_bot, _ = cam.ray_to_pixel(0.0, math.atan2(-cam.mount_z_m, 1.7))
    assert abs(rows.min() - v_top) < 3 and abs(rows.max() - v_bot) < 3
    above = col[rows.min() - 20]
    assert above.min() > 150  # light wall above the desk


def _unwarp(img, cam, poster_a, poster_b, z_lo, z_hi, shape):
    """Sample the image where each texel of a poster from a to b (left to right as seen)
    projects: the texture as the camera model says the image holds it."""
    th, tw = shape
    s = (np.arange(tw) + 0.5) / tw
    z = z_hi - (np.arange(th) + 0.5) / th * (z_hi - z_lo)
    px = poster_a[0] + s * (poster_b[0] - poster_a[0])
    py = poster_a[1] + s * (poster_b[1] - poster_a[1])
    dx, dy = px - ROBOT[0], py - ROBOT[1]
    bearing = np.arctan2(dy, dx) - ROBOT[2]
    elev = np.arctan2(z[:, None] - cam.mount_z_m, np.hypot(dx, dy)[None, :])
    u, v, inside = cam.ray_to_pixel(np.broadcast_to(bearing, elev.shape), elev)
    assert inside.all()
    return cv2.remap(img, (u - 0.5).astype(np.float32), (v - 0.5).astype(np.float32),
                     cv2.INTER_LINEAR)


def test_poster_texture_appears_unmirrored(tmp_path):
    # An asymmetric test texture: a dark L in the upper left, a gradient, stripes.
    tex = np.full((240, 180, 3), 230, np.uint8)
    tex[20:140, 20:50] = 30
    tex[110:140, 20:110] = 30
    tex[170:220, :] = np.linspace(0, 255, 180)[None, :, None].astype(np.uint8)
    tex[:, 140:150] = (200, 40, 40)
    # poster on the east wall (x = 9.8 - 0.075), facing west, 1.5 m ahead-left
    world = make_world(tmp_path, "  - {name: p, type: poster, logo: test, "
                                 "pose: [9.73, 5.6, 3.1416], width_m: 0.6, height_m: 0.8, "
                                 "center_height_m: 0.8}\n")
    cam = PanoramicCamera()
    img = CameraRenderer(world, cam, {"test": tex}).render(*ROBOT)
    # Seen from the west, facing east: the viewer's left is north (+y).
    a, b = (9.73, 5.9), (9.73, 5.3)
    want = cv2.cvtColor(cv2.resize(poster_texture(tex, 0.6, 0.8), (30, 40),
                                   interpolation=cv2.INTER_AREA), cv2.COLOR_BGR2GRAY)
    got = cv2.cvtColor(_unwarp(img, cam, a, b, 0.4, 1.2, (40, 30)), cv2.COLOR_BGR2GRAY)
    corr = np.corrcoef(want.ravel(), got.ravel())[0, 1]
    mirrored = np.corrcoef(want[:, ::-1].ravel(), got.ravel())[0, 1]
    assert corr > 0.9 and mirrored < corr - 0.3, (corr, mirrored)


def test_poster_without_texture_gets_a_pattern_and_back_side_is_not_drawn(tmp_path):
    world = make_world(tmp_path, "  - {name: p, type: poster, logo: nothing, "
                                 "pose: [9.73, 5.6, 3.1416]}\n")
    cam = PanoramicCamera()
    r = CameraRenderer(world, cam)
    img = r.render(*ROBOT)
    got = _unwarp(img, cam, (9.73, 5.9), (9.73, 5.3), 0.5, 1.3, (40, 30))
    assert cv2.cvtColor(got, cv2.COLOR_BGR2GRAY).std() > 20  # a pattern, not a blank wall
    # a poster facing away from the robot (into the wall) is not seen
    away = make_world(tmp_path, "  - {name: p, type: poster, logo: nothing, "
                                "pose: [9.73, 5.6, 0.0]}\n")
    img2 = CameraRenderer(away, cam).render(*ROBOT)
    got2 = _unwarp(img2, cam, (9.73, 5.9), (9.73, 5.3), 0.5, 1.3, (40, 30))
    assert cv2.cvtColor(got2, cv2.COLOR_BGR2GRAY).std() < 10


def edge_width_px(row):
    """10-90 % width of the one rising edge in a row of grey levels."""
    lo, hi = float(row.min()), float(row.max())
    f = (row.astype(float) - lo) / (hi - lo)
    return np.count_nonzero((f > 0.1) & (f < 0.9))


@pytest.mark.parametrize("exposure_s", [0.1, 0.05])
def test_motion_blur_length_follows_yaw_rate_and_exposure(exposure_s):
    cam = PanoramicCamera()
    img = np.zeros((8, 200, 3), np.uint8)
    img[:, 100:] = 200
    widths = []
    for rate in (0.0, 0.26, 0.52, 0.87):
        length = cam.blur_length_px(rate, exposure_s)
        w = edge_width_px(motion_blur(img, length)[4, :, 1])
        widths.append(w)
        assert abs(w - 0.8 * length) <= 1.5  # the 10-90 % part of a box of that length
    assert widths == sorted(widths) and widths[-1] > widths[0] + 10


def test_effects_are_deterministic_for_a_seed(tmp_path):
    world = make_world(tmp_path, "  - {name: c, type: cone, pose: [6.0, 5.5]}\n")
    cam = PanoramicCamera()
    img = CameraRenderer(world, cam).render(*ROBOT)
    params = CameraEffectsParams()
    a = CameraEffects(params, img.shape, seed=3).apply(img, 12.0, 9.0, frame=7)
    b = CameraEffects(params, img.shape, seed=3).apply(img, 12.0, 9.0, frame=7)
    c = CameraEffects(params, img.shape, seed=4).apply(img, 12.0, 9.0, frame=7)
    d = CameraEffects(params, img.shape, seed=3).apply(img, 12.0, 9.0, frame=8)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c) and not np.array_equal(a, d)
    noise = a.astype(float) - CameraEffects(
        CameraEffectsParams(noise_sigma=0.0), img.shape, seed=3).apply(img, 12.0, 9.0, 7)
    assert 1.0 < noise.std() < 3.0  # noise_sigma 2 (clipped at 0 and 255)
    # the gains drift slowly, within their amplitudes
    fx = CameraEffects(params, img.shape, seed=3)
    g = np.array([fx.gains(t) for t in np.arange(0.0, 60.0, 0.1)])
    assert g.min() > 1.0 - 0.12 - 0.06 - 0.02 and g.max() < 1.0 + 0.12 + 0.06 + 0.03
    assert np.abs(np.diff(g, axis=0)).max() < 0.01  # per 0.1 s
    assert g.max() - g.min() > 0.05


def test_rendering_is_deterministic(tmp_path):
    world = make_world(tmp_path, "  - {name: c, type: cone, pose: [6.0, 5.5]}\n")
    r = CameraRenderer(world, PanoramicCamera())
    people = [Body(4.0, 6.0, 0.2, 1.75, (1.0, 0.45, 0.0))]
    assert np.array_equal(r.render(*ROBOT, people=people), r.render(*ROBOT, people=people))
    assert r.render(*ROBOT).shape == (768, 1024, 3)
