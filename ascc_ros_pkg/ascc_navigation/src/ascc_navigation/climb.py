"""The scan matcher's compiled kernels (numba): gmapping's greedy six-move search, and
the image its likelihood fields are the distance transform of (``field_image``).

One particle after another, each from its sampled pose in its own map: try the six moves
around the current pose (+-x, +-y by the step times ``lstep``, +-theta by the step times
``astep``); take the best if it improves the objective, else halve the step; stop after
``iterations`` halvings (or ``max_steps`` tries). Objective: the match score
sum_b exp(-d_b^2 / (2 sigma^2)) minus sum_k prior[k] * (pose_k - start_k)^2 minus
along * ((pose - start)_xy . h)^2, h the unit vector of the start's heading (turned by
``along_angle``); d_b is the
bilinear distance of end point b to the particle's map (``rbpf._LikelihoodFields``), from
the four corners of its cell in the distance image.

It computes what ``_LikelihoodFields.distances`` and ``match_score`` computed for the
numpy search it replaces, in the same number types (end points rotated and placed in
float32 cell coordinates, the bilinear patch and the score in float64), but one end point
at a time and the six moves in one pass over the end points: no (particles x moves x
beams) arrays, no Python between the moves: 36-47 % less CPU per filter update. One
thing differs: exp(-d^2 / (2 sigma^2)) comes from a table (``score_table``:
``TABLE_SIZE`` intervals over the distances' range [0, match radius], linear between
entries), not from the C library's exp, which took a third of the search's time. It is
within h^2 / (8 sigma^2) of the exponential (h the table's step; 2.7e-7 per beam for the
shipped sigma 0.05 m and radius 0.15 m), so a score of 600 beams within 2e-4 of numpy's
(test_climb.py). The search is 24 % faster on a corridor run's updates; a difference that
small still sends the filter down other paths now and then (docs/results).

The loop closure's correlative matcher (``posegraph.correlative_match``) has two kernels
here too: the coarse grid's mean scores (``grid_scores``) and the refinement's bilinear
scores (``pose_scores``), each one pass over the end points per candidate instead of
numpy's (candidates x points) arrays: a sequential or loop match takes a quarter of the
time it did, with the same result. Both can score only the end points that land in space
the submap saw (a loop match: ``posegraph.LikelihoodField``'s ``seen``).
No ROS imports.
"""

from __future__ import annotations

import functools
import math
import time
from types import SimpleNamespace
from typing import Optional, Tuple

import numpy as np
from numba import njit

# intervals of the score's table over [0, the distances' cap] (``score_table``): 16 KB
TABLE_SIZE = 2048
# moves in the map frame: +-x, +-y (times lstep), +-theta (times astep); the order decides
# ties (the first best move is taken), as in rbpf's numpy search before it
MOVES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
                 dtype=np.float64)


@njit(cache=True, nogil=True)
def _distance(dist, base, w, u, v, max_u, max_v):
    """Bilinear distance at window cell coordinates u, v (float32, clamped to the window)
    in the distance image ``dist`` (flat float32, rows of ``w`` cells, the particle's band
    at ``base``): the cell's patch from its four corners in float32, as
    ``_LikelihoodFields._corners``, evaluated in float64. A NaN coordinate clamps to 0:
    numba does not check the index, and NaN would make one outside the image."""
    if not u >= np.float32(0.0):
        u = np.float32(0.0)
    elif u > max_u:
        u = max_u
    if not v >= np.float32(0.0):
        v = np.float32(0.0)
    elif v > max_v:
        v = max_v
    iu = np.int32(u)
    iv = np.int32(v)
    fu = np.float64(u) - iu
    fv = np.float64(v) - iv
    j = base + iv * w + iu
    d00 = dist[j]
    b = dist[j + 1] - d00
    d01 = dist[j + w]
    e = dist[j + w + 1] - d01 - b
    return (d00 + fu * b) + fv * ((d01 - d00) + fu * e)


@njit(cache=True, nogil=True)
def _kernel(table, inv_h, last, d):
    """exp(-d^2 / (2 sigma^2)) for a distance d in [0, the cap] from ``score_table``'s
    entries (at d = i h, inv_h = 1 / h), linear between the two around d; past the last
    interval (``last``) the line through its ends."""
    x = d * inv_h
    i = np.int64(x)
    if i > last:
        i = last
    t = table[i]
    return t + (x - i) * (table[i + 1] - t)


@njit(cache=True, nogil=True)
def _score(g, base, x, y, theta, mx, my):
    """Match score of the end points (mx, my: float32 cells, base frame) seen from
    (x, y, theta); g: ``geometry``."""
    dist, w, max_u, max_v, inv_res, ox, oy, table, inv_h, last = g
    c = np.float32(math.cos(theta))
    s = np.float32(math.sin(theta))
    xc = np.float32((x - ox) * inv_res)
    yc = np.float32((y - oy) * inv_res)
    total = 0.0
    for b in range(mx.size):
        d = _distance(dist, base, w, xc + (c * mx[b] - s * my[b]),
                      yc + (s * mx[b] + c * my[b]), max_u, max_v)
        total += _kernel(table, inv_h, last, d)
    return total


@njit(cache=True, nogil=True)
def _six_scores(g, base, x, y, theta, dl, da, mx, my, out):
    """Match scores of the six moves (``MOVES``: x +- dl, y +- dl, theta +- da) around
    (x, y, theta) into out, in one pass over the end points (the four translations share
    one rotation)."""
    dist, w, max_u, max_v, inv_res, ox, oy, table, inv_h, last = g
    c0 = np.float32(math.cos(theta))
    s0 = np.float32(math.sin(theta))
    c1 = np.float32(math.cos(theta + da))
    s1 = np.float32(math.sin(theta + da))
    c2 = np.float32(math.cos(theta - da))
    s2 = np.float32(math.sin(theta - da))
    xc = np.float32((x - ox) * inv_res)
    yc = np.float32((y - oy) * inv_res)
    xp = np.float32((x + dl - ox) * inv_res)
    xm = np.float32((x - dl - ox) * inv_res)
    yp = np.float32((y + dl - oy) * inv_res)
    ym = np.float32((y - dl - oy) * inv_res)
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    t3 = 0.0
    t4 = 0.0
    t5 = 0.0
    for b in range(mx.size):
        a = mx[b]
        e = my[b]
        ru = c0 * a - s0 * e
        rv = s0 * a + c0 * e
        d0 = _distance(dist, base, w, xp + ru, yc + rv, max_u, max_v)
        d1 = _distance(dist, base, w, xm + ru, yc + rv, max_u, max_v)
        d2 = _distance(dist, base, w, xc + ru, yp + rv, max_u, max_v)
        d3 = _distance(dist, base, w, xc + ru, ym + rv, max_u, max_v)
        d4 = _distance(dist, base, w, xc + (c1 * a - s1 * e), yc + (s1 * a + c1 * e),
                       max_u, max_v)
        d5 = _distance(dist, base, w, xc + (c2 * a - s2 * e), yc + (s2 * a + c2 * e),
                       max_u, max_v)
        t0 += _kernel(table, inv_h, last, d0)
        t1 += _kernel(table, inv_h, last, d1)
        t2 += _kernel(table, inv_h, last, d2)
        t3 += _kernel(table, inv_h, last, d3)
        t4 += _kernel(table, inv_h, last, d4)
        t5 += _kernel(table, inv_h, last, d5)
    out[0] = t0
    out[1] = t1
    out[2] = t2
    out[3] = t3
    out[4] = t4
    out[5] = t5


@njit(cache=True, nogil=True)
def _climb(g, band, mx, my, start, particles, prior, along, along_angle, unit, iterations,
           max_steps, pose, score):
    """The search for every start pose (rows of ``start``), results into pose and score."""
    w = g[1]
    scores = np.empty(6)
    for i in range(start.shape[0]):
        base = particles[i] * band * w
        sx, sy, st = start[i, 0], start[i, 1], start[i, 2]
        hx = math.cos(st + along_angle)
        hy = math.sin(st + along_angle)
        px, py, pt = sx, sy, st
        sc = _score(g, base, px, py, pt, mx, my)
        best = sc
        step = 1.0
        halvings = 0
        for _ in range(max_steps):
            if halvings >= iterations:
                break
            _six_scores(g, base, px, py, pt, step * unit[0], step * unit[2], mx, my, scores)
            jbest = -1
            obest = 0.0
            cx = cy = ct = 0.0
            for m in range(6):
                qx = px + MOVES[m, 0] * (step * unit[0])
                qy = py + MOVES[m, 1] * (step * unit[1])
                qt = pt + MOVES[m, 2] * (step * unit[2])
                dx = qx - sx
                dy = qy - sy
                dt = qt - st
                obj = scores[m] - (dx * dx * prior[0] + dy * dy * prior[1] + dt * dt * prior[2])
                if along != 0.0:
                    a = dx * hx + dy * hy
                    obj -= along * (a * a)
                if jbest < 0 or obj > obest:
                    jbest = m
                    obest = obj
                    cx, cy, ct = qx, qy, qt
            if obest > best:
                px, py, pt = cx, cy, ct
                best = obest
                sc = scores[jbest]
            else:
                step *= 0.5
                halvings += 1
        pose[i, 0] = px
        pose[i, 1] = py
        pose[i, 2] = pt
        score[i] = sc


@njit(cache=True, nogil=True)
def _field_image(visits, hits, y0, x0, h, w, band, table, out):
    """out[p, i, j] = table[visits << 8 | hits] at cell (y0 + i, x0 + j) of particle p's
    counts for rows i < h, 255 (no obstacle) in the band's pad rows below."""
    for p in range(out.shape[0]):
        for i in range(band):
            if i < h:
                for j in range(w):
                    out[p, i, j] = table[(np.int64(visits[p, y0 + i, x0 + j]) << 8)
                                         | hits[p, y0 + i, x0 + j]]
            else:
                for j in range(w):
                    out[p, i, j] = 255


def field_image(visits: np.ndarray, hits: np.ndarray, window: Tuple[int, int, int, int],
                band: int, table: np.ndarray) -> np.ndarray:
    """The distance transform's input for every particle's window [x0, x1) x [y0, y1) of
    the count grids ``visits``, ``hits`` (N, H, W, uint8): ``table`` (65536 entries,
    visits << 8 | hits -> 0 occupied, 255 not) per cell, as (N, band, x1 - x0) uint8, the
    rows from y1 - y0 to ``band`` 255. One pass, no (N, h, w) key array: a quarter of
    numpy's time."""
    x0, y0, x1, y1 = window
    out = np.empty((visits.shape[0], band, x1 - x0), np.uint8)
    _field_image(visits, hits, int(y0), int(x0), int(y1 - y0), int(x1 - x0), int(band),
                 table, out)
    return out


@functools.lru_cache(maxsize=8)
def score_table(radius: float, sigma: float) -> Tuple[np.ndarray, float]:
    """exp(-d^2 / (2 sigma^2)) at d = i h, i = 0 .. TABLE_SIZE + 1, h = radius / TABLE_SIZE
    (the exponent's factor rounded to float32 as ``match_score`` has it), and 1 / h.
    Built once per (radius, sigma), not at every search: the array is read-only."""
    h = radius / TABLE_SIZE
    d = np.arange(TABLE_SIZE + 2) * h
    table = np.exp(d * d * float(np.float32(-0.5 / sigma ** 2)))
    table.flags.writeable = False
    return table, 1.0 / h


def geometry(fields, sigma: float) -> tuple:
    """The kernels' view of the likelihood fields (``rbpf._LikelihoodFields``) and of the
    score's width: (the flat float32 distance image, window width, float32 clamp bounds
    as numpy's clip of float32 cells has them, 1 / resolution, window origin x, y, the
    score's table over the distances' range [0, fields.radius] and its 1 / step, its last
    interval)."""
    table, inv_h = score_table(fields.radius, sigma)
    return (fields.dist, int(fields.w),
            np.float32(fields.w - 1.001), np.float32(fields.h - 1.001), 1.0 / fields.res,
            float(fields.origin_x), float(fields.origin_y), table, inv_h, TABLE_SIZE)


@njit(cache=True, nogil=True)
def _grid_scores(lut, base, shift, out):
    """out[t, j] = mean over m of lut[base[t, m] + shift[j]] (float64 sums)."""
    n = base.shape[1]
    for t in range(base.shape[0]):
        for j in range(shift.size):
            off = shift[j]
            total = 0.0
            for m in range(n):
                total += lut[base[t, m] + off]
            out[t, j] = total / n


@njit(cache=True, nogil=True)
def _grid_scores_seen(lut, seen, base, shift, min_count, out):
    """out[t, j] = sum over m of lut*seen at base[t, m] + shift[j] over max(the sum of seen
    there, min_count) (float64 sums): the mean over the points that land in seen space."""
    n = base.shape[1]
    for t in range(base.shape[0]):
        for j in range(shift.size):
            off = shift[j]
            total = 0.0
            count = 0.0
            for m in range(n):
                k = base[t, m] + off
                total += lut[k]
                count += seen[k]
            out[t, j] = total / max(count, min_count)


def grid_scores(lut: np.ndarray, base: np.ndarray, shift: np.ndarray,
                seen: Optional[np.ndarray] = None, min_share: float = 0.1) -> np.ndarray:
    """The loop closure's coarse correlative search (``posegraph.correlative_match``): the
    mean of the flat score table ``lut`` (float32) at the end points' flat indices ``base``
    (T headings, M points) shifted by each of the flat offsets ``shift`` (S,), as (T, S)
    float32, without numpy's (S, M) gather per heading. ``seen`` (the table's shape, 0 or
    1): the mean over the points landing where it is 1 only (``lut`` is then expected zero
    elsewhere), over at least ``min_share`` of the points (the others count as 0)."""
    base = np.ascontiguousarray(base, dtype=np.int64)
    out = np.empty((base.shape[0], shift.size), np.float32)
    flat = np.ascontiguousarray(lut, dtype=np.float32).ravel()
    shift = np.ascontiguousarray(shift, dtype=np.int64)
    if seen is None:
        _grid_scores(flat, base, shift, out)
    else:
        _grid_scores_seen(flat, np.ascontiguousarray(seen, dtype=np.float32).ravel(), base,
                          shift, float(min_share * base.shape[1]), out)
    return out


@njit(cache=True, nogil=True)
def _pose_scores(dist, seen, min_count, x0, y0, res, cand, px, py, sigma, out):
    """Bilinear match scores of the points (px, py; base frame [m]) at each candidate pose
    (rows of ``cand``) in the distance image ``dist`` (h, w) whose cell (0, 0) has its
    corner at (x0, y0): the distance interpolated between cell centres (clamped to the
    image), then exp(-d^2 / 2 sigma^2), averaged over the points. ``seen`` (h, w; or
    (0, 0): everywhere): each point weighted by it, interpolated alike, the sum of the
    weights (at least ``min_count``) the divisor."""
    use_seen = seen.shape[0] > 0
    max_u = dist.shape[1] - 1.001
    max_v = dist.shape[0] - 1.001
    inv_res = 1.0 / res
    k2 = -0.5 / (sigma * sigma)
    n = px.size
    for k in range(cand.shape[0]):
        c = math.cos(cand[k, 2])
        s = math.sin(cand[k, 2])
        u0 = (cand[k, 0] - x0) * inv_res - 0.5
        v0 = (cand[k, 1] - y0) * inv_res - 0.5
        cu = c * inv_res
        su = s * inv_res
        total = 0.0
        count = 0.0
        for m in range(n):
            u = u0 + (cu * px[m] - su * py[m])
            v = v0 + (su * px[m] + cu * py[m])
            if not u >= 0.0:  # NaN too: numba does not check the index
                u = 0.0
            elif u > max_u:
                u = max_u
            if not v >= 0.0:
                v = 0.0
            elif v > max_v:
                v = max_v
            iu = int(u)
            iv = int(v)
            fu = u - iu
            fv = v - iv
            d00 = dist[iv, iu]
            d10 = dist[iv + 1, iu]
            top = d00 + fu * (dist[iv, iu + 1] - d00)
            bottom = d10 + fu * (dist[iv + 1, iu + 1] - d10)
            d = top + fv * (bottom - top)
            if use_seen:
                s00 = seen[iv, iu]
                s10 = seen[iv + 1, iu]
                s_top = s00 + fu * (seen[iv, iu + 1] - s00)
                s_bottom = s10 + fu * (seen[iv + 1, iu + 1] - s10)
                weight = s_top + fv * (s_bottom - s_top)
                total += weight * math.exp(k2 * (d * d))
                count += weight
            else:
                total += math.exp(k2 * (d * d))
        out[k] = total / max(count, min_count) if use_seen else total / n


def pose_scores(dist: np.ndarray, x0: float, y0: float, res: float, cand: np.ndarray,
                pts: np.ndarray, sigma: float, seen: Optional[np.ndarray] = None,
                min_share: float = 0.1) -> np.ndarray:
    """The loop closure's refinement scores (``posegraph._refine``) of the base-frame points
    ``pts`` (M, 2) at the poses ``cand`` (K, 3), one pass per pose, no (K, M) arrays.
    ``seen`` (dist's shape, 0..1): the mean over the points weighted by it (as in
    ``grid_scores``), over at least ``min_share`` of the points."""
    pts = np.asarray(pts, dtype=np.float64)
    out = np.empty(cand.shape[0])
    seen = np.zeros((0, 0), np.float32) if seen is None else seen
    _pose_scores(np.ascontiguousarray(dist, dtype=np.float32),
                 np.ascontiguousarray(seen, dtype=np.float32),
                 float(min_share * pts.shape[0]), float(x0), float(y0),
                 float(res), np.ascontiguousarray(cand, dtype=np.float64),
                 np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]),
                 float(sigma), out)
    return out


def end_points(pts: np.ndarray, res: float) -> Tuple[np.ndarray, np.ndarray]:
    """End points (M, 2, base frame [m]) in cells, float32, as ``rotated`` has them."""
    inv = np.float32(1.0 / res)
    return ((pts[:, 0] * inv).astype(np.float32), (pts[:, 1] * inv).astype(np.float32))


def hill_climb(fields, pts: np.ndarray, prior: np.ndarray, start: np.ndarray,
               particles: np.ndarray, lstep: float, astep: float, iterations: int,
               sigma: float, max_steps: int, along: float = 0.0, along_angle: float = 0.0
               ) -> Tuple[np.ndarray, np.ndarray]:
    """The search (module docstring) for the poses ``start`` (n, 3, map frame) in the maps
    of ``particles`` (n,), end points ``pts`` (M, 2, base frame [m]) in the likelihood
    fields ``fields`` (``rbpf._LikelihoodFields``). Returns the poses (headings not
    wrapped) and their match scores."""
    mx, my = end_points(pts, fields.res)
    n = start.shape[0]
    pose = np.empty((n, 3))
    score = np.empty(n)
    _climb(geometry(fields, sigma), int(fields.band), mx, my,
           np.ascontiguousarray(start, dtype=np.float64),
           np.ascontiguousarray(particles, dtype=np.int64),
           np.asarray(prior, dtype=np.float64), float(along), float(along_angle),
           np.array([lstep, lstep, astep], dtype=np.float64), int(iterations), int(max_steps),
           pose, score)
    return pose, score


def warm_up() -> float:
    """One search on a made-up 8 x 8 field through ``hill_climb`` (so with the argument
    types of a filter update), so that the kernels are loaded from numba's cache, or
    compiled (about 2 s of CPU, once per source change), before the first scan. Returns
    the CPU time it took [s]."""
    t0 = time.process_time()
    counts = np.zeros((1, 4, 4), np.uint8)
    field_image(counts, counts, (0, 0, 4, 4), 6, np.zeros(1 << 16, np.uint8))
    fields = SimpleNamespace(dist=np.zeros(64, np.float32), w=8, h=8, band=8, res=0.05,
                             origin_x=0.0, origin_y=0.0, radius=0.15)
    hill_climb(fields, np.array([[0.15, 0.2]]), np.ones(3), np.zeros((1, 3)),
               np.zeros(1, np.int64), 0.05, 0.05, 1, 0.05, 2)
    for seen in (None, np.ones((8, 8), np.float32)):
        grid_scores(np.zeros(64, np.float32), np.zeros((1, 2), np.int64),
                    np.zeros(3, np.int64), seen)
        pose_scores(np.zeros((8, 8), np.float32), 0.0, 0.0, 0.05, np.zeros((2, 3)),
                    np.zeros((3, 2)), 0.05, seen)
    return time.process_time() - t0
