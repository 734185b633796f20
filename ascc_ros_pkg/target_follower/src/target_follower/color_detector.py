"""Low-level target detection by colour (thesis 2.4, 5.3): the orange cone and shirt.

The thesis's pipeline, vectorised with OpenCV: (optionally) shrink the frame by
``processing_scale`` (INTER_AREA, which also averages the sensor noise), Gaussian blur,
BGR -> HSV, threshold each channel (hue band, minimum saturation and value), dilate then
erode (a closing that fills small holes and joins the blob), connected components
(``cv2.connectedComponentsWithStats``). In a double panorama the components are found on
the two strips laid side by side, one 360-degree strip (front +90 .. -90 deg, then rear
-90 .. 180 .. +90 deg), so a blob never spans the rows between the front and the rear
strip, and a target at a bearing of -90 deg (the front strip's right edge continues as the
rear strip's left edge) is one blob, not two halves; components touching both ends of the
360-degree strip (+90 deg) are merged too (``wrap``, also for a single 360-degree
panorama). A merged blob's centroid lies in one strip: its ``bbox`` is the part in that
strip (the whole blob decides area, aspect and fill). A component is a plausible target when its
area, the aspect of its bounding box (height / width) and its fill ratio (area / box area)
lie within limits; the plausible ones are returned best first by their score,
``1 - exp(-area / score_area_px)``, i.e. the largest first (the thesis's "largest blob").

Brightness and white balance: a gain changes V, not H or S, so the value threshold is low;
a white-balance error shifts the hue of orange by a few degrees, so the hue band is wide
enough for +-25 % channel gains while staying clear of red (0 deg) and of yellow (50 deg,
the logo's). Brown and beige share orange's hue: what sets them apart is saturation.
Orange paint or cloth is saturated (the simulator's orange renders at S >= 230 of 255
after noise, drift and JPEG), the furniture's brown at S 140-180 (measured on rendered
office frames), so ``sat_min`` = 200 lies in the gap; skin is lower still. A minimum of
150 let brown desks pass as cones and shirts, and the follower then followed a desk.

Every size limit is in pixels of the full-resolution image; ``Blob`` coordinates are too.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List

import cv2
import numpy as np

from ascc_common.params import param

KINDS = ("cone", "shirt", "logo")
COLOR_KINDS = ("cone", "shirt")


@dataclass
class ColorParams:
    """Thresholds and limits of one colour target (defaults: the cone, config/cone.yaml;
    the shirt's are in config/shirt.yaml)."""

    hue_min_deg: float = param(8.0, "[deg] lower end of the hue band (0..360)", ge=0.0,
                               le=360.0)
    hue_max_deg: float = param(42.0, "[deg] upper end of the hue band (0..360; below "
                                     "hue_min_deg: the band wraps through 0)", ge=0.0,
                               le=360.0)
    sat_min: int = param(200, "[0..255] minimum HSV saturation (orange ~240+; brown ~160)",
                         ge=0, le=255)
    val_min: int = param(110, "[0..255] minimum HSV value (brightness)", ge=0, le=255)
    processing_scale: float = param(0.25, "[1] the frame is shrunk by this factor before "
                                          "segmentation", gt=0.0, le=1.0)
    blur_sigma_px: float = param(0.6, "[px, processed image] Gaussian blur sigma (0: none)",
                                 ge=0.0)
    morph_kernel_px: int = param(3, "[px, processed image] dilate/erode kernel size (0: no "
                                    "morphology)", ge=0)
    min_area_px: float = param(300.0, "[px] smallest plausible blob area (full resolution)",
                               ge=0.0)
    max_area_px: float = param(60000.0, "[px] largest plausible blob area (full "
                                        "resolution)", gt=0.0)
    min_aspect: float = param(0.7, "[1] smallest bounding-box height / width", gt=0.0)
    max_aspect: float = param(3.5, "[1] largest bounding-box height / width", gt=0.0)
    min_fill: float = param(0.35, "[1] smallest blob area / bounding-box area", ge=0.0,
                            le=1.0)
    max_fill: float = param(0.85, "[1] largest blob area / bounding-box area", ge=0.0,
                            le=1.0)
    score_area_px: float = param(3000.0, "[px] blob area of score 0.63 (score = 1 - "
                                         "exp(-area / score_area_px))", gt=0.0)
    max_detections: int = param(5, "[1] most blobs reported per frame", gt=0)

    def validate(self) -> None:
        if self.min_area_px >= self.max_area_px:
            raise ValueError("min_area_px (%g) must be below max_area_px (%g)"
                             % (self.min_area_px, self.max_area_px))
        if self.min_aspect > self.max_aspect or self.min_fill > self.max_fill:
            raise ValueError("min_aspect/min_fill must not exceed max_aspect/max_fill")


@dataclass
class Blob:
    """One detection in image pixels (full resolution): centroid (u, v) (pixel centres at
    +0.5), bounding box (x, y, w, h), area, score 0..1; ``quad`` (4 x 2 corners) for a logo."""

    kind: str
    u: float
    v: float
    bbox: tuple
    area_px: float
    score: float
    quad: object = None

    def to_json(self) -> dict:
        return {"kind": self.kind, "u": round(self.u, 2), "v": round(self.v, 2),
                "bbox": [int(b) for b in self.bbox], "area_px": int(round(self.area_px)),
                "score": round(self.score, 4)}


class ColorDetector:
    """Detects the blobs of one colour kind in BGR frames (thread-compatible: no state
    besides the parameters and the prebuilt kernel)."""

    def __init__(self, kind: str, params: ColorParams, strip_height_px: int = 0,
                 wrap: bool = False):
        """``strip_height_px``: height of one panorama strip of the full-resolution frame
        (384 for a 1024 x 768 double panorama, whose two strips cover 360 deg and join at
        both ends; 0: one strip, the whole frame); ``wrap``: a single strip covers 360
        deg, so its left and right edges join."""
        if kind not in COLOR_KINDS:
            raise ValueError("colour detector kind must be one of %s, not %r"
                             % (COLOR_KINDS, kind))
        params.validate()
        self.kind = kind
        self.p = params
        self.strip_height_px = strip_height_px
        self.wrap = wrap
        k = params.morph_kernel_px
        self.kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)) if k > 0 else None
        lo = int(round(params.hue_min_deg / 2.0)) % 180  # OpenCV hue: 0..179 = 0..358 deg
        hi = int(round(params.hue_max_deg / 2.0)) % 180
        self.hue_ranges = [(lo, hi)] if lo <= hi else [(lo, 179), (0, hi)]

    def mask(self, bgr: np.ndarray) -> np.ndarray:
        """The cleaned binary mask (0/255) at processing scale."""
        p = self.p
        img = bgr
        if p.processing_scale < 1.0:
            img = cv2.resize(bgr, None, fx=p.processing_scale, fy=p.processing_scale,
                             interpolation=cv2.INTER_AREA)
        if p.blur_sigma_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), p.blur_sigma_px)
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        m = None
        for lo, hi in self.hue_ranges:
            part = cv2.inRange(hsv, (lo, p.sat_min, p.val_min), (hi, 255, 255))
            m = part if m is None else cv2.bitwise_or(m, part)
        if self.kernel is not None:
            m = cv2.morphologyEx(m, cv2.MORPH_OPEN, self.kernel)
            m = cv2.morphologyEx(m, cv2.MORPH_CLOSE, self.kernel)
        return m

    def detect(self, bgr: np.ndarray) -> List[Blob]:
        """Plausible blobs of this kind in the BGR frame, best first."""
        if bgr is None or bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
            raise ValueError("expected a BGR uint8 image (h x w x 3), got %s"
                             % (None if bgr is None else "%s %s" % (bgr.shape, bgr.dtype)))
        m = self.mask(bgr)
        sy = m.shape[0] / float(bgr.shape[0])
        sx = m.shape[1] / float(bgr.shape[1])
        if 0 < self.strip_height_px < bgr.shape[0]:  # double panorama: one 360 deg strip
            cut = int(round(self.strip_height_px * sy))
            rows = min(cut, m.shape[0] - cut)
            blobs = self._components(np.hstack([m[:rows], m[cut:cut + rows]]), sx, sy,
                                     True, cut, bgr.shape[1])
        else:
            blobs = self._components(m, sx, sy, self.wrap, 0, bgr.shape[1])
        blobs.sort(key=lambda b: -b.score)
        return blobs[:self.p.max_detections]

    def _components(self, m: np.ndarray, sx: float, sy: float, wrap: bool, cut: int,
                    width_px: int) -> List[Blob]:
        """Blobs of the mask ``m`` (processing scale), one strip or the two strips of a
        double panorama side by side (``cut``: the rear strip's first row in the processed
        frame, 0 for one strip); ``wrap``: ``m``'s ends join (360 deg)."""
        p = self.p
        n, labels, stats, cents = cv2.connectedComponentsWithStats(m, connectivity=8)
        if n <= 1:
            return []
        width = m.shape[1]
        st = stats[1:].astype(np.float64)
        x0, y0 = st[:, cv2.CC_STAT_LEFT], st[:, cv2.CC_STAT_TOP]
        x1, y1 = x0 + st[:, cv2.CC_STAT_WIDTH], y0 + st[:, cv2.CC_STAT_HEIGHT]
        a = st[:, cv2.CC_STAT_AREA]
        cx, cy = cents[1:, 0] * a, cents[1:, 1] * a  # area-weighted, summed when merged
        keep = np.ones(n - 1, bool)
        if wrap:  # components meeting across the ends of the 360 deg strip are one
            ends = (labels[:, -1] > 0) & (labels[:, 0] > 0)
            for r, q in sorted(set(zip(labels[ends, -1] - 1, labels[ends, 0] - 1))):
                if r == q or not (keep[r] and keep[q]):
                    continue  # a ring round the whole panorama, or merged already
                # the right-end part moves one turn left, next to the left-end part
                x0[q], x1[q] = min(x0[q], x0[r] - width), max(x1[q], x1[r] - width)
                y0[q], y1[q] = min(y0[q], y0[r]), max(y1[q], y1[r])
                cx[q] += cx[r] - width * a[r]
                cy[q] += cy[r]
                a[q] += a[r]
                keep[r] = False
        w, h = x1 - x0, y1 - y0
        area = a / (sx * sy)  # in full-resolution pixels
        aspect = (h / sy) / (w / sx)
        fill = a / (w * h)
        ok = keep & ((area >= p.min_area_px) & (area <= p.max_area_px)
                     & (aspect >= p.min_aspect) & (aspect <= p.max_aspect)
                     & (fill >= p.min_fill) & (fill <= p.max_fill))
        out = []
        strip_w = width_px * sx  # one strip's width at processing scale
        for i in np.flatnonzero(ok):
            cu = cx[i] / a[i] + 0.5  # continuous coordinates, processing scale
            turns = math.floor(cu / width)  # a merged blob may sit left of column 0
            cu -= turns * width
            cv = cy[i] / a[i] + 0.5
            rear = cut > 0 and cu >= strip_w
            du, dv = (strip_w, -cut) if rear else (0.0, 0.0)
            du += turns * width
            bx0, bx1 = max(x0[i] - du, 0.0), min(x1[i] - du, strip_w)
            by0 = y0[i] - dv
            out.append(Blob(self.kind, (cu - du) / sx, (cv - dv) / sy,
                            (int(round(bx0 / sx)), int(round(by0 / sy)),
                             int(round((bx1 - bx0) / sx)), int(round(h[i] / sy))),
                            float(area[i]), 1.0 - math.exp(-area[i] / p.score_area_px)))
        return out
