"""Frontier candidate generation in the thesis's three phases (section 2.3, fig. 2.6).

Input: a trinary int8 grid (see `ascc_common.grid.to_trinary`), its resolution and the
robot's cell.

Phase 1, preliminary generation (`preliminary_generation`): FREE cells with an UNKNOWN
    cell within `neighbourhood_cells` (Chebyshev distance). Cells outside the grid count as
    not unknown: there is nothing to explore beyond the map's edge.
Phase 2, filtering (`filtering`): a phase-1 cell survives if
    - its frontier segment (8-connected component of phase-1 cells) is at least
      `min_frontier_size_m` long (cells x resolution): smaller gaps are noise or too narrow;
    - it is at least `footprint_radius_m` from every OCCUPIED cell (robot footprint fits);
    - it is reachable from the robot through such cells (8-connected flood fill).
Phase 3, grouping (`grouping`): surviving cells of one segment are cut into clusters no
    longer than `cluster_size_m` along the segment's main axis; each cluster's goal point is
    the cell nearest its centroid (within `goal_search_radius_m`) that the robot can stand
    on: reachable, and at least `footprint_radius_m` from occupied AND from unknown cells
    (the unknown right behind a frontier may be a wall). Clusters without such a cell are
    dropped. Clusters without such a cell within `goal_search_radius_m`, and the clusters
    of segments with no reachable cell at all (behind a gap too narrow for the footprint,
    say), get a view point instead: the nearest reachable safe cell within
    `observe_range_m` with a line of sight to the cluster centroid (`observe_only` is True
    for them; 0 disables this, and such clusters are dropped).

Everything is vectorised (OpenCV morphology, flood fill, connected components; numpy on the
sparse frontier cells) and works inside the bounding box of the known cells. Each phase's
wall time is recorded separately in `FrontierResult.timings_ms`; `find_frontiers` composes
the three. No ROS import here.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, Optional, Tuple

import cv2
import numpy as np
from numpy.lib.stride_tricks import as_strided

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN
from ascc_common.params import param

# disk_kernel is imported from here by ascc_eval.report
from .morphology import clear_of, dilate_disk, dilate_disk_stack, disk_kernel  # noqa: F401
from .paths import CoarseGraph, block_size, build_graph, path_lengths

# Outcome of `find_frontiers`; the node publishes it on ~status.
STATUS_OK = "ok"
STATUS_EMPTY_MAP = "empty_map"                     # no cell or no known cell
STATUS_ROBOT_OUTSIDE = "robot_outside_map"         # robot cell not inside the grid
STATUS_ROBOT_BLOCKED = "robot_not_in_free_space"   # no traversable cell near the robot
STATUS_NO_FRONTIERS = "no_frontiers"               # nothing left to explore from here

OFF_MAP = 50                                       # padding value, see _window_view
# grouping: dilate the whole window's unknown cells (instead of patches around the clusters)
# once the patches would cover more than this fraction of the window
NEAR_FULL_FRACTION = 0.25
PHASE1_STRIP_CELLS = 720_000                       # phase1_cells: cells per strip
KNOWN_SCAN_ROWS = 64                               # known_window: rows per band


@dataclass
class FrontierParams:
    """Parameters of the three phases; lengths in metres (``ascc_common.params``)."""

    neighbourhood_cells: int = param(1, "phase 1: unknown cell within this many cells")
    min_frontier_size_m: float = param(0.35, "[m] phase 2: shortest frontier segment kept")
    footprint_radius_m: float = param(0.3, "[m] phase 2: clearance from obstacles (README)")
    robot_snap_radius_m: float = param(0.5, "[m] robot cell moved to the nearest traversable "
                                       "one within this")
    cluster_size_m: float = param(2.0, "[m] phase 3: longest cluster along its segment")
    path_resolution_m: float = param(0.25, "[m] block size of the path-length grid (capped)")
    goal_search_radius_m: float = param(0.6, "[m] phase 3: goal within this of the centroid")
    observe_range_m: float = param(2.5, "[m] unreachable segments: view point within this")
    observe_rays: int = param(72, "rays searched for a view point")

    def validate(self) -> None:
        if self.neighbourhood_cells < 1:
            raise ValueError("neighbourhood_cells must be >= 1")
        for name in ("min_frontier_size_m", "footprint_radius_m", "robot_snap_radius_m",
                     "path_resolution_m", "goal_search_radius_m", "observe_range_m"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name} must be >= 0")
        if self.cluster_size_m <= 0.0:
            raise ValueError("cluster_size_m must be > 0")


@dataclass
class FrontierResult:
    """Candidates after each phase, in full-grid (row, col) cells, plus what phase 2 built.

    `window` = (row0, col0, rows, cols) is the part of the grid that was processed;
    `traversable` (uint8, 255 = free with clearance), the coarse `graph` and `path_m` (path
    length [m] from the robot per coarse block) cover that window.
    """

    status: str
    phase1_rc: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))
    phase2_rc: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))
    goals_rc: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))
    centroids_rc: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.float64))
    cluster_cells: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    observe_only: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    unreachable_rc: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))
    phase2_cluster: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    robot_rc: Optional[Tuple[int, int]] = None
    window: Tuple[int, int, int, int] = (0, 0, 0, 0)
    traversable: Optional[np.ndarray] = None
    graph: Optional[CoarseGraph] = None
    path_m: Optional[np.ndarray] = None
    timings_ms: Dict[str, float] = field(default_factory=dict)

    @property
    def n_candidates(self) -> int:
        return int(self.goals_rc.shape[0])

    def path_length_m(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Path length [m] from the robot to full-grid cells; inf if not reachable.

        A cell is reachable if it is traversable and its coarse block was reached.
        """
        rows = np.atleast_1d(np.asarray(rows, dtype=np.int64))
        cols = np.atleast_1d(np.asarray(cols, dtype=np.int64))
        out = np.full(rows.shape, np.inf)
        if self.traversable is None or self.graph is None or self.path_m is None:
            return out
        r0, c0, h, w = self.window
        lr, lc = rows - r0, cols - c0
        inside = (lr >= 0) & (lr < h) & (lc >= 0) & (lc < w)
        lr, lc = lr[inside], lc[inside]
        d = self.path_m[self.graph.nodes(lr, lc)].astype(np.float64)
        d[self.traversable[lr, lc] == 0] = np.inf
        out[inside] = d
        return out


def _first_known_row(u8: np.ndarray, reverse: bool) -> Optional[int]:
    """Index of the first (last if reverse) row of the uint8 view holding a known cell (a
    byte below 255), or None; read in bands of KNOWN_SCAN_ROWS rows from that end, so that
    only the unknown border and one band are read."""
    n = u8.shape[0]
    band = max(1, KNOWN_SCAN_ROWS)
    for i in range(0, n, band):
        a, b = (max(0, n - i - band), n - i) if reverse else (i, min(n, i + band))
        hit = np.flatnonzero(u8[a:b].min(axis=1) != 255)
        if hit.size:
            return a + int(hit[-1] if reverse else hit[0])
    return None


def known_window(grid: np.ndarray, margin: int) -> Optional[Tuple[int, int, int, int]]:
    """(row0, col0, rows, cols) of the bounding box of known cells grown by margin, or None."""
    # int8 -1 is uint8 255: a row (column) holds a known cell iff its minimum is below 255.
    # Rows are scanned inwards from the top and the bottom in bands (the known rows between
    # are not read for this); the columns' minima come from one sequential pass over the
    # known rows (column bands would touch a page per row each). numpy reductions run
    # several times faster than a mask and cv2.boundingRect.
    u8 = grid.view(np.uint8)
    top = _first_known_row(u8, False)
    if top is None:
        return None
    bottom = _first_known_row(u8, True)
    cols = np.flatnonzero(u8[top: bottom + 1].min(axis=0) != 255)
    r0, c0 = max(0, top - margin), max(0, int(cols[0]) - margin)
    r1 = min(grid.shape[0], bottom + 1 + margin)
    c1 = min(grid.shape[1], int(cols[-1]) + 1 + margin)
    return r0, c0, r1 - r0, c1 - c0


def phase1_mask(sub: np.ndarray, neighbourhood_cells: int) -> np.ndarray:
    """uint8 mask (255) of FREE cells with an UNKNOWN cell within the neighbourhood."""
    u8 = sub.view(np.uint8)
    size = 2 * neighbourhood_cells + 1
    near_unknown = cv2.dilate(cv2.compare(u8, UNKNOWN & 0xFF, cv2.CMP_EQ),
                              np.ones((size, size), np.uint8),
                              borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return cv2.bitwise_and(cv2.compare(u8, FREE, cv2.CMP_EQ), near_unknown)


def phase1_cells(sub: np.ndarray, neighbourhood_cells: int
                 ) -> Tuple[np.ndarray, np.ndarray]:
    """(rows, cols) of `phase1_mask`'s cells, row-major, without any full-size mask: strips
    of rows are compared, dilated and searched while they are in the cache."""
    u8 = sub.view(np.uint8)
    h, w = u8.shape
    n = neighbourhood_cells
    kernel = np.ones((2 * n + 1, 2 * n + 1), np.uint8)
    step = max(1, PHASE1_STRIP_CELLS // max(1, w))
    rows, cols = [np.zeros(0, np.intp)], [np.zeros(0, np.intp)]
    for y0 in range(0, h if w else 0, step):
        y1 = min(h, y0 + step)
        a0, a1 = max(0, y0 - n), min(h, y1 + n)
        # On the grid's bytes (FREE 0, UNKNOWN 255, the largest): the neighbourhood's
        # maximum is 255 iff it holds an UNKNOWN cell, and max - own byte (saturating) is
        # 255 iff moreover the cell itself is FREE; minus 254 (saturating) that is 1, and
        # every other cell 0. One dilation and two subtractions per strip, no masks.
        near = cv2.dilate(u8[a0:a1], kernel, borderType=cv2.BORDER_CONSTANT,
                          borderValue=0)[y0 - a0: y1 - a0]
        cv2.subtract(near, u8[y0:y1], dst=near)
        cv2.subtract(near, 254, dst=near)
        # The 0/1 bytes read as bool: a flat bool array's nonzero() is many times faster
        # than a uint8 or 2-D array's.
        flat = np.flatnonzero(near.view(bool).ravel())
        rows.append(flat // w + y0)
        cols.append(flat % w)
    return np.concatenate(rows), np.concatenate(cols)


def traversable_mask(sub: np.ndarray, radius_cells: float,
                     free: Optional[np.ndarray] = None) -> np.ndarray:
    """uint8 mask (255) of FREE cells at least radius_cells from every OCCUPIED cell.

    `free` (uint8 0/255 mask of sub's FREE cells) may be passed when already computed.
    """
    if radius_cells <= 0.0:
        if free is None:
            free = cv2.compare(sub.view(np.uint8), FREE, cv2.CMP_EQ)
        return free
    # Cells at distance exactly radius are still allowed: dilate by a disc just inside it.
    return clear_of(sub, FREE, OCCUPIED, max(0.0, radius_cells - 1e-6))


def snap_to_mask(mask: np.ndarray, row: int, col: int, radius_cells: int
                 ) -> Optional[Tuple[int, int]]:
    """The nonzero cell of mask closest to (row, col) within radius_cells, or None."""
    h, w = mask.shape
    if 0 <= row < h and 0 <= col < w and mask[row, col]:
        return row, col
    r0, r1 = max(0, row - radius_cells), min(h, row + radius_cells + 1)
    c0, c1 = max(0, col - radius_cells), min(w, col + radius_cells + 1)
    if r0 >= r1 or c0 >= c1:
        return None
    rr, cc = np.nonzero(mask[r0:r1, c0:c1])
    if rr.size == 0:
        return None
    d2 = (rr + r0 - row) ** 2 + (cc + c0 - col) ** 2
    k = int(np.argmin(d2))
    if d2[k] > radius_cells * radius_cells:
        return None
    return int(rr[k] + r0), int(cc[k] + c0)


def label_cells(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Label 8-connected groups of sparse cells (0..n_groups-1 per cell).

    Union-find done with whole-array operations: edges to the E, SW, S and SE neighbour
    (the next key; one binary search for the row below), then rounds of hooking each
    edge's roots onto the smaller one followed by pointer jumping, until every edge joins
    cells of one root.
    """
    n = rows.size
    if n == 0:
        return np.zeros(0, np.int64)
    width = int(cols.max()) + 3
    lin = (rows.astype(np.int64) + 1) * width + (cols.astype(np.int64) + 1)
    order = np.argsort(lin, kind="stable")
    key = lin[order]
    # The keys are sorted and unique: the E neighbour, if any, is the next key; the SW, S
    # and SE neighbours (consecutive keys) follow one another from one binary search.
    east = np.flatnonzero(key[1:] - key[:-1] == 1)
    src, dst = [east], [east + 1]
    pos = np.searchsorted(key, key + (width - 1))
    for off in (width - 1, width, width + 1):
        pos_c = np.minimum(pos, n - 1)
        hit = key[pos_c] == key + off
        src.append(np.flatnonzero(hit))
        dst.append(pos_c[hit])
        pos = pos + hit                          # the next offset's key sits one further
    u, v = np.concatenate(src), np.concatenate(dst)
    parent = np.arange(n, dtype=np.int64)
    while u.size:
        pu, pv = parent[u], parent[v]
        differ = pu != pv
        if not differ.any():
            break
        lo = np.minimum(pu, pv)[differ]
        np.minimum.at(parent, pu[differ], lo)
        np.minimum.at(parent, pv[differ], lo)
        while True:                                   # pointer jumping to the roots
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    # Dense labels in the order of the roots (what np.unique's inverse gives, without its
    # sort): every root is its own parent and the smallest index of its group.
    is_root = parent == np.arange(n)
    labels = np.empty(n, np.int64)
    labels[order] = (np.cumsum(is_root) - 1)[parent]
    return labels


def _unique_inverse(values: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """np.unique(values, return_inverse=True) for small non-negative integers, by a table
    of the values present and its cumulative sum instead of a sort."""
    values = np.asarray(values, dtype=np.int64)
    if values.size == 0:
        return values.copy(), values.copy()
    present = np.zeros(int(values.max()) + 1, bool)
    present[values] = True
    return np.flatnonzero(present), (np.cumsum(present) - 1)[values]


def group_clusters(rows: np.ndarray, cols: np.ndarray, segment: np.ndarray,
                   cluster_cells: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phase 3 on sparse cells: cut each segment along its main axis into pieces no longer
    than cluster_cells.

    Returns (cluster id per cell, centroid (row, col) per cluster as an (n, 2) array,
    cells per cluster).
    """
    seg_ids, seg = _unique_inverse(segment)
    n_seg = seg_ids.size
    r, c = rows.astype(np.float64), cols.astype(np.float64)
    cnt = np.bincount(seg, minlength=n_seg).astype(np.float64)
    mr = np.bincount(seg, r, n_seg) / cnt
    mc = np.bincount(seg, c, n_seg) / cnt
    dr, dc = r - mr[seg], c - mc[seg]
    # Main axis of each segment from its 2x2 covariance (closed-form eigenvector).
    srr = np.bincount(seg, dr * dr, n_seg)
    scc = np.bincount(seg, dc * dc, n_seg)
    src = np.bincount(seg, dr * dc, n_seg)
    theta = 0.5 * np.arctan2(2.0 * src, scc - srr)           # angle from the col axis
    t = dc * np.cos(theta)[seg] + dr * np.sin(theta)[seg]    # position along the axis
    tmin = np.full(n_seg, np.inf)
    tmax = np.full(n_seg, -np.inf)
    np.minimum.at(tmin, seg, t)
    np.maximum.at(tmax, seg, t)
    extent = tmax - tmin + 1.0
    pieces = np.maximum(1, np.ceil(extent / cluster_cells)).astype(np.int64)
    piece = np.minimum(((t - tmin[seg]) / (extent[seg] / pieces[seg])).astype(np.int64),
                       pieces[seg] - 1)
    offsets = np.concatenate(([0], np.cumsum(pieces)[:-1]))
    _, cluster = _unique_inverse(offsets[seg] + piece)
    n_cl = int(cluster.max()) + 1 if cluster.size else 0
    size = np.bincount(cluster, minlength=n_cl)
    cr = np.bincount(cluster, r, n_cl) / size
    cc = np.bincount(cluster, c, n_cl) / size
    return cluster, np.stack([cr, cc], axis=1), size


def disk_offsets(radius_cells: float) -> Tuple[np.ndarray, np.ndarray]:
    """(drow, dcol) of the cells within radius_cells, nearest first."""
    r = max(0, int(math.floor(radius_cells)))
    yy, xx = np.mgrid[-r: r + 1, -r: r + 1]
    d2 = (yy * yy + xx * xx).ravel()
    keep = d2 <= radius_cells * radius_cells + 1e-9
    order = np.argsort(d2[keep], kind="stable")
    return yy.ravel()[keep][order], xx.ravel()[keep][order]


def patches(image: np.ndarray, centres: np.ndarray, half: int, fill=0) -> np.ndarray:
    """(n, 2 half + 1, 2 half + 1) stack of the image around integer (row, col) centres;
    `fill` outside the image. Whole patches are copied row by row from a sliding-window view
    (no index arrays); the few that stick out of the image are clipped one by one."""
    h, w = image.shape
    side = 2 * half + 1
    n = centres.shape[0]
    r0, c0 = centres[:, 0] - half, centres[:, 1] - half
    whole = (r0 >= 0) & (c0 >= 0) & (r0 + side <= h) & (c0 + side <= w)
    if whole.any():
        # numpy 1.17 (Ubuntu 20.04) has no sliding_window_view: the same view by strides.
        s0, s1 = image.strides
        windows = as_strided(image, shape=(h - side + 1, w - side + 1, side, side),
                             strides=(s0, s1, s0, s1), writeable=False)
        if whole.all():                                   # the usual case: no fill needed
            return windows[r0, c0]
    out = np.full((n, side, side), fill, image.dtype)
    if whole.any():
        out[whole] = windows[r0[whole], c0[whole]]
    for i in np.flatnonzero(~whole):
        a0, a1 = max(0, r0[i]), min(h, r0[i] + side)
        b0, b1 = max(0, c0[i]), min(w, c0[i] + side)
        if a0 < a1 and b0 < b1:
            out[i, a0 - r0[i]: a1 - r0[i], b0 - c0[i]: b1 - c0[i]] = image[a0:a1, b0:b1]
    return out


def place_goals(traversable: np.ndarray, sub: np.ndarray, centroids: np.ndarray,
                search_cells: float, radius_cells: float,
                near_unknown: Optional[np.ndarray] = None) -> np.ndarray:
    """Per centroid, the nearest safe cell within search_cells; (-1, -1) if none.

    Safe: traversable and no UNKNOWN cell of sub (the grid window that traversable covers)
    within radius_cells. Works on one small patch per
    centroid (gathered, dilated as one stacked image, so the cost does not depend on the
    map's size); patches overlap-free thanks to a radius_cells margin around the search disc.
    A precomputed `near_unknown` mask (nonzero = unknown within radius_cells) skips that.
    """
    n = centroids.shape[0]
    if n == 0:
        return np.zeros((0, 2), np.int64)
    s_cells = max(0, int(math.floor(search_cells)))
    margin = int(math.ceil(radius_cells)) + 1
    half = s_cells + margin
    side = 2 * half + 1
    base = np.rint(centroids).astype(np.int64)
    if near_unknown is not None:
        near = patches(near_unknown, base, half).reshape(n, side * side)
    else:
        unknown = (patches(sub, base, half) == UNKNOWN).view(np.uint8)    # 0/1
        near = dilate_disk_stack(unknown, max(0.0, radius_cells - 1e-6)
                                 ).reshape(n, side * side)
    dr, dc = disk_offsets(search_cells)
    k = (dr + half) * side + (dc + half)                     # search disc, nearest first
    # Outside the mask the patches hold 0: not traversable, so never valid.
    valid = (near[:, k] == 0) & (patches(traversable, base, half).reshape(n, side * side)[:, k]
                                 > 0)
    first = valid.argmax(axis=1)
    found = valid[np.arange(n), first]
    goals = np.stack([base[:, 0] + dr[first], base[:, 1] + dc[first]], axis=1)
    goals[~found] = -1
    return goals


def view_goals(sub: np.ndarray, traversable: np.ndarray, reachable, centroids: np.ndarray,
               range_cells: float, radius_cells: float, n_rays: int,
               near_unknown: Optional[np.ndarray] = None) -> np.ndarray:
    """View points for frontier clusters the robot cannot reach; (-1, -1) if none.

    Rays go out from each centroid (n_rays, one cell per step, up to range_cells) and stop
    at the first occupied cell, so every sample has a line of sight to the centroid; the
    nearest sample that is traversable, reachable (`reachable(rows, cols)` -> bool) and at
    least radius_cells from UNKNOWN cells of sub is the view point. `near_unknown` (nonzero =
    unknown within radius_cells) may be precomputed for the whole mask; otherwise it is
    computed on one patch per centroid. Steps are searched in chunks, nearest first, and
    clusters drop out of the search once they have a view point.
    """
    h, w = traversable.shape
    n = centroids.shape[0]
    goals = np.full((n, 2), -1, np.int64)
    if n == 0:
        return goals
    steps = max(1, int(math.ceil(range_cells)))
    base = np.rint(centroids).astype(np.int64)
    theta = np.arange(n_rays) * (2.0 * math.pi / n_rays)
    s_all = np.arange(1, steps + 1)
    dr_all = np.rint(np.sin(theta)[None, :] * s_all[:, None]).astype(np.int64)   # (S, R)
    dc_all = np.rint(np.cos(theta)[None, :] * s_all[:, None]).astype(np.int64)
    open_rays = np.ones((n, n_rays), bool)          # no obstacle met yet on the ray
    todo = np.arange(n)
    chunk = max(8, int(math.ceil(radius_cells)) * 3)
    for s0 in range(0, steps, chunk):
        if todo.size == 0:
            break
        s1 = min(steps, s0 + chunk)
        dr, dc = dr_all[s0:s1], dc_all[s0:s1]
        m = todo.size
        # Patches of the window and of the masks around the centroids, covering this chunk
        # of steps (and the footprint around it); the samples are one gather per patch.
        # Outside the window counts as occupied (the ray ends) and not traversable.
        half = s1 + int(math.ceil(radius_cells)) + 1
        side = 2 * half + 1
        k = ((dr + half) * side + (dc + half)).ravel()            # (chunk * R,)
        sp = patches(sub, base[todo], half, fill=OCCUPIED)
        occ = (sp.reshape(m, side * side).take(k, axis=1) == OCCUPIED
               ).reshape(m, s1 - s0, n_rays)
        seen = np.logical_and.accumulate(~occ, axis=1)            # ray still open here
        blocked_before = np.ones_like(occ)
        blocked_before[:, 0] = ~open_rays[todo]
        blocked_before[:, 1:] = ~(seen[:, :-1] & open_rays[todo][:, None, :])
        open_rays[todo] &= seen[:, -1]
        valid = ~blocked_before.reshape(m, -1)
        valid &= patches(traversable, base[todo], half).reshape(m, side * side).take(
            k, axis=1) > 0
        if near_unknown is not None:
            near = patches(near_unknown, base[todo], half).reshape(m, side * side)
        else:
            unk = (sp == UNKNOWN).view(np.uint8)                   # 0/1
            near = dilate_disk_stack(unk, max(0.0, radius_cells - 1e-6)
                                     ).reshape(m, side * side)
        valid &= near.take(k, axis=1) == 0
        cand = np.nonzero(valid)
        c_r = base[todo[cand[0]], 0] + dr.ravel()[cand[1]]
        c_c = base[todo[cand[0]], 1] + dc.ravel()[cand[1]]
        ok = reachable(c_r, c_c)
        valid[cand[0][~ok], cand[1][~ok]] = False
        first = valid.argmax(axis=1)                              # nearest step first
        found = valid[np.arange(m), first]
        goals[todo[found], 0] = base[todo[found], 0] + dr.ravel()[first[found]]
        goals[todo[found], 1] = base[todo[found], 1] + dc.ravel()[first[found]]
        todo = todo[~found]
    return goals


def _aligned_window(grid_shape: Tuple[int, int], window: Tuple[int, int, int, int],
                    multiple: int) -> Tuple[int, int, int, int]:
    """Grow a window to a multiple of `multiple` cells, inside the grid when possible."""
    r0, c0, h, w = window
    out = []
    for start, size, limit in ((r0, h, grid_shape[0]), (c0, w, grid_shape[1])):
        size2 = -(-size // multiple) * multiple
        start = min(start, max(0, limit - size2))
        out.append((start, size2))
    return out[0][0], out[1][0], out[0][1], out[1][1]


def _window_view(grid: np.ndarray, window: Tuple[int, int, int, int]) -> np.ndarray:
    """grid[window], padded where the window sticks out of a small grid with OFF_MAP: not
    free, unknown or occupied, so the map's edge stays no frontier and no obstacle."""
    r0, c0, h, w = window
    sub = grid[r0: r0 + h, c0: c0 + w]
    if sub.shape != (h, w):
        padded = np.full((h, w), OFF_MAP, np.int8)
        padded[: sub.shape[0], : sub.shape[1]] = sub
        sub = padded
    return sub


@dataclass
class Preliminary:
    """Phase 1's output: the processed window of the grid and its frontier cells.

    Cells are window-local (row, col); `segment` labels each cell's 8-connected segment.
    """

    window: Tuple[int, int, int, int]    # (row0, col0, rows, cols) in the full grid
    sub: np.ndarray                      # the grid inside the window (OFF_MAP padded)
    rows: np.ndarray
    cols: np.ndarray
    segment: np.ndarray


@dataclass
class Filtered:
    """Phase 2's output: which phase-1 cells survive, and the reachability it computed."""

    robot: Tuple[int, int]               # window-local robot cell, snapped to traversable
    traversable: np.ndarray              # uint8 255 = free with footprint clearance
    graph: CoarseGraph
    path_m: np.ndarray                   # path length [m] from the robot per coarse block
    keep: np.ndarray                     # per phase-1 cell: survives the filter
    far: np.ndarray                      # per phase-1 cell: long enough, segment unreachable

    def reachable(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """bool per window-local cell: its coarse block was reached from the robot."""
        return np.isfinite(self.path_m[self.graph.nodes(rows, cols)])


@dataclass
class Grouped:
    """Phase 3's output: one goal per kept cluster (window-local cells)."""

    goals: np.ndarray                    # (n, 2) goal cells
    centroids: np.ndarray                # (n, 2) cluster centroids
    cluster_cells: np.ndarray            # cells per cluster
    observe_only: np.ndarray             # goal is a view point, not on the frontier
    phase2_cluster: np.ndarray           # per surviving (phase-2) cell: its goal, or -1


def preliminary_generation(grid: np.ndarray, neighbourhood_cells: int, margin: int,
                           tile: int) -> Optional[Preliminary]:
    """Phase 1: FREE cells with UNKNOWN within neighbourhood_cells, and their segments.

    Works on the bounding box of the known cells grown by `margin` and aligned to `tile`
    (the coarse graph's blocks divide it); None if the grid has no known cell.
    """
    window = known_window(grid, margin)
    if window is None:
        return None
    window = _aligned_window(grid.shape, window, tile)
    sub = _window_view(grid, window)
    rows, cols = phase1_cells(sub, neighbourhood_cells)
    return Preliminary(window, sub, rows, cols, label_cells(rows, cols))


def filtering(pre: Preliminary, robot: Tuple[int, int], resolution: float,
              p: FrontierParams, block: int) -> Optional[Filtered]:
    """Phase 2: keep phase-1 cells of long enough segments, with footprint clearance,
    reachable from the robot (window-local cell, snapped within robot_snap_radius_m);
    path lengths come out of it (coarse graph of `block` cells). None if the robot has no
    traversable cell nearby.
    """
    radius_cells = p.footprint_radius_m / resolution
    trav = traversable_mask(pre.sub, radius_cells)
    snap = snap_to_mask(trav, robot[0], robot[1],
                        int(math.ceil(p.robot_snap_radius_m / resolution)))
    if snap is None:
        return None
    graph = build_graph(trav, block)
    dist = path_lengths(graph, graph.node(*snap), resolution)
    segment = pre.segment
    seg_len_m = np.bincount(segment).astype(np.float64) * resolution
    size_ok = seg_len_m[segment] >= p.min_frontier_size_m - 1e-9
    keep = size_ok & (trav[pre.rows, pre.cols] > 0)
    keep &= np.isfinite(dist[graph.nodes(pre.rows, pre.cols)])
    # Segments without a single reachable cell (e.g. behind a gap too narrow for the
    # footprint) are not candidates, but may be looked at from a reachable view point.
    far = np.zeros(pre.rows.size, bool)
    if p.observe_range_m > 0.0 and pre.rows.size:
        seg_reached = np.bincount(segment, weights=keep.astype(np.float64)) > 0
        far = size_ok & ~seg_reached[segment]
    return Filtered(snap, trav, graph, dist, keep, far)


def grouping(pre: Preliminary, filt: Filtered, resolution: float,
             p: FrontierParams) -> Grouped:
    """Phase 3: clusters along each segment, goal = safe cell nearest the cluster centroid
    (or a view point, see the module docstring); clusters without a goal are dropped."""
    radius_cells = p.footprint_radius_m / resolution
    keep, far, segment = filt.keep, filt.far, pre.segment
    p2_r, p2_c, seg = pre.rows[keep], pre.cols[keep], segment[keep]
    trav = filt.traversable
    cluster_len = p.cluster_size_m / resolution
    cluster = np.zeros(0, np.int64)
    centroids, size = np.zeros((0, 2)), np.zeros(0, np.int64)
    f_centroids, f_size = np.zeros((0, 2)), np.zeros(0, np.int64)
    if p2_r.size:
        cluster, centroids, size = group_clusters(p2_r, p2_c, seg, cluster_len)
    if far.any():
        _, f_centroids, f_size = group_clusters(pre.rows[far], pre.cols[far], segment[far],
                                                cluster_len)
    # Unknown within the footprint radius: on small patches around each cluster, or once
    # for the whole window when the patches would cover more than a twentieth of it.
    near_full = None
    patch_area = (size.size * (2 * (p.goal_search_radius_m / resolution + radius_cells)) ** 2
                  + f_size.size * (2 * (p.observe_range_m / resolution + radius_cells)) ** 2)
    if patch_area > NEAR_FULL_FRACTION * pre.sub.size:
        unknown = cv2.compare(pre.sub.view(np.uint8), UNKNOWN & 0xFF, cv2.CMP_EQ)
        near_full = dilate_disk(unknown, max(0.0, radius_cells - 1e-6))
    # Goal: nearest cell to the centroid that is reachable and keeps the whole footprint in
    # known space (>= footprint radius from unknown cells too: the unknown just behind a
    # frontier may be a wall), searched within goal_search_radius_m.
    goals = place_goals(trav, pre.sub, centroids, p.goal_search_radius_m / resolution,
                        radius_cells, near_full)
    # Clusters without such a cell nearby (a narrow space behind the frontier) and the
    # unreachable segments' clusters get a view point with a line of sight instead.
    if p.observe_range_m > 0.0:
        missing = np.nonzero(goals[:, 0] < 0)[0]
        look = np.concatenate([centroids[missing], f_centroids])
        looked = view_goals(
            pre.sub, trav, filt.reachable,
            look, p.observe_range_m / resolution, radius_cells, p.observe_rays, near_full)
        goals[missing] = looked[: missing.size]
        f_goals = looked[missing.size:]
    else:
        missing = np.zeros(0, np.int64)
        f_goals = np.full((0, 2), -1, np.int64)
    observe = np.zeros(size.size + f_size.size, bool)
    observe[missing] = True
    observe[size.size:] = True
    centroids = np.concatenate([centroids, f_centroids])
    size = np.concatenate([size, f_size])
    goals = np.concatenate([goals, f_goals])
    found = goals[:, 0] >= 0
    found[found] = filt.reachable(goals[found, 0], goals[found, 1])
    kept = np.nonzero(found)[0]
    relabel = np.full(size.size, -1, np.int64)
    relabel[kept] = np.arange(kept.size)
    return Grouped(goals[kept], centroids[kept], size[kept], observe[kept], relabel[cluster])


def find_frontiers(grid: np.ndarray, resolution: float, robot_rc: Tuple[int, int],
                   params: Optional[FrontierParams] = None) -> FrontierResult:
    """Run the three phases on a trinary grid; never raises on bad maps or robot poses."""
    p = params or FrontierParams()
    p.validate()
    grid = np.ascontiguousarray(grid, dtype=np.int8)
    if grid.ndim != 2 or grid.size == 0 or not resolution > 0.0:
        return FrontierResult(STATUS_EMPTY_MAP)
    rr, rc = int(robot_rc[0]), int(robot_rc[1])
    if not (0 <= rr < grid.shape[0] and 0 <= rc < grid.shape[1]):
        return FrontierResult(STATUS_ROBOT_OUTSIDE)
    times: Dict[str, float] = {}
    radius_cells = p.footprint_radius_m / resolution
    k = block_size(resolution, p.footprint_radius_m, p.path_resolution_m)
    tile = k * max(1, int(round(16 / k)))                 # window: a multiple of k

    t0 = time.perf_counter()
    margin = p.neighbourhood_cells + int(math.ceil(radius_cells)) + 1
    pre = preliminary_generation(grid, p.neighbourhood_cells, margin, tile)
    if pre is None:
        return FrontierResult(STATUS_EMPTY_MAP, timings_ms={"phase1": 0.0})
    times["phase1"] = (time.perf_counter() - t0) * 1e3
    r0, c0 = pre.window[0], pre.window[1]
    result = FrontierResult(STATUS_OK, window=pre.window, timings_ms=times)
    result.phase1_rc = np.stack([pre.rows + r0, pre.cols + c0], axis=1).astype(np.int32)

    t0 = time.perf_counter()
    filt = filtering(pre, (rr - r0, rc - c0), resolution, p, k)
    times["phase2"] = (time.perf_counter() - t0) * 1e3
    if filt is None:
        result.status = STATUS_ROBOT_BLOCKED
        return result
    result.robot_rc = (filt.robot[0] + r0, filt.robot[1] + c0)
    result.traversable, result.graph, result.path_m = filt.traversable, filt.graph, filt.path_m
    keep, far = filt.keep, filt.far
    result.phase2_rc = np.stack([pre.rows[keep] + r0, pre.cols[keep] + c0],
                                axis=1).astype(np.int32)
    result.unreachable_rc = np.stack([pre.rows[far] + r0, pre.cols[far] + c0],
                                     axis=1).astype(np.int32)

    t0 = time.perf_counter()
    if not keep.any() and not far.any():
        times["phase3"] = (time.perf_counter() - t0) * 1e3
        result.status = STATUS_NO_FRONTIERS
        return result
    groups = grouping(pre, filt, resolution, p)
    result.goals_rc = (groups.goals + np.array([r0, c0])).astype(np.int32)
    result.centroids_rc = groups.centroids + np.array([r0, c0], dtype=np.float64)
    result.cluster_cells = groups.cluster_cells
    result.observe_only = groups.observe_only
    result.phase2_cluster = groups.phase2_cluster
    if groups.goals.shape[0] == 0:
        result.status = STATUS_NO_FRONTIERS
    times["phase3"] = (time.perf_counter() - t0) * 1e3
    return result
