"""Binary dilation by a disc, exact and cache-friendly. No ROS import.

`cv2.dilate` with a disc kernel is slow, and even rectangle kernels cost a full pass over
memory each: on the frontier search's 2820 x 2820 windows the passes, not the arithmetic,
are the cost. Here a dilation is a chain of `cv2.max` calls on shifted views, done strip by
strip (`STRIP_CELLS` output cells at a time), so the intermediate images stay in the cache:

* a centred running maximum of half-width a becomes one of half-width a + b (b <= a) by
  one maximum of the image shifted by -b and by +b (the two windows then touch);
* the disc is, row offset by row offset, a running maximum of some half-width: the rows
  of the widest half-width are one vertical running maximum, the others two shifted
  maxima each.

Outside the image counts as 0 (`cv2.BORDER_CONSTANT`), as in `cv2.dilate`; the results
equal `cv2.dilate` with the same kernel (tests compare them). Rectangles alone are better
left to `cv2.dilate`, which separates them.
"""

from __future__ import annotations

import math
from typing import Callable, Dict, List, Tuple

import cv2
import numpy as np

STRIP_CELLS = 720_000              # output cells per strip (256 rows of a 2820-cell window)


def disk_kernel(radius_cells: float) -> np.ndarray:
    """uint8 structuring element: cells whose centre is within radius_cells of the middle."""
    r = max(0, int(math.floor(radius_cells)))
    yy, xx = np.mgrid[-r: r + 1, -r: r + 1]
    return ((xx * xx + yy * yy) <= radius_cells * radius_cells + 1e-9).astype(np.uint8)


def disk_half_widths(radius_cells: float) -> List[int]:
    """Half-width of the disc's row at each row offset 0..floor(radius) (`disk_kernel`)."""
    r = max(0, int(math.floor(radius_cells)))
    return [int(math.floor(math.sqrt(max(0.0, radius_cells ** 2 - dy * dy)) + 1e-9))
            for dy in range(r + 1)]


def dilate_disk(mask: np.ndarray, radius_cells: float) -> np.ndarray:
    """Dilate a uint8 mask by `disk_kernel(radius_cells)`; outside the mask counts as 0."""
    return dilate_rows(mask, disk_half_widths(radius_cells))


def _grow(src: np.ndarray, cur: int, half: int, axis: int, dst: np.ndarray) -> int:
    """dst = centred running maximum along axis, of half-width min(half, 2 cur) (at least
    1), from src holding one of half-width cur; returns the new half-width. Only positions
    at least the new half-width from both ends are written (the rest is padding)."""
    n = src.shape[axis]
    s = (slice(None),) * axis
    if cur == 0:
        b = 1
        mid = s + (slice(1, n - 1),)
        cv2.max(src[s + (slice(0, n - 2),)], src[mid], dst=dst[mid])
        cv2.max(dst[mid], src[s + (slice(2, n),)], dst=dst[mid])
    else:
        b = min(cur, half - cur)
        cv2.max(src[s + (slice(0, n - 2 * b),)], src[s + (slice(2 * b, n),)],
                dst=dst[s + (slice(b, n - b),)])
    return cur + b


def dilate_rows(mask: np.ndarray, half: List[int]) -> np.ndarray:
    """Dilate a 2-D uint8 mask by the symmetric kernel whose row at offset +-dy spans
    columns -half[dy] .. half[dy]; half must not increase with dy (a disc, a rectangle)."""
    mask = np.asarray(mask, dtype=np.uint8)
    out = np.empty(mask.shape, np.uint8)

    def load(a0: int, a1: int, dst: np.ndarray) -> None:
        dst[...] = mask[a0:a1]

    def emit(y0: int, y1: int, dilated: np.ndarray) -> None:
        out[y0:y1] = dilated

    dilate_strips(mask.shape, half, load, emit)
    return out


def clear_of(image: np.ndarray, keep_value: int, obstacle_value: int,
             radius_cells: float) -> np.ndarray:
    """uint8 mask, 255 where image == keep_value and no cell == obstacle_value lies within
    `disk_kernel(radius_cells)` (outside the image: no obstacle). One strip-wise sweep:
    neither the obstacle mask nor its dilation is ever held at full size."""
    u8 = image.view(np.uint8) if image.dtype != np.uint8 else image
    out = np.empty(u8.shape, np.uint8)

    def load(a0: int, a1: int, dst: np.ndarray) -> None:
        cv2.compare(u8[a0:a1], obstacle_value & 0xFF, cv2.CMP_EQ, dst=dst)

    def emit(y0: int, y1: int, dilated: np.ndarray) -> None:
        o = out[y0:y1]
        cv2.compare(u8[y0:y1], keep_value & 0xFF, cv2.CMP_EQ, dst=o)
        cv2.subtract(o, dilated, dst=o)                   # 255 - 255 saturates to 0

    dilate_strips(u8.shape, disk_half_widths(radius_cells), load, emit)
    return out


def dilate_strips(shape: Tuple[int, int], half: List[int],
                  load: Callable[[int, int, np.ndarray], None],
                  emit: Callable[[int, int, np.ndarray], None]) -> None:
    """The dilation engine: for each strip of output rows y0..y1, `load(a0, a1, dst)` fills
    dst with the source rows a0..a1 (uint8), and `emit(y0, y1, dilated)` receives the
    strip's dilation (a scratch view, overwritten by the next strip)."""
    if any(a < b for a, b in zip(half, half[1:])):
        raise ValueError("half-widths must not increase with the row offset")
    h, w = shape
    if h == 0 or w == 0:
        return
    r, hmax = len(half) - 1, half[0]
    t0 = max(dy for dy in range(r + 1) if half[dy] == hmax)   # rows of the widest width
    widths = sorted(set(half))
    strip = max(1, STRIP_CELLS // w)
    rows_cap = min(h, strip) + 2 * r
    shape_p = (rows_cap, w + 2 * hmax)
    pad = np.zeros(shape_p, np.uint8)
    # One buffer per step of the chains, reused by every strip.
    h_bufs = [np.empty(shape_p, np.uint8) for _ in range(_steps(widths))]
    v_bufs = [np.empty(shape_p, np.uint8) for _ in range(_steps([t0]))]
    o_buf = np.empty((min(h, strip), w), np.uint8)
    for y0 in range(0, h, strip):
        y1 = min(h, y0 + strip)
        a0, a1 = max(0, y0 - r), min(h, y1 + r)
        top, bottom = a0 - (y0 - r), (y1 + r) - a1
        rows = y1 - y0 + 2 * r
        p = pad[:rows]
        p[:top] = 0
        p[rows - bottom:] = 0
        load(a0, a1, p[top: rows - bottom, hmax: hmax + w])
        # Horizontal running maxima of every half-width a kernel row has.
        by_width: Dict[int, np.ndarray] = {0: p}
        src, cur, i = p, 0, 0
        for target in widths:
            while cur < target:
                dst = h_bufs[i][:rows]
                cur = _grow(src, cur, target, 1, dst)
                src, i = dst, i + 1
            by_width[target] = src
        # Vertical running maximum of the widest rows, then the narrower rows one by one.
        src, cur, i = by_width[hmax], 0, 0
        while cur < t0:
            dst = v_bufs[i][:rows]
            cur = _grow(src, cur, t0, 0, dst)
            src, i = dst, i + 1
        o = o_buf[: y1 - y0]
        o[...] = src[r: r + y1 - y0, hmax: hmax + w]
        for dy in range(t0 + 1, r + 1):
            b = by_width[half[dy]]
            cv2.max(o, b[r + dy: r + dy + y1 - y0, hmax: hmax + w], dst=o)
            cv2.max(o, b[r - dy: r - dy + y1 - y0, hmax: hmax + w], dst=o)
        emit(y0, y1, o)


def _steps(targets: List[int]) -> int:
    """Number of `_grow` steps from half-width 0 through the (sorted) targets."""
    cur, n = 0, 0
    for half in targets:
        while cur < half:
            cur = cur + (1 if cur == 0 else min(cur, half - cur))
            n += 1
    return n
