"""Synthetic double-panorama scenes with known targets, for tests and benchmarks (no rospy).

Not the simulator's renderer: a quick painter that draws a cluttered background (walls,
furniture boxes, stripes, noise; never orange by construction unless asked) into the
camera's image and places a cone, an orange shirt (a person) or the logo poster at a known
bearing and range through ``ascc_common.camera_model.PanoramicCamera.ray_to_pixel``, so a
detector's bearing can be checked against the truth. Then the photometric effects the
detector must survive: gain, white balance, sensor noise, horizontal motion blur of
``blur_px`` pixels, JPEG compression. Every scene is drawn from a seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import cv2
import numpy as np

from ascc_common.camera_model import PanoramicCamera

CONE_BGR = (0, 100, 255)  # traffic-cone orange
SHIRT_BGR = (20, 110, 240)  # a slightly different orange, cotton
CONE_HEIGHT_M = 0.45
CONE_BASE_M = 0.28  # base width [m]
SHIRT_BOTTOM_M = 0.85  # shirt from hip to shoulder, above the floor [m]
SHIRT_TOP_M = 1.45
SHIRT_WIDTH_M = 0.42
LOGO_HEIGHT_M = 0.40  # the poster's printed logo, 3:4 like the template
LOGO_CENTRE_M = 0.55  # height of the poster's centre above the floor [m]


@dataclass
class Placed:
    """A target placed in a scene: the truth a detector is judged against."""

    kind: str
    bearing_rad: float  # camera bearing of the target's centre
    range_m: float  # horizontal range from the camera
    bbox: Tuple[int, int, int, int]  # drawn extent (x, y, w, h) [px]


@dataclass
class Scene:
    image: np.ndarray  # BGR uint8
    targets: List[Placed] = field(default_factory=list)


def _strip_origin(cam: PanoramicCamera, bearing: float) -> Tuple[float, int]:
    """Column of ``bearing`` and the row offset of its strip."""
    u, v, _ = cam.ray_to_pixel(bearing, cam.pitch_rad)
    return float(u), int(float(v) // cam.strip_height_px) * cam.strip_height_px


def _v(cam: PanoramicCamera, elevation: float, row0: int) -> float:
    return row0 + cam.strip_height_px / 2.0 - (elevation - cam.pitch_rad) * cam.px_per_rad


def background(cam: PanoramicCamera, rng: np.random.Generator,
               clutter: int = 25) -> np.ndarray:
    """A cluttered panorama: per-strip wall gradient and floor, boxes of random non-orange
    colours, stripes, dots, texture noise."""
    h, w = cam.height_px, cam.width_px
    img = np.empty((h, w, 3), np.uint8)
    sh = cam.strip_height_px
    for s in range(cam.strips):
        wall = np.array(_non_orange(rng, 90))
        floor = np.array(_non_orange(rng, 40)) * 0.7
        horizon = s * sh + sh // 2 + int(rng.integers(-10, 40))
        grad = np.linspace(0.8, 1.1, horizon - s * sh)[:, None, None]
        img[s * sh:horizon] = np.clip(wall[None, None, :] * grad, 0, 255)
        img[horizon:(s + 1) * sh] = floor
    for _ in range(clutter):
        colour = _non_orange(rng)
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        bw, bh = int(rng.integers(10, 160)), int(rng.integers(10, 200))
        kind = rng.integers(0, 4)
        if kind == 0:
            cv2.rectangle(img, (x, y), (x + bw, y + bh), colour, -1)
        elif kind == 1:
            cv2.circle(img, (x, y), bw // 3 + 3, colour, -1)
        elif kind == 2:
            for i in range(0, bh, 8):
                cv2.line(img, (x, y + i), (x + bw, y + i), colour, 2)
        else:
            pts = rng.integers(0, 60, (5, 2)) + np.array([x, y])
            cv2.fillPoly(img, [pts.astype(np.int32)], colour)
    noise = rng.normal(0, 6, img.shape)
    return np.clip(img + noise, 0, 255).astype(np.uint8)


def _non_orange(rng: np.random.Generator, val_min: int = 30) -> Tuple[int, int, int]:
    """A BGR colour clearly not orange: hue outside -20..70 deg, or unsaturated."""
    while True:
        hsv = np.array([[[rng.integers(0, 180), rng.integers(0, 256),
                          rng.integers(val_min, 256)]]], np.uint8)
        hue, sat = int(hsv[0, 0, 0]), int(hsv[0, 0, 1])
        if not (hue <= 35 or hue >= 170) or sat < 40:
            b, g, r = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
            return int(b), int(g), int(r)


def draw_cone(img: np.ndarray, cam: PanoramicCamera, bearing: float, range_m: float,
              colour=CONE_BGR) -> Placed:
    """An upright cone (a trapezoid with a dark base plate) standing on the floor."""
    uc, row0 = _strip_origin(cam, bearing)
    z = cam.mount_z_m
    top = _v(cam, math.atan2(CONE_HEIGHT_M - z, range_m), row0)
    bottom = _v(cam, math.atan2(-z, range_m), row0)
    half_base = math.atan2(CONE_BASE_M / 2, range_m) * cam.px_per_rad
    half_tip = max(1.0, 0.12 * half_base)
    pts = np.array([[uc - half_tip, top], [uc + half_tip, top], [uc + half_base, bottom],
                    [uc - half_base, bottom]])
    cv2.fillPoly(img, [np.round(pts * 16).astype(np.int32)], colour, cv2.LINE_AA, 4)
    plate = max(2, int(0.05 * (bottom - top)))
    cv2.rectangle(img, (int(uc - 1.3 * half_base), int(bottom)),
                  (int(uc + 1.3 * half_base), int(bottom) + plate), (30, 30, 30), -1)
    x0, y0 = int(uc - half_base), int(top)
    return Placed("cone", bearing, range_m, (x0, y0, int(2 * half_base), int(bottom - top)))


def draw_person(img: np.ndarray, cam: PanoramicCamera, bearing: float, range_m: float,
                colour=SHIRT_BGR, rng: Optional[np.random.Generator] = None) -> Placed:
    """A person: trousers, an orange shirt (torso and short sleeves), skin arms, head."""
    uc, row0 = _strip_origin(cam, bearing)
    z = cam.mount_z_m

    def v(height_m):
        return _v(cam, math.atan2(height_m - z, range_m), row0)

    def du(width_m):
        return math.atan2(width_m / 2, range_m) * cam.px_per_rad

    trousers = (60, 50, 40)
    skin = (120, 160, 200)
    cv2.rectangle(img, (int(uc - du(0.36)), int(v(SHIRT_BOTTOM_M))),
                  (int(uc + du(0.36)), int(v(0.0))), trousers, -1)
    cv2.ellipse(img, (int(uc), int(v(1.62))), (int(du(0.18)), int(v(1.52) - v(1.62))),
                0, 0, 360, skin, -1)
    x0, x1 = int(uc - du(SHIRT_WIDTH_M)), int(uc + du(SHIRT_WIDTH_M))
    y0, y1 = int(v(SHIRT_TOP_M)), int(v(SHIRT_BOTTOM_M))
    cv2.rectangle(img, (x0, y0), (x1, y1), colour, -1)
    sleeve = int(du(0.18))
    cv2.rectangle(img, (x0 - sleeve, y0), (x0, int(v(1.2))), colour, -1)
    cv2.rectangle(img, (x1, y0), (x1 + sleeve, int(v(1.2))), colour, -1)
    cv2.rectangle(img, (x0 - sleeve, int(v(1.2))), (x0, int(v(0.85))), skin, -1)
    return Placed("shirt", bearing, range_m, (x0 - sleeve, y0, x1 - x0 + 2 * sleeve, y1 - y0))


def draw_logo(img: np.ndarray, cam: PanoramicCamera, bearing: float, range_m: float,
              template: np.ndarray, height_m: float = LOGO_HEIGHT_M,
              centre_m: float = LOGO_CENTRE_M, shear: float = 0.0) -> Placed:
    """The logo poster (the template, resized to its angular size, optionally sheared a
    little as if seen at an angle) on a white margin at a known bearing and range."""
    uc, row0 = _strip_origin(cam, bearing)
    z = cam.mount_z_m
    top = _v(cam, math.atan2(centre_m + height_m / 2 - z, range_m), row0)
    bottom = _v(cam, math.atan2(centre_m - height_m / 2 - z, range_m), row0)
    th, tw = template.shape[:2]
    h = bottom - top
    w = h * tw / th
    src = np.float32([[0, 0], [tw, 0], [tw, th], [0, th]])
    dst = np.float32([[uc - w / 2, top + shear * h], [uc + w / 2, top - shear * h],
                      [uc + w / 2, bottom + shear * h], [uc - w / 2, bottom - shear * h]])
    margin = 0.06 * h
    white = dst + np.float32([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * margin
    cv2.fillConvexPoly(img, np.round(white).astype(np.int32), (245, 245, 245))
    H = cv2.getPerspectiveTransform(src, dst)
    warped = cv2.warpPerspective(template, H, (img.shape[1], img.shape[0]),
                                 flags=cv2.INTER_AREA)
    mask = cv2.warpPerspective(np.full((th, tw), 255, np.uint8), H,
                               (img.shape[1], img.shape[0]), flags=cv2.INTER_NEAREST)
    img[mask > 0] = warped[mask > 0]
    x, y, bw, bh = cv2.boundingRect(dst)
    return Placed("logo", bearing, range_m, (x, y, bw, bh))


def photometric(img: np.ndarray, rng: np.random.Generator, gain: float = 1.0,
                wb_bgr: Tuple[float, float, float] = (1.0, 1.0, 1.0), noise_sd: float = 3.0,
                blur_px: float = 0.0, jpeg_quality: int = 0) -> np.ndarray:
    """Gain and white balance (per-channel gains), horizontal motion blur over ``blur_px``
    pixels (a box along the rows, as a rotation during the exposure draws it), sensor
    noise, and a JPEG round trip when ``jpeg_quality`` > 0."""
    out = img.astype(np.float32) * (gain * np.asarray(wb_bgr, np.float32))
    n = int(round(blur_px))
    if n >= 2:
        out = cv2.blur(out, (n, 1), borderType=cv2.BORDER_REFLECT)
    if noise_sd > 0:
        out += rng.normal(0.0, noise_sd, out.shape).astype(np.float32)
    out = np.clip(out, 0, 255).astype(np.uint8)
    if jpeg_quality > 0:
        ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
        out = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return out


def distractors(img: np.ndarray, rng: np.random.Generator, count: int = 4) -> None:
    """Orange-ish things a colour detector must not take for a target: thin orange pipes
    (wrong aspect), specks (too small), a hollow orange frame (low fill), brown wood and
    skin/beige (orange hue, too dark or unsaturated), a red box (wrong hue)."""
    h, w = img.shape[:2]
    for _ in range(count):
        x, y = int(rng.integers(20, w - 200)), int(rng.integers(20, h - 200))
        kind = int(rng.integers(0, 6))
        if kind == 0:  # a long thin pipe
            if rng.random() < 0.5:
                cv2.rectangle(img, (x, y), (x + int(rng.integers(150, 300)), y + 5), CONE_BGR, -1)
            else:
                cv2.rectangle(img, (x, y), (x + 5, y + int(rng.integers(150, 250))), CONE_BGR, -1)
        elif kind == 1:  # specks
            for _ in range(12):
                cx, cy = x + int(rng.integers(0, 150)), y + int(rng.integers(0, 150))
                cv2.circle(img, (cx, cy), 3, CONE_BGR, -1)
        elif kind == 2:  # a hollow frame
            s = int(rng.integers(80, 160))
            cv2.rectangle(img, (x, y), (x + s, y + s), SHIRT_BGR, 4)
        elif kind == 3:  # brown wood
            cv2.rectangle(img, (x, y), (x + 120, y + 90), (15, 35, 60), -1)
        elif kind == 4:  # beige / skin
            cv2.rectangle(img, (x, y), (x + 100, y + 120), (150, 190, 225), -1)
        else:  # a red box
            cv2.rectangle(img, (x, y), (x + 90, y + 90), (30, 20, 200), -1)


def random_scene(kind: Optional[str], seed: int, cam: Optional[PanoramicCamera] = None,
                 template: Optional[np.ndarray] = None, blur_px: float = 0.0,
                 with_distractors: bool = True, range_m: Optional[Tuple[float, float]] = None,
                 jpeg_quality: int = 0, photometric_range: float = 1.0) -> Scene:
    """One scene of seed ``seed``: ``kind`` (cone, shirt, logo; None: no target) at a
    random bearing and range in ``range_m``, random gain (0.7..1.3 scaled by
    ``photometric_range``) and white balance (+-20 %), distractors, blur, noise."""
    cam = cam or PanoramicCamera()
    rng = np.random.default_rng(seed)
    img = background(cam, rng)
    if with_distractors:
        distractors(img, rng)
    targets = []
    if kind is not None:
        lo, hi = range_m or {"cone": (0.8, 3.0), "shirt": (1.0, 3.5),
                             "logo": (0.8, 1.8)}[kind]
        r = float(rng.uniform(lo, hi))
        rear = rng.random() < 0.4
        b = float(rng.uniform(-1.3, 1.3))
        bearing = float(math.atan2(math.sin(b + math.pi), math.cos(b + math.pi))) if rear else b
        if kind == "cone":
            targets.append(draw_cone(img, cam, bearing, r))
        elif kind == "shirt":
            targets.append(draw_person(img, cam, bearing, r, rng=rng))
        elif kind == "logo":
            if template is None:
                raise ValueError("a logo scene needs the template image")
            targets.append(draw_logo(img, cam, bearing, r, template,
                                     shear=float(rng.uniform(-0.06, 0.06))))
        else:
            raise ValueError("unknown kind %r" % kind)
    g = 1.0 + photometric_range * float(rng.uniform(-0.3, 0.3))
    wb = tuple(1.0 + photometric_range * float(x) for x in rng.uniform(-0.2, 0.2, 3))
    out = photometric(img, rng, gain=g, wb_bgr=wb, blur_px=blur_px, jpeg_quality=jpeg_quality)
    return Scene(out, targets)
