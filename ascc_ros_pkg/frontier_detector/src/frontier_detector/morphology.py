"""Binary dilation by a disc, exact and cache-friendly. No ROS import.

`cv2.dilate` with a disc kernel is slow, and even rectangle kernels cost a full pass over
memory each: on the frontier search's 2820 x 2820 windows the passes, not the arithmetic,
are the cost. Here a dilation is a chain of `cv2.max` calls on shifted views, done strip by
strip (`STRIP_CELLS` output cells at a time), so the intermediate images stay in the cache:

* a forward running maximum of width a (cell i: the maximum of cells i .. i + a - 1)
  becomes one of width a + b (b <= a) by one maximum with itself shifted by b; the centred
  one of half-width hw is that of width 2 hw + 1, read hw cells earlier;
* the disc is, row offset by row offset, a running maximum of some half-width: the rows
  of the widest half-width are one vertical running maximum, the others two shifted
  maxima each.

`clear_of` (the traversable mask, the largest of these) is compiled instead (numba): one
sweep over the image's rows, the rows' horizontal maxima kept in a ring of 2 r + 1 rows,
so the image is read once and the mask written once.

Outside the image counts as 0 (`cv2.BORDER_CONSTANT`), as in `cv2.dilate`; the results
equal `cv2.dilate` with the same kernel (tests compare them). Rectangles alone are better
left to `cv2.dilate`, which separates them.
"""

from __future__ import annotations

import math
from typing import Callable, Dict, List, Tuple

import cv2
import numpy as np
from numba import njit

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


def dilate_disk_stack(stack: np.ndarray, radius_cells: float) -> np.ndarray:
    """Dilate each image of an (n, rows, cols) uint8 stack by `disk_kernel(radius_cells)`;
    cells within the radius of an image's border may also see the neighbouring image's
    (callers keep such a margin). The images are laid side by side: a few long rows cost
    OpenCV much less than many short ones (n x rows of them stacked vertically)."""
    n, rows, cols = stack.shape
    wide = np.ascontiguousarray(stack.transpose(1, 0, 2)).reshape(rows, n * cols)
    return dilate_disk(wide, radius_cells).reshape(rows, n, cols).transpose(1, 0, 2)


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
    `disk_kernel(radius_cells)` (outside the image: no obstacle). One compiled sweep over
    the rows: neither the obstacle mask nor its dilation is ever held at full size."""
    u8 = image.view(np.uint8) if image.dtype != np.uint8 else image
    h, w = u8.shape
    out = np.empty((h, w), np.uint8)
    if h == 0 or w == 0:
        return out
    if u8.strides[1] != 1 or u8.strides[0] < w:
        u8 = np.ascontiguousarray(u8)
    # The rows as slices of one flat byte view of the image's memory (a window of a larger
    # grid included): the compiled loops then run over contiguous rows, and vectorise.
    flat = np.lib.stride_tricks.as_strided(u8, shape=((h - 1) * u8.strides[0] + w,),
                                           strides=(1,), writeable=False)
    _clear_rows(flat, u8.strides[0], h, w, np.uint8(keep_value & 0xFF),
                np.uint8(obstacle_value & 0xFF),
                np.array(disk_half_widths(radius_cells), np.int64), out)
    return out


@njit(cache=True, nogil=True)
def _clear_rows(flat, stride, h, w, keep, obstacle, half, out):
    """`clear_of`'s sweep. Input row y is flat[y * stride: y * stride + w]. For each input
    row, its 0/1 obstacle bytes and their centred horizontal ORs of the disc's half-widths
    go into a ring of 2 r + 1 rows (`_row_widths`); output row y is then the OR, over
    dy = -r .. r, of input row y + dy's half-width half[|dy|], and 255 where the cell is
    keep and that OR is 0. Every inner loop runs over contiguous slices, which LLVM
    vectorises."""
    r = half.size - 1
    hmax = half[0]
    span = 2 * r + 1
    widx = np.zeros(r + 1, np.int64)               # ring plane of half[dy]
    for dy in range(1, r + 1):
        widx[dy] = widx[dy - 1] + (half[dy] != half[dy - 1])
    want = np.full(hmax + 1, -1, np.int64)         # ring plane of half-width k, or -1
    for dy in range(r + 1):
        want[half[dy]] = widx[dy]
    ring = np.zeros((span, widx[r] + 1, w + 2 * hmax), np.uint8)  # rows padded by hmax 0s
    scratch = np.zeros((3, w + 2 * hmax), np.uint8)
    acc = np.zeros(w, np.uint8)
    for y in range(h + r):
        if y < h:
            _row_widths(flat[y * stride: y * stride + w], obstacle, ring[y % span], want,
                        scratch)
        yo = y - r
        if yo < 0:
            continue
        acc[:] = 0
        for dy in range(max(-r, -yo), min(r, h - 1 - yo) + 1):
            src = ring[(yo + dy) % span, widx[abs(dy)]][hmax: hmax + w]
            for x in range(w):
                acc[x] |= src[x]
        row = flat[yo * stride: yo * stride + w]
        o = out[yo]
        for x in range(w):
            o[x] = (np.uint8(row[x] == keep) & np.uint8(acc[x] == 0)) * np.uint8(255)


@njit(cache=True, nogil=True)
def _row_widths(row, obstacle, planes, want, scratch):
    """One input row's 0/1 obstacle bytes (half-width 0) and their centred horizontal ORs
    of half-width 1 .. hmax (k from k - 1 by one OR of two shifted copies), each into
    planes[want[k]] if wanted, else a scratch row; rows are padded by hmax zeros."""
    hmax = want.size - 1
    w = row.size
    n_pad = w + 2 * hmax
    a = planes[want[0]] if want[0] >= 0 else scratch[2]
    inner = a[hmax: hmax + w]
    for x in range(w):
        inner[x] = row[x] == obstacle
    prev = a
    for k in range(1, hmax + 1):
        b = planes[want[k]] if want[k] >= 0 else scratch[k % 2]
        n = n_pad - 2 * k                          # half-width k is valid on k .. n_pad - k
        dst = b[k: k + n]
        left = prev[k - 1: k - 1 + n]
        right = prev[k + 1: k + 1 + n]
        if k == 1:
            mid = prev[k: k + n]
            for x in range(n):
                dst[x] = left[x] | mid[x] | right[x]
        else:
            for x in range(n):
                dst[x] = left[x] | right[x]
        prev = b


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
    strip = max(1, STRIP_CELLS // w)
    rows_cap = min(h, strip) + 2 * r
    shape_p = (rows_cap, w + 2 * hmax)
    pad = np.zeros(shape_p, np.uint8)
    # Forward running maxima (f[i] = max of src[i .. i + width - 1]) by doubling; the
    # centred one of half-width hw is f of width 2 hw + 1 read hw places to the left.
    h_plan = _doubling([2 * hw + 1 for hw in set(half)])
    v_plan = _doubling([2 * t0 + 1])
    h_bufs = [np.empty(shape_p, np.uint8) for _ in h_plan]
    v_bufs = [np.empty(shape_p, np.uint8) for _ in v_plan[:-1]]
    o_buf = np.empty((min(h, strip), w), np.uint8)
    for y0 in range(0, h, strip):
        y1 = min(h, y0 + strip)
        a0, a1 = max(0, y0 - r), min(h, y1 + r)
        top, bottom = a0 - (y0 - r), (y1 + r) - a1
        rows, n_out = y1 - y0 + 2 * r, y1 - y0
        p = pad[:rows]
        p[:top] = 0
        p[rows - bottom:] = 0
        load(a0, a1, p[top: rows - bottom, hmax: hmax + w])
        # Horizontal: every width a kernel row has (buffer columns 0 .. end - b).
        by_width: Dict[int, np.ndarray] = {1: p}
        src = p
        for (width, b), buf in zip(h_plan, h_bufs):
            dst = buf[:rows]
            n = dst.shape[1]
            cv2.max(src[:, : n - b], src[:, b:], dst=dst[:, : n - b])
            by_width[width] = src = dst
        widest = by_width[2 * hmax + 1]                 # centred: columns 0 .. w - 1
        o = o_buf[:n_out]
        # Vertical over the widest rows (offsets -t0 .. t0); the last step writes o.
        src, start = widest, r - t0                     # o's row i is src's row i + start
        if not v_plan:
            o[...] = src[start: start + n_out, :w]
        for i, (_, b) in enumerate(v_plan):
            if i == len(v_plan) - 1:
                cv2.max(src[start: start + n_out, :w], src[start + b: start + b + n_out, :w],
                        dst=o)
            else:
                dst = v_bufs[i][:rows]
                cv2.max(src[: rows - b], src[b:], dst=dst[: rows - b])
                src = dst
        # The narrower rows, two shifted maxima each.
        for dy in range(t0 + 1, r + 1):
            hw = half[dy]
            f, c = by_width[2 * hw + 1], hmax - hw
            cv2.max(o, f[r + dy: r + dy + n_out, c: c + w], dst=o)
            cv2.max(o, f[r - dy: r - dy + n_out, c: c + w], dst=o)
        emit(y0, y1, o)


def _doubling(widths: List[int]) -> List[Tuple[int, int]]:
    """Steps (new width, shift b) that make forward running maxima of all the widths from
    width 1: width a + b = max(width a, width a shifted by b), b <= a."""
    steps: List[Tuple[int, int]] = []
    cur = 1
    for target in sorted(set(widths)):
        while cur < target:
            b = min(cur, target - cur)
            cur += b
            steps.append((cur, b))
    return steps
