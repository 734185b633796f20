"""What the simulated Q24's sensor does to a rendered panorama (no rospy), all seeded.

In the order light meets the sensor: a slight lens blur (Gaussian), **motion blur along
the image rows** of ``PanoramicCamera.blur_length_px(yaw_rate, exposure_s)`` pixels (a
rotation about the vertical axis moves every panorama row sideways; a centred 1-D box
filter whose end taps carry the fractional part, so the length is exact), slowly drifting
**brightness (gain) and white balance** (per-channel gains, smooth functions of time with
seeded phases), then **sensor noise** (Gaussian, ``noise_sigma`` grey levels). JPEG
compression is the node's.

The blur does not wrap around the panorama: at a strip's left and right edges the row is
mirrored (``cv2.BORDER_REFLECT``), so the ``blur/2`` columns next to an edge are blurred
with the wrong neighbours (those columns are 90 deg to the side of the robot or behind
it). The noise comes from a noise field drawn once (seeded) and sampled each frame at a
seeded random offset and flip, so one frame costs an add, not a fresh Gaussian draw (25 ms
at 1024 x 768); consecutive frames' noise is uncorrelated pixel by pixel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import cv2
import numpy as np

from ascc_common.params import param

_MARGIN = 64  # noise field margin for the random offsets [px]


@dataclass
class CameraEffectsParams:
    """The sensor model's parameters (``~effects/...`` in the node)."""

    exposure_s: float = param(0.1, "[s] exposure time: an indoor auto-exposure value "
                                   "(the motion blur grows with it)", ge=0.0)
    noise_sigma: float = param(2.0, "[grey levels of 255] Gaussian sensor noise", ge=0.0)
    gain_drift: float = param(0.12, "amplitude of the slow brightness (gain) drift, "
                                    "relative", ge=0.0, le=0.9)
    white_balance_drift: float = param(0.06, "amplitude of the slow per-channel gain "
                                             "(white balance) drift, relative", ge=0.0,
                                       le=0.9)
    drift_period_s: float = param(30.0, "[s] period of the slowest drift component", gt=0.0)
    lens_blur_px: float = param(0.6, "[px] sigma of the lens blur; 0: none", ge=0.0)


def motion_blur_kernel(length_px: float) -> np.ndarray:
    """A centred 1 x n box kernel of length ``length_px`` (the end taps carry the
    fraction), summing to 1; ``[[1]]`` below one pixel."""
    if not length_px > 1.0:
        return np.ones((1, 1), dtype=np.float32)
    n = 2 * int(math.ceil((length_px - 1.0) / 2.0)) + 1  # odd, >= length_px
    k = np.ones(n, dtype=np.float64)
    k[0] = k[-1] = (length_px - (n - 2)) / 2.0
    return (k / k.sum()).astype(np.float32)[None, :]


def motion_blur(img: np.ndarray, length_px: float) -> np.ndarray:
    """Blur along the image rows by ``length_px`` (no wrap at the edges: reflected)."""
    if not length_px > 1.0:
        return img
    return cv2.filter2D(img, -1, motion_blur_kernel(length_px),
                        borderType=cv2.BORDER_REFLECT)


class CameraEffects:
    """The sensor model of one camera: ``apply(image, t_s, blur_px, frame)``.

    Args:
        params: the model's parameters.
        shape: the image shape (height, width, 3).
        seed: fixes the drift phases and the noise (with the frame number).
    """

    def __init__(self, params: CameraEffectsParams, shape: Tuple[int, int, int],
                 seed: int = 0):
        self.params = params
        self.seed = int(seed)
        rng = np.random.default_rng([self.seed, 0x51C])
        self._phase = rng.uniform(0.0, 2.0 * math.pi, size=5)
        self._wb_period = rng.uniform(0.6, 1.4, size=3)
        h, w = shape[0], shape[1]
        self._noise = None
        if params.noise_sigma > 0:
            self._noise = (rng.standard_normal((h + _MARGIN, w + _MARGIN, shape[2]),
                                               dtype=np.float32)
                           * np.float32(params.noise_sigma))

    def gains(self, t_s: float) -> np.ndarray:
        """Per-channel (B, G, R) gains at time ``t_s`` [s]: brightness x white balance."""
        p = self.params
        w = 2.0 * math.pi / p.drift_period_s
        ph = self._phase
        g = 1.0 + p.gain_drift * (0.65 * math.sin(w * t_s + ph[0])
                                  + 0.35 * math.sin(2.7 * w * t_s + ph[1]))
        wb = 1.0 + p.white_balance_drift * np.sin(w * t_s / self._wb_period + ph[2:5])
        return (g * wb).astype(np.float32)

    def apply(self, img: np.ndarray, t_s: float, blur_px: float, frame: int
              ) -> np.ndarray:
        """The sensor's image (uint8, same shape) of the rendered ``img`` at time ``t_s``
        [s] with a motion blur of ``blur_px`` [px]; ``frame`` picks the noise."""
        p = self.params
        out = img
        if p.lens_blur_px > 0:
            out = cv2.GaussianBlur(out, (0, 0), p.lens_blur_px)
        out = motion_blur(out, blur_px)
        f = out.astype(np.float32)
        f *= self.gains(t_s)
        if self._noise is not None:
            rng = np.random.default_rng([self.seed, int(frame)])
            dy, dx = rng.integers(0, _MARGIN, size=2)
            noise = self._noise[dy:dy + img.shape[0], dx:dx + img.shape[1]]
            if rng.random() < 0.5:
                noise = noise[::-1]
            f += noise
        np.clip(f, 0.0, 255.0, out=f)
        return f.astype(np.uint8)
