"""High-level target detection (thesis 2.4): the project's logo by local features.

The thesis matched SURF features of the OSU logo; SURF is not in free OpenCV, so ORB
(opencv-python-headless) does the same job here, with a feature cap for speed:

1. The template (``templates/ascc_logo.png``) is shrunk to a few heights
   (``template_min_height_px`` x ``template_scale_step``^k, k < ``template_levels``) close
   to the sizes it has in the panorama, and ORB describes each; these descriptor sets are
   cached per blur length (below).
2. ORB describes the frame (grey, optionally shrunk by ``processing_scale``), at most
   ``max_features`` keypoints.
3. Each template set is matched to the frame by 2-nearest-neighbour Hamming matching and
   Lowe's ratio test (``ratio``); the set with the most inliers wins.
4. A homography is fitted to the good matches with RANSAC (``cv2.findHomography``,
   ``ransac_reproj_px``). A homography is always "found", so the fit counts only when it is
   plausible: at least ``min_inliers`` inliers making up ``min_inlier_ratio`` of the
   matches; the template's outline maps to a convex quadrilateral of area within
   [``min_area_px``, ``max_area_px``], its width / height within ``max_aspect_change`` of
   the template's, opposite sides within ``max_side_ratio`` of each other (no strong
   perspective: a poster seen by a robot), and the homography's determinant not near 0.

**Motion blur** (thesis Table 2.1: SURF matching collapses at 0.87 rad/s). While the robot
turns, every panorama row moves by ``blur_px = |yaw rate| x exposure x px_per_rad``
(``PanoramicCamera.blur_length_px``) during one exposure: a box blur along the rows. The
robot knows its yaw rate (odometry), so the detector blurs the template the same way
before describing it (``blur_px`` in frame pixels, scaled to each template level by the
frame's ``processing_scale``): blurred features then match blurred features. Blur lengths
are rounded to ``blur_step_px`` and each set is computed once and cached (the template is
small: a set costs a few milliseconds).

**Seams.** The double panorama's two 180-degree strips are joined into one 360-degree
strip before ORB sees the frame (as the colour detector does), and its first
``seam_overlap_px`` columns are repeated after its end: a poster at -90 or +90 deg,
half at the end of one strip and half at the start of the other, is matched whole. The
joined image has 2 x width + ``seam_overlap_px`` columns of one strip's height (12 % more
pixels than the frame at the defaults).

Result: at most one ``Blob`` (kind "logo"), with the quadrilateral's centroid, bounding
box (the part in its strip), area and ``quad`` (4 x 2 corners, full-resolution frame
pixels; on a seam the corners beyond it keep continuous columns, < 0 or >= width);
score = inliers / (inliers + ``score_inliers``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import cv2
import numpy as np

from ascc_common.params import param

from .color_detector import Blob


@dataclass
class LogoParams:
    """Feature matching and fit-plausibility parameters of the logo detector."""

    features: str = param("orb", "local features: orb or sift", choices=("orb", "sift"))
    processing_scale: float = param(1.0, "[1] the frame is shrunk by this factor before "
                                         "feature detection", gt=0.0, le=1.0)
    max_features: int = param(1500, "[1] ORB keypoints kept per frame", gt=0)
    fast_threshold: int = param(12, "[0..255] ORB's FAST corner threshold", gt=0)
    template_min_height_px: float = param(90.0, "[px, processed frame] height of the "
                                                "smallest template level", gt=8.0)
    template_levels: int = param(3, "[1] template sizes described", gt=0)
    template_scale_step: float = param(1.6, "[1] size ratio of successive template "
                                            "levels", gt=1.0)
    template_features: int = param(500, "[1] ORB keypoints per template level", gt=0)
    blur_step_px: float = param(4.0, "[px, full resolution] blur lengths are rounded to "
                                     "multiples of this", gt=0.0)
    ratio: float = param(0.8, "[1] Lowe's ratio test (best / second-best distance)",
                         gt=0.0, le=1.0)
    ransac_reproj_px: float = param(5.0, "[px, processed frame] RANSAC inlier threshold",
                                    gt=0.0)
    min_inliers: int = param(12, "[1] fewest RANSAC inliers for a detection", ge=4)
    min_inlier_ratio: float = param(0.3, "[1] fewest inliers / good matches", ge=0.0,
                                    le=1.0)
    min_area_px: float = param(1500.0, "[px, full resolution] smallest projected logo "
                                       "area", ge=0.0)
    max_area_px: float = param(200000.0, "[px, full resolution] largest projected logo "
                                         "area", gt=0.0)
    max_aspect_change: float = param(1.6, "[1] largest factor between the projected and "
                                          "the template's width / height", ge=1.0)
    max_side_ratio: float = param(1.6, "[1] largest ratio of opposite sides of the "
                                       "projected outline", ge=1.0)
    score_inliers: float = param(20.0, "[1] inlier count of score 0.5 (score = n / (n + "
                                       "score_inliers))", gt=0.0)
    seam_overlap_px: int = param(256, "[px, full resolution] columns of the 360-degree "
                                      "strip's start repeated after its end, so that a "
                                      "logo up to this wide on that seam is whole", ge=0)


def load_template(path: str) -> np.ndarray:
    """The template as a BGR image; ValueError naming ``path`` if missing, empty or not an
    image."""
    img = cv2.imread(path, cv2.IMREAD_COLOR)
    if img is None or img.size == 0:
        raise ValueError("cannot read the logo template %r (missing, empty or not an "
                         "image)" % path)
    if min(img.shape[:2]) < 32:
        raise ValueError("the logo template %r is too small (%dx%d px)"
                         % (path, img.shape[1], img.shape[0]))
    return img


def _grey(img: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img


class _TemplateSet:
    """Descriptors of the template at one size and blur: keypoints (n x 2, template-level
    pixels), descriptors, and the level's outline (4 x 2)."""

    def __init__(self, pts: np.ndarray, desc: Optional[np.ndarray], outline: np.ndarray):
        self.pts = pts
        self.desc = desc
        self.outline = outline


class LogoDetector:
    """Finds the template in BGR frames; ``detect(frame, blur_px)``. Not thread-safe (the
    template cache): one instance per worker thread."""

    def __init__(self, template_bgr: np.ndarray, params: LogoParams, strip_height_px: int = 0,
                 wrap: bool = False):
        """``strip_height_px``: the double panorama's strip height (its two strips are
        joined into one 360-degree strip before matching; 0: the frame is one strip);
        ``wrap``: a single strip covers 360 degrees (its ends join)."""
        if template_bgr is None or template_bgr.size == 0:
            raise ValueError("empty logo template")
        self.p = params
        self.strip_height_px = strip_height_px
        self.wrap = wrap
        self.template = _grey(template_bgr)
        th, tw = self.template.shape[:2]
        self.template_aspect = tw / float(th)  # width / height
        if params.features == "sift":
            self.orb = cv2.SIFT_create(nfeatures=params.max_features)
            self.template_orb = cv2.SIFT_create(nfeatures=params.template_features)
            self.matcher = cv2.BFMatcher(cv2.NORM_L2)
        else:
            self.orb = cv2.ORB_create(nfeatures=params.max_features,
                                      fastThreshold=params.fast_threshold)
            self.template_orb = cv2.ORB_create(nfeatures=params.template_features,
                                               fastThreshold=params.fast_threshold)
            self.matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
        self._cache: Dict[int, List[_TemplateSet]] = {}

    # -- the template at a blur -----------------------------------------------------------
    def template_sets(self, blur_px: float) -> List[_TemplateSet]:
        """The template's descriptor sets for a frame blurred over ``blur_px`` (full
        resolution) pixels along its rows; cached per rounded blur."""
        step = self.p.blur_step_px
        key = int(round(max(0.0, blur_px) / step))
        if key not in self._cache:
            self._cache[key] = self._describe(key * step * self.p.processing_scale)
        return self._cache[key]

    def _describe(self, blur_proc_px: float) -> List[_TemplateSet]:
        p = self.p
        th, tw = self.template.shape[:2]
        sets = []
        for k in range(p.template_levels):
            h = p.template_min_height_px * p.template_scale_step ** k
            s = min(1.0, h / th)
            img = cv2.resize(self.template, (max(8, int(round(tw * s))),
                                             max(8, int(round(th * s)))),
                             interpolation=cv2.INTER_AREA)
            # a white margin like the poster's, so that corners near the edge are found
            # and room for ORB's 31 px patches (keypoints within edgeThreshold are dropped)
            pad = max(32, int(0.1 * img.shape[0]))
            img = cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=245)
            n = int(round(blur_proc_px))
            if n >= 2:
                img = cv2.blur(img, (n, 1), borderType=cv2.BORDER_REPLICATE)
            kps, desc = self.template_orb.detectAndCompute(img, None)
            pts = np.float32([kp.pt for kp in kps]).reshape(-1, 2)
            sx, sy = (img.shape[1] - 2 * pad) / float(tw), (img.shape[0] - 2 * pad) / float(th)
            # outline in OpenCV's keypoint coordinates (pixel centres at integers)
            outline = np.float32([[0, 0], [tw, 0], [tw, th], [0, th]]) * [sx, sy] + pad - 0.5
            sets.append(_TemplateSet(pts, desc, outline))
        return sets

    # -- detection ------------------------------------------------------------------------
    def detect(self, bgr: np.ndarray, blur_px: float = 0.0) -> List[Blob]:
        """[the logo] or [] for a BGR (or grey) frame blurred along its rows over
        ``blur_px`` full-resolution pixels (0: still)."""
        if bgr is None or bgr.dtype != np.uint8 or bgr.ndim not in (2, 3):
            raise ValueError("expected a uint8 image, got %s"
                             % (None if bgr is None else "%s %s" % (bgr.shape, bgr.dtype)))
        p = self.p
        grey, strip_w, cut, period = self._strip(_grey(bgr))
        if p.processing_scale < 1.0:
            grey = cv2.resize(grey, None, fx=p.processing_scale, fy=p.processing_scale,
                              interpolation=cv2.INTER_AREA)
        kps, desc = self.orb.detectAndCompute(grey, None)
        if desc is None or len(kps) < p.min_inliers:
            return []
        frame_pts = np.float32([kp.pt for kp in kps])
        best: Optional[Tuple[int, np.ndarray, np.ndarray]] = None
        for ts in self.template_sets(blur_px):
            fit = self._fit(ts, frame_pts, desc)
            if fit is not None and (best is None or fit[0] > best[0]):
                best = fit
        if best is None:
            return []
        inliers, quad, _ = best
        return [self._blob(self._to_frame(self._full(quad), strip_w, cut, period), inliers,
                           strip_w)]

    def _strip(self, grey: np.ndarray) -> Tuple[np.ndarray, int, int, int]:
        """The image ORB sees: a double panorama's two strips side by side (the front
        strip's right end, -90 deg, runs into the rear strip's left end), and for a
        360-degree strip its first ``seam_overlap_px`` columns again after its end (+90
        deg for the double panorama), so a logo on a seam is whole. Also returns one
        strip's width, the rear strip's first row (0: one strip) and the 360-degree
        period in columns (0: the frame does not wrap)."""
        h, w = grey.shape[:2]
        cut, period = 0, 0
        if 0 < self.strip_height_px < h:
            cut = self.strip_height_px
            rows = min(cut, h - cut)
            grey = np.hstack([grey[:rows], grey[cut:cut + rows]])
            period = 2 * w
        elif self.wrap:
            period = w
        if period:
            grey = np.hstack([grey, grey[:, :min(self.p.seam_overlap_px, period)]])
        return np.ascontiguousarray(grey), w, cut, period

    @staticmethod
    def _to_frame(quad: np.ndarray, strip_w: int, cut: int, period: int) -> np.ndarray:
        """A quadrilateral found in ``_strip``'s image -> frame pixels: its centre is
        brought into the first turn and, past the front strip's width, into the rear
        strip. Corners beyond the seam keep their continuous columns (< 0 or >= width)."""
        quad = quad.copy()
        c = float(quad[:, 0].mean())
        if period:
            quad[:, 0] -= math.floor(c / period) * period
            c = float(quad[:, 0].mean())
        if cut and c >= strip_w:
            quad[:, 0] -= strip_w
            quad[:, 1] += cut
        return quad

    def _fit(self, ts: _TemplateSet, frame_pts: np.ndarray, desc: np.ndarray):
        p = self.p
        if ts.desc is None or len(ts.desc) < 2:
            return None
        pairs = self.matcher.knnMatch(ts.desc, desc, k=2)
        good = [m[0] for m in pairs if len(m) == 2 and m[0].distance < p.ratio * m[1].distance]
        if len(good) < p.min_inliers:
            return None
        src = ts.pts[[m.queryIdx for m in good]]
        dst = frame_pts[[m.trainIdx for m in good]]
        H, mask = cv2.findHomography(src, dst, cv2.RANSAC, p.ransac_reproj_px)
        if H is None:
            return None
        inliers = int(mask.sum())
        if inliers < p.min_inliers or inliers < p.min_inlier_ratio * len(good):
            return None
        quad = cv2.perspectiveTransform(ts.outline.reshape(-1, 1, 2), H).reshape(4, 2)
        if not self.plausible(self._full(quad), H):
            return None
        return inliers, quad, H

    def _full(self, pts: np.ndarray) -> np.ndarray:
        """Processed-frame OpenCV coordinates -> full-resolution pixels (centres at +0.5,
        the camera model's convention)."""
        return (pts + 0.5) / self.p.processing_scale

    def plausible(self, quad: np.ndarray, H: np.ndarray) -> bool:
        """Is ``quad`` (the template's outline in full-resolution frame pixels, corners in
        the template's order TL, TR, BR, BL) a plausible view of the poster?"""
        p = self.p
        if not np.all(np.isfinite(quad)) or abs(np.linalg.det(H[:2, :2])) < 1e-6:
            return False
        if not cv2.isContourConvex(quad.astype(np.float32).reshape(-1, 1, 2)):
            return False
        area = cv2.contourArea(quad.astype(np.float32))
        if not p.min_area_px <= area <= p.max_area_px:
            return False
        sides = np.linalg.norm(quad - np.roll(quad, -1, axis=0), axis=1)  # top, right, bottom, left
        if sides.min() <= 1.0:
            return False
        if max(sides[0] / sides[2], sides[2] / sides[0], sides[1] / sides[3],
               sides[3] / sides[1]) > p.max_side_ratio:
            return False
        # orientation: TL -> TR runs left to right, TL -> BL top to bottom (not mirrored)
        if quad[1, 0] <= quad[0, 0] or quad[3, 1] <= quad[0, 1]:
            return False
        aspect = (sides[0] + sides[2]) / (sides[1] + sides[3])
        change = aspect / self.template_aspect
        return 1.0 / p.max_aspect_change <= change <= p.max_aspect_change

    def _blob(self, quad: np.ndarray, inliers: int, strip_w: int) -> Blob:
        """The detection; its box is the part of the quadrilateral in its strip."""
        m = cv2.moments(quad.astype(np.float32))
        area = float(m["m00"])
        u, v = (m["m10"] / area, m["m01"] / area) if area > 0 else quad.mean(axis=0)
        u = float(np.clip(u, 0.0, strip_w - 1e-6))
        x0, y0 = np.floor(quad.min(axis=0))
        x1, y1 = np.ceil(quad.max(axis=0))
        x0, x1 = max(x0, 0.0), min(x1, float(strip_w))
        return Blob("logo", float(u), float(v),
                    (int(x0), int(y0), int(x1 - x0), int(y1 - y0)), area,
                    inliers / (inliers + self.p.score_inliers), quad=quad.astype(float))
