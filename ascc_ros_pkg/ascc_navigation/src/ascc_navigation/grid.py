"""Grid algorithms of the mapper, the localizer and the navigator: gmapping's cell rule,
sampling along segments, ray casting, and map-vs-truth agreement.

Grids, their geometry (``GridInfo``) and cell values come from ``ascc_common.grid``
(arrays indexed ``[iy, ix]``, row 0 at the origin). No ROS imports.
"""

from __future__ import annotations

import functools
import math
from typing import Optional, Tuple

import numpy as np

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo

RAYCAST_BISECT_STEPS = 6  # refinement of ray-cast ranges: step / 64


def _cell_rule(hits: np.ndarray, visits: np.ndarray, occ_thresh: float) -> np.ndarray:
    out = np.full(visits.shape, FREE, dtype=np.int8)
    out[hits.astype(np.float32) > np.float32(occ_thresh) * visits.astype(np.float32)] = OCCUPIED
    out[visits == 0] = UNKNOWN
    return out


@functools.lru_cache(maxsize=4)
def count_table(occ_thresh: float) -> np.ndarray:
    """The cell rule for every pair of uint8 counts: int8 table indexed visits << 8 | hits."""
    visits, hits = np.divmod(np.arange(1 << 16), 1 << 8)
    table = _cell_rule(hits, visits, occ_thresh)
    table.flags.writeable = False
    return table


def occupancy_from_counts(hits: np.ndarray, visits: np.ndarray, occ_thresh: float) -> np.ndarray:
    """gmapping's cell rule: unknown if never visited, else occupied iff hits/visits > occ_thresh.

    ``hits``/``visits`` are integer count arrays of one shape; returns an int8 -1/0/100 grid.
    uint8 counts (the mapper's) are looked up in ``count_table``: one pass over the grid,
    about a sixth of the comparison's time (the map is published every few seconds).
    """
    if hits.dtype != np.uint8 or visits.dtype != np.uint8:
        return _cell_rule(hits, visits, occ_thresh)
    key = visits.astype(np.uint16)
    key <<= 8
    key |= hits
    return count_table(float(occ_thresh)).take(key)


def sample_segments(x0, y0, x1, y1, step: float,
                    include_end: bool = False) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every ``step`` [m] along each segment (x0,y0)->(x1,y1), all segments at once.

    Broadcasts scalars against arrays (e.g. one start point, many end points). Returns
    ``(xs, ys, seg)`` where ``seg`` holds the index of the segment each point belongs to. The
    end point itself is included only with ``include_end``. Used to trace free space along
    laser beams: a cell the segment crosses for less than ``step`` may be skipped, so choose
    ``step`` well below the resolution when every cell matters.
    """
    x0, y0, x1, y1 = np.broadcast_arrays(*(np.asarray(v, dtype=float).ravel()
                                           for v in (x0, y0, x1, y1)))
    length = np.hypot(x1 - x0, y1 - y0)
    inner = np.ceil(length / step - 1e-9).astype(np.int64)  # samples k*step < length
    counts = inner + (1 if include_end else 0)
    seg = np.repeat(np.arange(x0.size), counts)
    # position of each sample inside its own segment: 0, 1, 2, ...
    starts = np.cumsum(counts) - counts
    k = np.arange(seg.size) - np.repeat(starts, counts)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(length[seg] > 0.0, k * step / length[seg], 1.0)
    frac = np.minimum(frac, 1.0)  # the extra sample of include_end is the end point itself
    xs = x0[seg] + frac * (x1[seg] - x0[seg])
    ys = y0[seg] + frac * (y1[seg] - y0[seg])
    return xs, ys, seg


def raycast(occupied: np.ndarray, info: GridInfo, x: float, y: float, angles,
            max_range: float, step: Optional[float] = None) -> np.ndarray:
    """Range [m] to the first occupied cell along each ray from (x, y); ``inf`` if none.

    ``occupied`` is a boolean (height, width) grid; cells outside it count as free. Rays are
    marched in steps of ``step`` (default resolution/4), all rays and steps at once, then the
    crossing into the occupied cell is bisected, so ranges are exact to step/64 (a wall thinner
    than ``step`` can be missed). A ray starting inside an occupied cell has range 0.
    Handy for simulating scans and for expected-range models.
    """
    angles = np.asarray(angles, dtype=float).ravel()
    if step is None:
        step = info.resolution / 4.0
    t = np.arange(0.0, max_range + step, step)
    t = t[t <= max_range + 1e-12]
    px = x + np.outer(np.cos(angles), t)
    py = y + np.outer(np.sin(angles), t)
    ix, iy = info.world_to_cell(px, py)
    inside = info.contains(ix, iy)
    hit = np.zeros(ix.shape, dtype=bool)
    hit[inside] = occupied[iy[inside], ix[inside]]
    found = hit.any(axis=1)
    first = np.argmax(hit, axis=1)
    # The cell boundary lies between the last free sample and the first occupied one:
    # bisect that interval (all rays at once) down to step / 2**BISECT_STEPS.
    lo = t[np.maximum(first - 1, 0)]
    hi = t[first]
    c = np.cos(angles)
    s = np.sin(angles)
    for _ in range(RAYCAST_BISECT_STEPS):
        mid = 0.5 * (lo + hi)
        mx, my = info.world_to_cell(x + c * mid, y + s * mid)
        ok = info.contains(mx, my)
        occ = np.zeros(mid.shape, dtype=bool)
        occ[ok] = occupied[my[ok], mx[ok]]
        hi = np.where(occ, mid, hi)
        lo = np.where(occ, lo, mid)
    return np.where(found & (first > 0), hi, np.where(found, 0.0, np.inf))


def map_agreement(estimate: np.ndarray, est_info: GridInfo, truth: np.ndarray,
                  truth_info: GridInfo, offset=(0.0, 0.0, 0.0)) -> dict:
    """Compare a -1/0/100 map with ground truth, cell by cell.

    Every cell the estimate marks known (0 or 100) is looked up in the truth grid at its
    centre, mapped through ``offset`` = (x [m], y [m], yaw [rad]), the pose of the
    estimate's frame in the truth's frame (e.g. the robot's start pose for a SLAM map).
    Returns a dict:
      ``known``: estimated known cells that fall on known truth cells (the compared set);
      ``agree``: how many of those have the same value; ``accuracy`` = agree/known;
      ``free_accuracy`` / ``occupied_accuracy``: the same restricted to estimated free /
      occupied cells; ``unmatched``: estimated known cells that fall outside the truth grid or
      on its unknown cells (not compared, reported so nothing hides).
    """
    iy, ix = np.nonzero(estimate != UNKNOWN)
    est_vals = estimate[iy, ix]
    wx, wy = est_info.cell_to_world(ix, iy)
    ox, oy = float(offset[0]), float(offset[1])
    yaw = float(offset[2]) if len(offset) > 2 else 0.0
    c, s = math.cos(yaw), math.sin(yaw)
    tx, ty = truth_info.world_to_cell(ox + c * wx - s * wy, oy + s * wx + c * wy)
    inside = truth_info.contains(tx, ty)
    truth_vals = np.full(est_vals.shape, UNKNOWN, dtype=np.int8)
    truth_vals[inside] = truth[ty[inside], tx[inside]]
    compared = truth_vals != UNKNOWN
    agree = compared & (truth_vals == est_vals)
    result = {"known": int(compared.sum()), "agree": int(agree.sum()),
              "unmatched": int((~compared).sum())}
    result["accuracy"] = result["agree"] / result["known"] if result["known"] else float("nan")
    for name, value in (("free", FREE), ("occupied", OCCUPIED)):
        sel = compared & (est_vals == value)
        n = int(sel.sum())
        result[name + "_cells"] = n
        result[name + "_accuracy"] = float((agree & sel).sum()) / n if n else float("nan")
    return result
