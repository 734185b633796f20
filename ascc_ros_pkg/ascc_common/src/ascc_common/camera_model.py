"""The Q24 panoramic camera model: pixel <-> ray in the robot frame (no rospy).

One module for the simulator's renderer and the target detector, so that a bearing the
detector reports is the bearing the renderer drew, and the detector never assumes the
simulator: on a robot the same model describes the real Q24's panorama view.

The view is an unwrapped 360-degree panorama (the Mobotix Q24 hemispheric camera, thesis
2.2) with equal angles per pixel (equirectangular), square pixels: the horizontal scale
``px_per_rad = strip_width / strip_span`` is the vertical one too. Two layouts:

* ``double_panorama`` (default; the Q24's 4:3 "double panorama" view): two strips stacked,
  each ``width`` x ``height / 2`` pixels covering 180 degrees of bearing. The top strip is
  the front half (bearing +90 deg at its left edge, 0 at its centre column, -90 deg at its
  right edge); the bottom strip continues the same clockwise sweep over the rear half
  (-90 deg at its left edge, 180 deg at its centre, +90 deg at its right edge). At
  1024 x 768 that is 326 px/rad (5.7 px/deg) and a vertical field of 67.5 deg per strip.
* ``panorama``: one strip of ``width`` x ``height`` covering ``hfov_rad`` (360 deg
  default) centred on the camera's forward direction.

Bearings are in the camera frame ``camera`` (x forward, y left, z up, like ``base_link``:
this is not an optical frame), counter-clockwise positive, wrapped to [-pi, pi). Elevation
is positive up; the centre row of each strip looks at elevation ``pitch_rad`` (the
panorama's tilt). Pixel (u, v) is the continuous coordinate whose pixel centres are at
integer + 0.5, u along a row (left to right), v down the image. The camera sits at
``mount_xyz_m`` in ``base_link``, rotated by ``mount_yaw_rad`` about z.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import numpy as np

from .params import param
from .pose2d import wrap_angle

LAYOUTS = ("double_panorama", "panorama")


@dataclass
class PanoramicCamera:
    """Geometry of one panoramic view; every field is a ``~camera/...`` style parameter."""

    width_px: int = param(1024, "[px] image width", gt=0)
    height_px: int = param(768, "[px] image height", gt=0)
    layout: str = param("double_panorama", "double_panorama (two 180 deg strips, front on "
                                           "top) or panorama (one strip)", choices=LAYOUTS)
    hfov_rad: float = param(2.0 * math.pi, "[rad] bearing span of the single panorama "
                                           "strip (layout panorama only)", gt=0.0,
                            le=2.0 * math.pi)
    pitch_rad: float = param(0.0, "[rad] elevation of each strip's centre row (tilt)")
    mount_x_m: float = param(0.0, "[m] camera position in base_link, x")
    mount_y_m: float = param(0.0, "[m] camera position in base_link, y")
    mount_z_m: float = param(0.55, "[m] camera height above the floor (base_link z)", gt=0.0)
    mount_yaw_rad: float = param(0.0, "[rad] camera yaw in base_link")

    def validate(self) -> None:
        if self.layout == "double_panorama" and self.height_px % 2:
            raise ValueError("height_px must be even for the double_panorama layout "
                             "(got %d)" % self.height_px)

    # -- derived geometry -------------------------------------------------------------
    @property
    def strips(self) -> int:
        """Number of stacked strips (2 for double_panorama, 1 for panorama)."""
        return 2 if self.layout == "double_panorama" else 1

    @property
    def strip_height_px(self) -> int:
        return self.height_px // self.strips

    @property
    def strip_span_rad(self) -> float:
        """Bearing span of one strip [rad]."""
        return math.pi if self.layout == "double_panorama" else self.hfov_rad

    @property
    def px_per_rad(self) -> float:
        """Pixels per radian, horizontally and vertically (square pixels)."""
        return self.width_px / self.strip_span_rad

    @property
    def vfov_rad(self) -> float:
        """Vertical field of view of one strip [rad]."""
        return self.strip_height_px / self.px_per_rad

    def strip_left_bearing(self, strip: int) -> float:
        """Camera bearing at the left edge (u = 0) of strip 0 (top) or 1 [rad]."""
        return self.strip_span_rad / 2.0 - strip * self.strip_span_rad

    # -- pixel <-> ray ------------------------------------------------------------------
    def column_bearings(self, strip: int = 0) -> np.ndarray:
        """Camera bearing of every pixel column's centre in ``strip`` (width,) [rad],
        unwrapped (decreasing from the left edge)."""
        u = np.arange(self.width_px, dtype=np.float64) + 0.5
        return self.strip_left_bearing(strip) - u / self.px_per_rad

    def row_elevations(self) -> np.ndarray:
        """Elevation of every pixel row's centre within a strip (strip_height,) [rad]."""
        v = np.arange(self.strip_height_px, dtype=np.float64) + 0.5
        return self.pitch_rad + (self.strip_height_px / 2.0 - v) / self.px_per_rad

    def pixel_to_ray(self, u, v) -> Tuple[np.ndarray, np.ndarray]:
        """Camera bearing (wrapped) and elevation [rad] of pixel coordinates (u, v)."""
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        sh = self.strip_height_px
        strip = np.clip(np.floor(v / sh), 0, self.strips - 1)
        vs = v - strip * sh
        bearing = self.strip_span_rad / 2.0 - strip * self.strip_span_rad - u / self.px_per_rad
        elevation = self.pitch_rad + (sh / 2.0 - vs) / self.px_per_rad
        return wrap_angle(bearing), elevation

    def ray_to_pixel(self, bearing, elevation) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates (u, v) of camera rays and whether each lies in the image."""
        b = np.asarray(bearing, dtype=np.float64)
        e = np.asarray(elevation, dtype=np.float64)
        sh = self.strip_height_px
        if self.layout == "double_panorama":
            rear = np.abs(wrap_angle(b)) > math.pi / 2.0
            strip = rear.astype(np.float64)
            # offset clockwise from the strip's left edge, in [0, pi)
            off = np.where(rear, wrap_angle(-math.pi / 2.0 - b) % (2 * math.pi),
                           math.pi / 2.0 - wrap_angle(b))
        else:
            strip = np.zeros_like(b)
            off = self.hfov_rad / 2.0 - wrap_angle(b)
            if self.hfov_rad >= 2.0 * math.pi - 1e-9:
                off = off % (2.0 * math.pi)  # a full circle: bearing -pi is column 0
        u = off * self.px_per_rad
        v = strip * sh + sh / 2.0 - (e - self.pitch_rad) * self.px_per_rad
        vs = v - strip * sh
        inside = (u >= 0) & (u < self.width_px) & (vs >= 0) & (vs < sh)
        return u, v, inside

    # -- camera <-> base_link -----------------------------------------------------------
    def base_bearing(self, camera_bearing):
        """Bearing in base_link as seen from the camera's position [rad]."""
        return wrap_angle(np.asarray(camera_bearing, dtype=np.float64) + self.mount_yaw_rad)

    def point_in_base(self, camera_bearing, range_m) -> Tuple[np.ndarray, np.ndarray]:
        """base_link (x, y) [m] of a point at horizontal ``range_m`` from the camera along
        ``camera_bearing``."""
        b = self.base_bearing(camera_bearing)
        r = np.asarray(range_m, dtype=np.float64)
        return self.mount_x_m + r * np.cos(b), self.mount_y_m + r * np.sin(b)

    def range_from_floor_contact(self, elevation_rad) -> np.ndarray:
        """Horizontal range [m] of a floor point seen at ``elevation_rad`` (< 0); inf at or
        above the horizon."""
        e = np.asarray(elevation_rad, dtype=np.float64)
        with np.errstate(divide="ignore"):
            return np.where(e < 0, self.mount_z_m / np.tan(-np.minimum(e, -1e-12)), np.inf)

    @staticmethod
    def range_from_extent(top_rad, bottom_rad, height_m: float) -> np.ndarray:
        """Horizontal range [m] of an upright object of known vertical ``height_m`` whose
        top and bottom are seen at elevations ``top_rad`` > ``bottom_rad``."""
        span = np.tan(np.asarray(top_rad, dtype=np.float64)) - np.tan(
            np.asarray(bottom_rad, dtype=np.float64))
        with np.errstate(divide="ignore"):
            return np.where(span > 0, height_m / np.maximum(span, 1e-12), np.inf)

    def blur_length_px(self, yaw_rate_rad_s: float, exposure_s: float) -> float:
        """Length [px] of the horizontal motion blur a rotation at ``yaw_rate_rad_s`` draws
        during one exposure (every panorama row moves with the rotation)."""
        return abs(yaw_rate_rad_s) * exposure_s * self.px_per_rad
