"""The simulated Q24 camera: the panorama a robot sees of the 2D world (no rospy).

Column ray casting (thesis 2.2's camera, geometry from ``ascc_common.camera_model``): one
ray per pixel column and strip, all at once (numpy). The walls come from the building map
through the laser's exact grid ray caster (``ascc_sim.laser.RayCaster``); furniture
outlines, posters, cones and people are intersected analytically. Each thing a column's
ray hits spans the rows between the elevations of its bottom and top at its range; a depth
test per pixel paints them in the order far to near (the painter's order of each
column's hits):

* walls ``wall_height_m`` (2.5 m) tall, a light colour with a mild texture (panels,
  grain, a darker skirting board) and a shade by the angle of incidence; a floor and a
  ceiling (the wall height) shaded by distance;
* furniture as boxes of their ``height_m`` and colour (front faces shaded by incidence, a
  lighter top face where the camera looks down on it; the wall shows above low furniture;
  tables with ``solid: legs`` are boxes too);
* cones as orange cones: the silhouette of a cone of the world's radius and height (a
  triangle), shaded across;
* posters on their wall with their texture (``logo`` name -> image; a logo without a
  texture gets a plain generated pattern), ``width_m`` x ``height_m`` centred at
  ``center_height_m`` (default 0.9 m: a 0.8 m poster spans 0.5-1.3 m), seen from the
  front only, sampled from a pyramid level near their size on screen;
* people as upright cylinders: dark trousers, a shirt in the person's colour, a head.

The camera sits at ``mount_*`` on the robot's true pose; nothing is seen through walls.
"""
from __future__ import annotations

import math
import zlib
from dataclasses import dataclass
from typing import Dict, List, NamedTuple, Optional, Sequence, Tuple

import cv2
import numpy as np

from ascc_common.camera_model import PanoramicCamera
from ascc_common.params import nested, param

from .camera_effects import CameraEffectsParams
from .grid import GridMap
from .laser import RayCaster
from .world import World, WorldObject

WALL_BGR = np.array([196.0, 214.0, 226.0], dtype=np.float32)  # light beige
FLOOR_BGR = np.array([92.0, 104.0, 116.0], dtype=np.float32)  # grey-brown carpet
CEILING_BGR = np.array([222.0, 226.0, 228.0], dtype=np.float32)
TROUSERS_BGR = np.array([70.0, 45.0, 40.0], dtype=np.float32)  # dark blue jeans
SKIN_BGR = np.array([120.0, 155.0, 200.0], dtype=np.float32)
HAIR_BGR = np.array([30.0, 35.0, 45.0], dtype=np.float32)


@dataclass
class SimCameraParams:
    """The sim_camera node's parameters (private); ``~logo_textures`` (a dict) is read
    beside them."""

    world: Optional[str] = param(None, "path of the world YAML (required)")
    robot: str = param("/", "namespace of the world's robot that carries the camera "
                            "(/: the one without namespace)")
    rate_hz: float = param(10.0, "[Hz, sim time] frame rate", gt=0.0)
    publish_topics: bool = param(True, "publish the camera topics (false: only the "
                                       "HTTP stream)")
    http_port: int = param(-1, "MJPEG server port on 127.0.0.1; -1: off, 0: any free port",
                           ge=-1)
    http_path: str = param("/", "path of the MJPEG stream")
    jpeg_quality: int = param(85, "JPEG quality (0-100)", ge=0, le=100)
    seed: int = param(0, "seed of the sensor noise and drifts")
    truth_timeout_s: float = param(1.0, "[s] no frame while the robot's true pose is older",
                                   gt=0.0)
    wall_height_m: float = param(2.5, "[m] height of the walls and the ceiling", gt=0.0)
    max_range_m: float = param(30.0, "[m] walls farther (or none) are drawn at this range",
                               gt=0.0)
    camera: PanoramicCamera = nested(PanoramicCamera, "camera/")
    effects: CameraEffectsParams = nested(CameraEffectsParams, "effects/")


class Body(NamedTuple):
    """A person as the camera sees it (map frame)."""

    x: float  # [m]
    y: float  # [m]
    radius_m: float
    height_m: float
    color: Tuple[float, float, float]  # shirt, RGB 0..1


def bgr(rgb: Sequence[float]) -> np.ndarray:
    """A world colour (RGB 0..1) as float32 BGR 0..255."""
    return np.array([rgb[2], rgb[1], rgb[0]], dtype=np.float32) * 255.0


def load_textures(paths: Dict[str, str]) -> Dict[str, np.ndarray]:
    """BGR images of ``{logo name: image path}``; ValueError naming an unreadable file."""
    out = {}
    for name, path in paths.items():
        img = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if img is None or img.size == 0:
            raise ValueError("logo texture %r: cannot read image %s" % (name, path))
        out[name] = img
    return out


def poster_texture(logo: Optional[np.ndarray], width_m: float, height_m: float,
                   name: str = "", px_per_m: float = 800.0) -> np.ndarray:
    """The printed poster: a white sheet of the poster's aspect with ``logo`` fitted in
    its middle 90 % (aspect kept), or, without a logo, a plain pattern (a frame and grey
    lines of "text", fixed by ``name``). BGR uint8."""
    w = max(8, int(round(width_m * px_per_m)))
    h = max(8, int(round(height_m * px_per_m)))
    sheet = np.full((h, w, 3), 250, dtype=np.uint8)
    if logo is not None:
        scale = 0.9 * min(w / logo.shape[1], h / logo.shape[0])
        lw = max(1, int(round(logo.shape[1] * scale)))
        lh = max(1, int(round(logo.shape[0] * scale)))
        x0, y0 = (w - lw) // 2, (h - lh) // 2
        sheet[y0:y0 + lh, x0:x0 + lw] = cv2.resize(logo, (lw, lh),
                                                   interpolation=cv2.INTER_AREA)
        return sheet
    rng = np.random.default_rng(zlib.crc32(name.encode("utf-8")))
    m = max(2, w // 40)
    cv2.rectangle(sheet, (0, 0), (w - 1, h - 1), (90, 90, 90), m)
    line_h = max(2, h // 30)
    for y in range(4 * m, h - 4 * m, 3 * line_h):
        x1 = int(4 * m + rng.uniform(0.3, 1.0) * (w - 8 * m))
        grey = int(rng.integers(60, 160))
        cv2.rectangle(sheet, (4 * m, y), (x1, y + line_h), (grey, grey, grey), -1)
    return sheet


class _Poster(NamedTuple):
    a: np.ndarray  # (2,) left end as seen from the front [m]
    b: np.ndarray  # (2,) right end
    normal: np.ndarray  # (2,) out of the wall
    z_lo: float
    z_hi: float
    pyramid: List[np.ndarray]  # the texture and its halvings, float32 BGR


class _Box(NamedTuple):
    p: np.ndarray  # (M, 2) edge start points
    e: np.ndarray  # (M, 2) edge vectors
    normals: np.ndarray  # (M, 2) unit edge normals
    height_m: float
    color: np.ndarray  # BGR float32


class CameraRenderer:
    """Renders the panorama of ``camera`` (a PanoramicCamera) in ``world``.

    Args:
        world: the loaded world (``World.map`` gives the walls, ``World.objects`` the rest).
        camera: the camera geometry and its mount on ``base_link``.
        textures: ``{logo name: BGR uint8 image}`` for the posters (``load_textures``).
        wall_height_m: height of every wall and of the ceiling [m].
        max_range_m: walls beyond this range (or none) are drawn at it [m].
    """

    def __init__(self, world: World, camera: PanoramicCamera,
                 textures: Optional[Dict[str, np.ndarray]] = None,
                 wall_height_m: float = 2.5, max_range_m: float = 30.0):
        camera.validate()
        self.world = world
        self.camera = camera
        self.wall_height_m = float(wall_height_m)
        self.max_range_m = float(max_range_m)
        if not self.wall_height_m > camera.mount_z_m:
            raise ValueError("wall_height_m must be above the camera (%.2f m)"
                             % camera.mount_z_m)
        textures = textures or {}
        self._walls = RayCaster(GridMap(world.map.occupancy, world.map.info),
                                self.max_range_m)
        self._res = world.map.info.resolution
        # camera-frame bearing of every column, the strips side by side: (N,)
        self._bearings = np.concatenate([camera.column_bearings(s)
                                         for s in range(camera.strips)])
        self._tan = np.tan(camera.row_elevations()).astype(np.float32)  # (sh,) decreasing
        self._neg_tan = -self._tan  # increasing, for searchsorted
        sh = camera.strip_height_px
        # Per-row colours of the floor (darker far away, i.e. near the horizon) and the
        # ceiling, and the wall texture along z.
        t = self._tan.astype(np.float64)
        with np.errstate(divide="ignore"):
            floor_d = np.where(t < 0, camera.mount_z_m / np.maximum(-t, 1e-9), np.inf)
            ceil_d = np.where(t > 0, (self.wall_height_m - camera.mount_z_m)
                              / np.maximum(t, 1e-9), np.inf)
        self._floor_rows = (FLOOR_BGR[None, :] * (0.75 + 0.35 * np.exp(-floor_d / 3.0))
                            [:, None]).astype(np.float32)
        self._ceil_rows = (CEILING_BGR[None, :] * (0.8 + 0.2 * np.exp(-ceil_d / 4.0))
                           [:, None]).astype(np.float32)
        self._rows = np.arange(sh)
        self._boxes = [self._box(o) for o in world.objects
                       if o.type == "furniture" and len(o.footprint) >= 3]
        self._cones = [o for o in world.objects if o.type == "cone"]
        self._posters = [self._poster(o, textures.get(o.kind)) for o in world.objects
                         if o.type == "poster"]

    # -- static preparation --------------------------------------------------------------
    @staticmethod
    def _box(o: WorldObject) -> _Box:
        p = np.asarray(o.footprint, dtype=np.float64)
        e = np.roll(p, -1, axis=0) - p
        n = np.column_stack((e[:, 1], -e[:, 0]))
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        return _Box(p, e, n, o.height_m, bgr(o.color))

    @staticmethod
    def _poster(o: WorldObject, logo: Optional[np.ndarray]) -> _Poster:
        c, s = math.cos(o.pose.yaw), math.sin(o.pose.yaw)
        normal = np.array([c, s])
        along = np.array([-s, c])  # the poster's local +y
        centre = np.array([o.pose.x, o.pose.y])
        width = float(np.linalg.norm(o.footprint[0] - o.footprint[3]))
        # Facing the poster (looking along -normal), the viewer's left is local -y.
        a = centre - along * width / 2.0
        b = centre + along * width / 2.0
        zc = o.center_height_m
        tex = poster_texture(logo, width, o.height_m, o.name).astype(np.float32)
        pyramid = [tex]
        while min(pyramid[-1].shape[:2]) > 16:
            pyramid.append(cv2.pyrDown(pyramid[-1]))
        return _Poster(a, b, normal, zc - o.height_m / 2.0, zc + o.height_m / 2.0, pyramid)

    # -- rendering -----------------------------------------------------------------------
    def render(self, x: float, y: float, yaw: float,
               people: Sequence[Body] = ()) -> np.ndarray:
        """The BGR uint8 image (height_px, width_px, 3) seen from the robot at map pose
        (x, y, yaw) [m, rad] with ``people`` in the world."""
        cam = self.camera
        c, s = math.cos(yaw), math.sin(yaw)
        cx = x + c * cam.mount_x_m - s * cam.mount_y_m
        cy = y + s * cam.mount_x_m + c * cam.mount_y_m
        ang = self._bearings + yaw + cam.mount_yaw_rad
        dx, dy = np.cos(ang), np.sin(ang)
        origin = np.array([cx, cy])
        r_wall, cos_wall, _ = self._walls.cast(cx, cy, ang)
        r_wall = np.minimum(r_wall, self.max_range_m)
        img, zbuf = self._background(cx, cy, dx, dy, r_wall, cos_wall)
        for poster in self._posters:
            self._draw_poster(img, poster, origin, dx, dy, r_wall)
        for box in self._boxes:
            self._draw_box(img, zbuf, box, origin, dx, dy)
        for cone in self._cones:
            self._draw_cone(img, zbuf, cone, origin, dx, dy)
        for body in people:
            self._draw_person(img, zbuf, body, origin, dx, dy)
        out = np.clip(img, 0.0, 255.0).astype(np.uint8)
        # (sh, strips * W, 3) -> the strips stacked: (strips * sh, W, 3)
        w = cam.width_px
        return np.ascontiguousarray(np.concatenate(
            [out[:, k * w:(k + 1) * w] for k in range(cam.strips)], axis=0))

    def _background(self, cx: float, cy: float, dx: np.ndarray, dy: np.ndarray,
                    r_wall: np.ndarray, cos_wall: np.ndarray
                    ) -> Tuple[np.ndarray, np.ndarray]:
        """Floor, ceiling and walls: the image (sh, N, 3) float32 and the depth buffer."""
        cz = self.camera.mount_z_m
        t = self._tan[:, None]
        r = r_wall.astype(np.float32)[None, :]
        top = (self.wall_height_m - cz) / r
        bot = -cz / r
        # Wall texture along the wall (a coordinate that runs along both x and y walls):
        # panels 1.2 m wide, fine grain, lighter where the wall faces the camera.
        u = cx + r_wall * dx + cy + r_wall * dy
        grain = np.sin(u * 157.0) * np.sin(u * 61.0 + 1.3)
        col = (0.72 + 0.2 * cos_wall + 0.03 * np.sin(u * 2.0 * math.pi / 1.2)
               + 0.025 * grain) * np.exp(-r_wall / 40.0)
        z = cz + t * r  # height of the wall point in each pixel [m]
        skirting = np.where(z < 0.08, np.float32(0.7), np.float32(1.0))
        wall = (col.astype(np.float32)[None, :] * skirting)[:, :, None] * WALL_BGR
        floor_or_ceil = np.where(t[:, :, None] > 0, self._ceil_rows[:, None, :],
                                 self._floor_rows[:, None, :])
        on_wall = (t <= top) & (t >= bot)
        img = np.where(on_wall[:, :, None], wall, floor_or_ceil).astype(np.float32, copy=False)
        zbuf = np.broadcast_to(r, on_wall.shape).copy()
        return img, zbuf

    def _rows_between(self, t_lo: np.ndarray, t_hi: np.ndarray) -> Tuple[int, int]:
        """The row range [r0, r1) that can hold elevations tangents in [min t_lo,
        max t_hi]."""
        r0 = int(np.searchsorted(self._neg_tan, -float(np.max(t_hi)), side="left"))
        r1 = int(np.searchsorted(self._neg_tan, -float(np.min(t_lo)), side="right"))
        return r0, r1

    def _paint(self, img: np.ndarray, zbuf: Optional[np.ndarray], cols: np.ndarray,
               depth: np.ndarray, t_lo: np.ndarray, t_hi: np.ndarray, shade,
               ) -> None:
        """Paint the columns ``cols`` between the elevation tangents ``t_lo``..``t_hi``
        where ``depth`` is nearer than the depth buffer (None: always); ``shade(t, r0, r1)``
        gives the colours (rows, len(cols), 3) of rows r0..r1 (``t`` their tangents)."""
        r0, r1 = self._rows_between(t_lo, t_hi)
        if r1 <= r0:
            return
        t = self._tan[r0:r1, None]
        mask = (t >= t_lo[None, :]) & (t <= t_hi[None, :])
        d = depth.astype(np.float32)[None, :]
        if zbuf is not None:
            zsub = zbuf[r0:r1, cols]
            mask &= d < zsub
            zbuf[r0:r1, cols] = np.where(mask, d, zsub)
        if not mask.any():
            return
        sub = img[r0:r1, cols]
        img[r0:r1, cols] = np.where(mask[:, :, None], shade(t, r0, r1), sub)

    def _draw_box(self, img, zbuf, box: _Box, origin, dx, dy) -> None:
        # Ray (origin + t d) against every edge (p + s e): t = cross(p - o, e) / cross(d, e),
        # s = cross(p - o, d) / cross(d, e).
        po = box.p - origin
        den = dx[:, None] * box.e[None, :, 1] - dy[:, None] * box.e[None, :, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            tt = (po[None, :, 0] * box.e[None, :, 1] - po[None, :, 1] * box.e[None, :, 0]) / den
            ss = (po[None, :, 0] * dy[:, None] - po[None, :, 1] * dx[:, None]) / den
        ok = (np.abs(den) > 1e-12) & (ss >= 0.0) & (ss <= 1.0) & (tt > 1e-6)
        if not ok.any():
            return
        t_in = np.where(ok, tt, np.inf)
        cols = np.nonzero(np.isfinite(t_in.min(axis=1)))[0]
        k = t_in[cols].argmin(axis=1)
        near = t_in[cols, k]
        far = np.where(ok[cols], tt[cols], -np.inf).max(axis=1)
        cos_inc = np.abs(dx[cols] * box.normals[k, 0] + dy[cols] * box.normals[k, 1])
        cz = self.camera.mount_z_m
        h = box.height_m
        t_front = (h - cz) / near
        t_top = np.where(far > near, (h - cz) / far, t_front)
        t_hi = np.maximum(t_front, t_top)
        front = (box.color[None, :] * (0.55 + 0.4 * cos_inc)[:, None]).astype(np.float32)
        top = np.float32(1.08) * box.color

        def shade(t, r0, r1):
            on_top = t > t_front[None, :]
            return np.where(on_top[:, :, None], top, front[None, :, :])

        self._paint(img, zbuf, cols, near, -cz / near, t_hi, shade)

    def _circle_hits(self, ox: float, oy: float, radius: float, origin, dx, dy
                     ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Columns whose rays pass within ``radius`` of (ox, oy) in front of the camera:
        (cols, along-ray distance of the closest approach, lateral offset / radius)."""
        ex, ey = ox - origin[0], oy - origin[1]
        proj = dx * ex + dy * ey
        perp = np.abs(dx * ey - dy * ex)
        hit = (perp < radius) & (proj > radius)
        cols = np.nonzero(hit)[0]
        return cols, proj[cols], perp[cols] / radius

    def _draw_cone(self, img, zbuf, cone: WorldObject, origin, dx, dy) -> None:
        cols, proj, q = self._circle_hits(cone.pose.x, cone.pose.y, cone.radius_m, origin,
                                          dx, dy)
        if len(cols) == 0:
            return
        cz = self.camera.mount_z_m
        near = proj - cone.radius_m * np.sqrt(1.0 - q * q)
        z_top = cone.height_m * (1.0 - q)  # the silhouette: a triangle
        color = bgr(cone.color)
        cols_bgr = (color[None, :] * (1.0 - 0.35 * q * q)[:, None]).astype(np.float32)

        def shade(t, r0, r1):
            return np.broadcast_to(cols_bgr[None, :, :], (r1 - r0,) + cols_bgr.shape)

        self._paint(img, zbuf, cols, near, -cz / near, (z_top - cz) / proj, shade)

    def _draw_person(self, img, zbuf, body: Body, origin, dx, dy) -> None:
        cols, proj, q = self._circle_hits(body.x, body.y, body.radius_m, origin, dx, dy)
        if len(cols) == 0:
            return
        cz = self.camera.mount_z_m
        h = body.height_m
        near = proj - body.radius_m * np.sqrt(1.0 - q * q)
        light = (1.0 - 0.4 * q * q).astype(np.float32)[None, :, None]
        shirt = bgr(body.color)
        z_waist, z_neck = 0.47 * h, 0.82 * h

        def shade_body(t, r0, r1):
            z = cz + t * near[None, :].astype(np.float32)
            return np.where((z < z_waist)[:, :, None], TROUSERS_BGR, shirt) * light

        self._paint(img, zbuf, cols, near, -cz / near, (z_neck - cz) / near, shade_body)
        head = q < 0.45
        if not head.any():
            return
        hq = q[head] / 0.45
        hr = 0.45 * body.radius_m
        hnear = proj[head] - hr * np.sqrt(1.0 - hq * hq)
        hlight = (1.0 - 0.4 * hq * hq).astype(np.float32)[None, :, None]

        def shade_head(t, r0, r1):
            z = cz + t * hnear[None, :].astype(np.float32)
            return np.where((z > 0.95 * h)[:, :, None], HAIR_BGR, SKIN_BGR) * hlight

        self._paint(img, zbuf, cols[head], hnear, (z_neck - cz) / hnear, (h - cz) / hnear,
                    shade_head)

    def _draw_poster(self, img, poster: _Poster, origin, dx, dy, r_wall) -> None:
        e = poster.b - poster.a
        po = poster.a - origin
        den = dx * e[1] - dy * e[0]
        facing = dx * poster.normal[0] + dy * poster.normal[1] < 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            tt = (po[0] * e[1] - po[1] * e[0]) / den
            ss = (po[0] * dy - po[1] * dx) / den
        # On the wall that holds it: the wall point the ray meets lies no more than two
        # cells in front of the poster's plane (the grid quantises the wall's face).
        wx = origin[0] + r_wall * dx - poster.a[0]
        wy = origin[1] + r_wall * dy - poster.a[1]
        in_front = wx * poster.normal[0] + wy * poster.normal[1]
        ok = (facing & (np.abs(den) > 1e-12) & (ss >= 0.0) & (ss < 1.0) & (tt > 0.05)
              & (in_front <= 2.0 * self._res + 0.01))
        cols = np.nonzero(ok)[0]
        if len(cols) == 0:
            return
        dist = tt[cols]
        cz = self.camera.mount_z_m
        # The texture level nearest to (not below) the poster's width on screen.
        width_px = len(cols)
        level = 0
        while (level + 1 < len(poster.pyramid)
               and poster.pyramid[level + 1].shape[1] >= width_px):
            level += 1
        tex = poster.pyramid[level]
        th, tw = tex.shape[:2]
        u = (ss[cols] * tw).astype(np.float32)
        height = poster.z_hi - poster.z_lo

        def shade(t, r0, r1):
            z = cz + t * dist[None, :].astype(np.float32)
            v = (poster.z_hi - z) / height * th
            map_x = np.broadcast_to(u[None, :] - 0.5, v.shape).astype(np.float32)
            out = cv2.remap(tex, map_x, (v - 0.5).astype(np.float32), cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_REPLICATE)
            return out

        self._paint(img, None, cols, dist, (poster.z_lo - cz) / dist,
                    (poster.z_hi - cz) / dist, shade)
