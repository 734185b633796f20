"""Global path planning on an inflated occupancy grid, as navfn does for move_base (no ROS).

1. ``Costmap``: the occupancy grid is reduced to a coarser planning grid (``resolution``,
   0.1 m by default). Each planning cell keeps the smallest clearance [m] (distance to the
   nearest occupied map cell, from ``cv2.distanceTransform`` on the full-resolution map) of
   the map cells it covers, so the coarse grid never hides an obstacle. Cells where the
   robot's circle grown by ``footprint_padding`` could touch an obstacle's surface (radius +
   padding + 1.2 map cells of centre distance) are lethal; within ``inflation_radius`` the
   step cost grows as costmap_2d's inflation layer does, exp(-cost_scaling_factor (d - r)).
   Unknown cells are allowed (navfn's ``allow_unknown``) at an extra cost.
2. ``plan``: the cost-to-goal of every cell on the 8-connected grid, by chain relaxation.
   Along one straight line of cells the recurrence d[i] = min(d[i], d[i-1] + e[i-1]) has
   the closed form d = S + cummin(d - S) with S the running sum of the step costs e, so a
   whole line is relaxed with two numpy calls; lines in the 8 directions (rows, columns and
   both diagonals, the diagonals as strided views of a sheared buffer) are relaxed in turn
   until nothing changes. That is Bellman-Ford with whole straight runs per round: exact
   (same costs as Dijkstra), and the rounds needed are the turns of the longest optimal
   path, not its length. Integer step costs keep the sums exact, so "nothing changes" is
   detected exactly. The path is then read off by steepest descent from the start.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Optional, Sequence, Tuple

import cv2
import numpy as np
from numpy.lib.stride_tricks import as_strided

from ascc_common.grid import GridInfo
from ascc_common.params import param

OCCUPIED_MIN = 65  # occupancy value [0..100] from which a map cell is an obstacle
UNIT = 1000  # integer cost of one straight step over a free cell
DIAG = 1414  # integer cost of one diagonal step over a free cell (sqrt 2 * UNIT)
LETHAL = 10 ** 12  # step cost into a lethal cell; any sum above it means "no way through"
INF = 2 ** 62  # cost-to-goal of cells not reached (stays far from int64 overflow)
WINDOW_MARGIN = 20  # planning cells round start and goal of the first search window


@dataclass
class PlannerParams:
    """Planner parameters, read as move_base's (``ascc_common.params``; package README)."""

    robot_radius: float = param(0.17, "[m] iRobot Create: 0.33 m diameter",
                                "global_costmap/robot_radius", gt=0.0)
    footprint_padding: float = param(0.05, "[m] extra clearance planned paths keep to "
                                     "obstacles", "global_costmap/footprint_padding", ge=0.0)
    inflation_radius: float = param(0.55, "[m] costs fall to zero at this clearance",
                                    "global_costmap/inflation_layer/inflation_radius")
    cost_scaling_factor: float = param(10.0, "[1/m] decay of the inflation cost",
                                       "global_costmap/inflation_layer/cost_scaling_factor")
    inflation_weight: float = param(5.0, "extra step cost (x free step) right at the robot "
                                    "radius", "stand_in/inflation_weight")
    allow_unknown: bool = param(True, "plan through unknown cells (explore needs it)",
                                "NavfnROS/allow_unknown")
    unknown_cost: float = param(0.5, "extra step cost (x free step) of an unknown cell",
                                "stand_in/unknown_cost")
    resolution: float = param(0.1, "[m] planning grid resolution (>= map resolution)",
                              "stand_in/planner_resolution", gt=0.0)
    default_tolerance: float = param(0.2, "[m] an unreachable goal may move this far to a "
                                     "free cell", "NavfnROS/default_tolerance")
    max_rounds: int = 400  # relaxation rounds at most (a safety net, see ``plan``)


INVALID_GOAL = "invalid_goal"  # off the map, or in an obstacle with no free cell near
INVALID_START = "invalid_start"  # the robot is off the map
UNREACHABLE = "unreachable"  # no path on the current costmap


@dataclass
class PlanResult:
    ok: bool
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (N, 2) [m] world
    cost: float = float("inf")  # [m] equivalent path length (free-space metres)
    reason: str = ""
    rounds: int = 0  # relaxation rounds used
    failure: str = ""  # INVALID_GOAL, INVALID_START or UNREACHABLE when not ok


class Costmap:
    """Planning grid: step costs per cell, lethal mask, world <-> cell conversions.

    ``clearance`` is capped at ``clearance_cap`` [m] (beyond the inflation radius and the
    lethal distance nothing depends on it), so that it can be recomputed in a window: a
    cell's capped clearance only depends on the map cells within the cap. ``updated``
    builds the costmap of a newer map from this one by recomputing only the planning cells
    within the cap of the map cells that changed (equal to building it anew)."""

    def __init__(self, grid: np.ndarray, info: GridInfo, params: Optional[PlannerParams] = None,
                 obstacles: Optional[np.ndarray] = None):
        """``grid`` int8 (height, width) -1/0/100 on ``info``'s geometry; ``obstacles``
        (K, 2) [m] extra obstacle points in the map frame (e.g. from the laser)."""
        p = params or PlannerParams()
        self.params = p
        grid = np.asarray(grid)
        if grid.shape != info.shape or grid.size == 0:
            raise ValueError("occupancy grid of shape %s does not match %r" % (grid.shape, info))
        info.check_axis_aligned()
        self.grid, self.info = grid.copy(), info  # the map this costmap is of
        self.marked = obstacles is not None and len(obstacles) > 0
        occupied = None
        if self.marked:
            occupied = grid >= OCCUPIED_MIN
            col, row = info.world_to_cell(obstacles[:, 0], obstacles[:, 1])
            ok = info.contains(col, row)
            occupied[row[ok], col[ok]] = True
        map_resolution = info.resolution
        # coarse planning grid: f x f map cells per planning cell
        f = max(1, int(round(p.resolution / map_resolution)))
        self.factor = f
        self.resolution = map_resolution * f
        self.origin = (info.origin_x, info.origin_y)
        # clearance is measured between cell centres: an obstacle's surface is half a map
        # cell nearer, and a point of a planning cell (so of a path segment) can be up to
        # half a map cell's diagonal from the nearest map-cell centre it was pooled from
        self.lethal_clearance = p.robot_radius + p.footprint_padding \
            + map_resolution * (0.5 + np.sqrt(0.5))
        # one map cell beyond both thresholds: a capped value compares as an uncapped one
        self.clearance_cap = max(self.lethal_clearance, p.inflation_radius) + map_resolution
        rows, cols = -(-grid.shape[0] // f), -(-grid.shape[1] // f)
        self.clearance = np.empty((rows, cols), dtype=np.float32)  # [m], capped
        self.unknown = np.empty((rows, cols), dtype=bool)
        self.occupied = np.empty((rows, cols), dtype=bool)
        self.lethal = np.empty((rows, cols), dtype=bool)
        self.weight = np.empty((rows, cols), dtype=float)  # x free step cost
        self._fill(grid, occupied, 0, rows, 0, cols)

    def _fill(self, grid: np.ndarray, occupied: Optional[np.ndarray], r0: int, r1: int,
              c0: int, c1: int) -> None:
        """Computes planning cells [r0:r1, c0:c1] from ``grid`` (and ``occupied``, the full
        obstacle mask, if given; else ``grid >= OCCUPIED_MIN``)."""
        p, f, res = self.params, self.factor, self.info.resolution
        height, width = grid.shape
        margin = int(np.ceil(self.clearance_cap / res)) + 1  # map cells an obstacle counts
        mr0, mr1 = r0 * f, min(r1 * f, height)
        mc0, mc1 = c0 * f, min(c1 * f, width)
        wr0, wr1 = max(mr0 - margin, 0), min(mr1 + margin, height)
        wc0, wc1 = max(mc0 - margin, 0), min(mc1 + margin, width)
        occ = grid[wr0:wr1, wc0:wc1] >= OCCUPIED_MIN if occupied is None \
            else occupied[wr0:wr1, wc0:wc1]
        cap = np.float32(self.clearance_cap)
        if occ.any():
            # exact Euclidean distance [cells] up to float rounding, which depends on the
            # image: the squared distance, an integer, is recovered and the root taken
            # from it, so a window gives the same values as the whole map
            cells = cv2.distanceTransform((~occ).astype(np.uint8), cv2.DIST_L2,
                                          cv2.DIST_MASK_PRECISE)
            np.minimum(cells, np.float32(margin), out=cells)
            sq = np.rint(cells * cells)
            clear = np.sqrt(sq) * np.float32(res)
            clear[sq * (res * res) >= self.clearance_cap ** 2] = cap
        else:
            clear = np.full(occ.shape, cap, dtype=np.float32)
        sub = slice(mr0 - wr0, mr1 - wr0), slice(mc0 - wc0, mc1 - wc0)
        n_r, n_c = r1 - r0, c1 - c0
        pad = ((0, n_r * f - (mr1 - mr0)), (0, n_c * f - (mc1 - mc0)))
        clear = np.pad(clear[sub], pad, constant_values=cap)
        unknown = np.pad(grid[mr0:mr1, mc0:mc1] < 0, pad, constant_values=True)
        occ = np.pad(occ[sub], pad, constant_values=False)
        block = slice(r0, r1), slice(c0, c1)
        clearance = clear.reshape(n_r, f, n_c, f).min(axis=(1, 3))
        self.clearance[block] = clearance
        self.unknown[block] = unknown.reshape(n_r, f, n_c, f).all(axis=(1, 3))
        self.occupied[block] = occ.reshape(n_r, f, n_c, f).any(axis=(1, 3))
        lethal = clearance < self.lethal_clearance
        if not p.allow_unknown:
            lethal |= self.unknown[block]
        self.lethal[block] = lethal
        d = np.maximum(clearance - p.robot_radius, 0.0)
        infl = np.where(clearance < p.inflation_radius,
                        p.inflation_weight * np.exp(-p.cost_scaling_factor * d), 0.0)
        self.weight[block] = 1.0 + infl + p.unknown_cost * self.unknown[block]

    def updated(self, grid: np.ndarray, info: GridInfo) -> Costmap:
        """The costmap of ``grid`` (a newer version of this map, same parameters): a new
        object; only the planning cells near changed map cells are recomputed. A map that
        grew by whole planning cells keeps the old cells; other geometry changes, and a
        costmap with laser marks, are built anew."""
        grid = np.asarray(grid)
        f = self.factor
        old = self.info
        shift_c = (old.origin_x - info.origin_x) / info.resolution
        shift_r = (old.origin_y - info.origin_y) / info.resolution
        dc, dr = int(round(shift_c)), int(round(shift_r))
        if (self.marked or grid.shape != info.shape or grid.size == 0
                or abs(info.resolution - old.resolution) > 1e-12 * old.resolution
                or not info.axis_aligned or abs(shift_c - dc) > 1e-6
                or abs(shift_r - dr) > 1e-6 or dc % f or dr % f or dc < 0 or dr < 0
                or dr + old.height > info.height or dc + old.width > info.width):
            return Costmap(grid, info, self.params)
        new = Costmap.__new__(Costmap)
        new.__dict__.update(self.__dict__)
        new.grid, new.info = grid.copy(), info
        rows, cols = -(-grid.shape[0] // f), -(-grid.shape[1] // f)
        pr, pc = dr // f, dc // f
        old_rows, old_cols = self.clearance.shape
        boxes = []  # map-cell boxes (r0, r1, c0, c1) to recompute
        for name in ("clearance", "unknown", "occupied", "lethal", "weight"):
            a = getattr(self, name)
            b = np.empty((rows, cols), dtype=a.dtype)
            b[pr:pr + old_rows, pc:pc + old_cols] = a
            setattr(new, name, b)
        if (rows, cols) != (old_rows, old_cols):  # grown: the new strips, and the old
            # border cells (their padding is now map)
            inner = (dr, dr + old.height, dc, dc + old.width)
            boxes += [(0, inner[0] + f, 0, info.width),
                      (inner[1] - f, info.height, 0, info.width),
                      (0, info.height, 0, inner[2] + f),
                      (0, info.height, inner[3] - f, info.width)]
        changed = grid[dr:dr + old.height, dc:dc + old.width] != self.grid
        rows_hit = np.flatnonzero(changed.any(axis=1))
        if rows_hit.size:
            cols_hit = np.flatnonzero(changed[rows_hit[0]:rows_hit[-1] + 1].any(axis=0))
            boxes.append((dr + rows_hit[0], dr + rows_hit[-1] + 1,
                          dc + cols_hit[0], dc + cols_hit[-1] + 1))
        margin = int(np.ceil(self.clearance_cap / info.resolution)) + 1
        for r0, r1, c0, c1 in boxes:
            r0, c0 = max(r0 - margin, 0) // f, max(c0 - margin, 0) // f
            r1 = min(-(-(r1 + margin) // f), rows)
            c1 = min(-(-(c1 + margin) // f), cols)
            if r0 < r1 and c0 < c1:
                new._fill(grid, None, r0, r1, c0, c1)
        return new

    @property
    def shape(self) -> Tuple[int, int]:
        return self.lethal.shape

    def to_cell(self, xy: Sequence[float]) -> Tuple[int, int]:
        """(row, col) of world point ``xy`` [m] (may be outside the grid)."""
        return (int(np.floor((xy[1] - self.origin[1]) / self.resolution)),
                int(np.floor((xy[0] - self.origin[0]) / self.resolution)))

    def to_world(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World coordinates (N, 2) [m] of cell centres."""
        return np.column_stack([self.origin[0] + (np.asarray(cols) + 0.5) * self.resolution,
                                self.origin[1] + (np.asarray(rows) + 0.5) * self.resolution])

    def inside(self, cell: Tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.shape[0] and 0 <= cell[1] < self.shape[1]

    def is_free_at(self, xy: Sequence[float]) -> bool:
        """True if the robot fits (not lethal) at world point ``xy``."""
        cell = self.to_cell(xy)
        return self.inside(cell) and not self.lethal[cell]

    def nearest_free(self, cell: Tuple[int, int], radius_m: float) -> Optional[Tuple[int, int]]:
        """The closest non-lethal cell within ``radius_m`` of ``cell``, or None."""
        r = int(np.ceil(radius_m / self.resolution))
        r0, r1 = max(cell[0] - r, 0), min(cell[0] + r + 1, self.shape[0])
        c0, c1 = max(cell[1] - r, 0), min(cell[1] + r + 1, self.shape[1])
        if r0 >= r1 or c0 >= c1:
            return None
        rr, cc = np.mgrid[r0:r1, c0:c1]
        dist2 = (rr - cell[0]) ** 2 + (cc - cell[1]) ** 2
        ok = ~self.lethal[r0:r1, c0:c1] & (dist2 <= r * r)
        if not ok.any():
            return None
        i = np.argmin(np.where(ok, dist2, np.iinfo(np.int64).max))
        return int(rr.flat[i]), int(cc.flat[i])


def _relax_lines(d: np.ndarray, e: np.ndarray) -> None:
    """In place: d[i] = min(d[i], min_{j<i} d[j] + e[j] + ... + e[i-1]) along axis 0."""
    s = np.cumsum(e, axis=0)
    s -= e  # exclusive running sum S[i] = e[0] + ... + e[i-1]
    best = np.minimum.accumulate(d - s, axis=0)
    best += s
    np.minimum(d, best, out=d)


class _Sheared:
    """A (rows, cols) grid inside a padded buffer, with views whose columns are lines.

    ``lines()`` yields, for the 8 directions, pairs (distance view, step-cost view) whose
    axis 0 runs along straight lines of cells; padding is lethal, so lines never wrap.
    """

    def __init__(self, cost_straight: np.ndarray, cost_diag: np.ndarray):
        rows, cols = cost_straight.shape
        width = cols + 2 * rows
        self.rows, self.cols, self.width = rows, cols, width
        self.d = np.full((rows, width), INF, dtype=np.int64)
        self.es = np.full((rows, width), LETHAL, dtype=np.int64)
        self.ed = np.full((rows, width), LETHAL, dtype=np.int64)
        self.es[:, rows:rows + cols] = cost_straight
        self.ed[:, rows:rows + cols] = cost_diag

    def core(self, a: np.ndarray) -> np.ndarray:
        return a[:, self.rows:self.rows + self.cols]

    def _diag(self, a: np.ndarray, sign: int) -> np.ndarray:
        """View v[i, k] = a[i, k + sign * i + offset]: columns are diagonals."""
        s0, s1 = a.strides
        offset = 0 if sign > 0 else self.rows
        base = a.ravel()[offset:]
        return as_strided(base, shape=(self.rows, self.cols + self.rows),
                          strides=(s0 + sign * s1, s1), writeable=True)

    def lines(self):
        d, es, ed = self.d, self.es, self.ed
        row_d, row_e = self.core(d).T, self.core(es).T  # axis 0 along a row
        col_d, col_e = self.core(d), self.core(es)
        for vd, ve in ((row_d, row_e), (col_d, col_e),
                       (self._diag(d, 1), self._diag(ed, 1)),
                       (self._diag(d, -1), self._diag(ed, -1))):
            yield vd, ve
            yield vd[::-1], ve[::-1]


def cost_to_goal(costmap: Costmap, goal: Tuple[int, int],
                 max_rounds: int = 400) -> Tuple[np.ndarray, int]:
    """Integer cost-to-goal (rows, cols) of every cell (>= LETHAL: unreachable), rounds."""
    w = costmap.weight
    cs = np.where(costmap.lethal, LETHAL, np.round(UNIT * w)).astype(np.int64)
    cd = np.where(costmap.lethal, LETHAL, np.round(DIAG * w)).astype(np.int64)
    transposed = cs.shape[0] > cs.shape[1]  # keep the padding (2 x rows) small
    if transposed:
        cs, cd, goal = cs.T, cd.T, (goal[1], goal[0])
    grid = _Sheared(cs, cd)
    grid.core(grid.d)[goal] = 0
    rounds = 0
    while rounds < max_rounds:
        rounds += 1
        before = grid.d.copy()
        for vd, ve in grid.lines():
            _relax_lines(vd, ve)
        if np.array_equal(before, grid.d):
            break
    out = grid.core(grid.d).copy()
    return (out.T if transposed else out), rounds


_STEPS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])
_STEP_UNITS = np.where(np.abs(_STEPS).sum(axis=1) == 2, DIAG, UNIT)


def descend(dist: np.ndarray, costmap: Costmap, start: Tuple[int, int],
            goal: Tuple[int, int]) -> np.ndarray:
    """Cells (N, 2) from ``start`` to ``goal``: each step to the neighbour that minimises
    step cost + cost-to-goal (the optimal policy of the converged field)."""
    rows, cols = dist.shape
    pad_d = np.pad(dist, 1, constant_values=INF)
    pad_w = np.pad(np.where(costmap.lethal, np.inf, costmap.weight), 1, constant_values=np.inf)
    cells = [start]
    r, c = start
    for _ in range(rows * cols):
        if (r, c) == goal:
            break
        nr, nc = r + 1 + _STEPS[:, 0], c + 1 + _STEPS[:, 1]
        total = pad_d[nr, nc] + np.round(_STEP_UNITS * pad_w[nr, nc])
        k = int(np.argmin(total))
        if not pad_d[nr[k], nc[k]] < dist[r, c]:
            break  # no descent: cannot happen on a converged field; the caller checks
        r, c = r + int(_STEPS[k, 0]), c + int(_STEPS[k, 1])
        cells.append((r, c))
    return np.array(cells)


def _escape_start(costmap: Costmap, start: Tuple[int, int]) -> None:
    """Lets the robot leave the inflated zone it stands in (cells not truly occupied)."""
    reach = int(np.ceil((costmap.params.robot_radius + 2 * costmap.resolution)
                        / costmap.resolution))
    r0, r1 = max(start[0] - reach, 0), min(start[0] + reach + 1, costmap.shape[0])
    c0, c1 = max(start[1] - reach, 0), min(start[1] + reach + 1, costmap.shape[1])
    block = costmap.lethal[r0:r1, c0:c1]
    soft = block & ~costmap.occupied[r0:r1, c0:c1]
    if soft.any():
        costmap.lethal = costmap.lethal.copy()
        costmap.lethal[r0:r1, c0:c1] = block & ~soft
        costmap.weight = costmap.weight.copy()
        costmap.weight[r0:r1, c0:c1][soft] = 1.0 + costmap.params.inflation_weight


class _Window:
    """The part [r0:r1, c0:c1] of a costmap's step costs (what ``cost_to_goal`` and
    ``descend`` read), as views."""

    def __init__(self, costmap: Costmap, r0: int, r1: int, c0: int, c1: int):
        self.lethal = costmap.lethal[r0:r1, c0:c1]
        self.weight = costmap.weight[r0:r1, c0:c1]


def _octile(r: np.ndarray, c: np.ndarray, cell: Tuple[int, int]) -> np.ndarray:
    """Least integer cost of a walk between cells (r, c) and ``cell`` (step costs are at
    least UNIT straight and DIAG diagonally)."""
    dr, dc = np.abs(r - cell[0]), np.abs(c - cell[1])
    lo = np.minimum(dr, dc)
    return DIAG * lo + UNIT * (np.maximum(dr, dc) - lo)


def _exit_bound(costmap: Costmap, start: Tuple[int, int], goal: Tuple[int, int],
                r0: int, r1: int, c0: int, c1: int) -> float:
    """A lower bound of the cost of every start -> goal walk that leaves [r0:r1, c0:c1]:
    it enters a non-lethal cell of the ring just outside the window (inf if none)."""
    rows, cols = costmap.shape
    ra, rb, ca, cb = max(r0 - 1, 0), min(r1 + 1, rows), max(c0 - 1, 0), min(c1 + 1, cols)
    ring_r, ring_c = [], []
    for edge, r, c in ((r0 > 0, r0 - 1, np.arange(ca, cb)),
                       (r1 < rows, r1, np.arange(ca, cb)),
                       (c0 > 0, np.arange(ra, rb), c0 - 1),
                       (c1 < cols, np.arange(ra, rb), c1)):
        if edge:
            r, c = np.broadcast_arrays(r, c)
            ring_r.append(r)
            ring_c.append(c)
    if not ring_r:
        return float("inf")
    r, c = np.concatenate(ring_r), np.concatenate(ring_c)
    ok = ~costmap.lethal[r, c]
    if not ok.any():
        return float("inf")
    r, c = r[ok], c[ok]
    return float(np.min(_octile(r, c, start) + _octile(r, c, goal)))


def windowed_cost_to_goal(costmap: Costmap, start: Tuple[int, int], goal: Tuple[int, int],
                          max_rounds: int = 400, margin: int = WINDOW_MARGIN):
    """``cost_to_goal`` in a window round start and goal, grown until it is exact.

    The window is the box of start and goal grown by ``margin`` cells; the start's
    cost-to-goal found inside it is the true one, and so is the path ``descend`` reads off,
    when it is lower than ``_exit_bound`` (every walk that leaves the window costs at least
    that): no cell the descent compares can then be reached more cheaply from outside.
    Else the margin is doubled, up to the whole grid. The first margin is small whatever
    the distance: a margin of half the distance (before) made the first window of a goal
    42 m along a corridor span the whole 37 m wide map, for a path that needs a few metres
    (docs/results/ascc_navigation.md, "CPU (navigator)").
    Returns (cost-to-goal of the window, its window, (r0, c0), rounds in all)."""
    rows, cols = costmap.shape
    margin = int(margin)
    total = 0
    while True:
        r0, r1 = max(min(start[0], goal[0]) - margin, 0), \
            min(max(start[0], goal[0]) + margin + 1, rows)
        c0, c1 = max(min(start[1], goal[1]) - margin, 0), \
            min(max(start[1], goal[1]) + margin + 1, cols)
        window = _Window(costmap, r0, r1, c0, c1)
        dist, rounds = cost_to_goal(window, (goal[0] - r0, goal[1] - c0), max_rounds)
        total += rounds
        whole = (r0, r1, c0, c1) == (0, rows, 0, cols)
        cost = dist[start[0] - r0, start[1] - c0]
        if whole or (cost < LETHAL
                     and cost < _exit_bound(costmap, start, goal, r0, r1, c0, c1)):
            return dist, window, (r0, c0), total
        margin *= 2


def plan(costmap: Costmap, start_xy: Sequence[float], goal_xy: Sequence[float]) -> PlanResult:
    """A path from ``start_xy`` to ``goal_xy`` [m], or the reason there is none."""
    start = costmap.to_cell(start_xy)
    goal = costmap.to_cell(goal_xy)
    if not costmap.inside(start):
        return PlanResult(False, reason="robot position (%.2f, %.2f) is outside the map"
                          % (start_xy[0], start_xy[1]), failure=INVALID_START)
    if not costmap.inside(goal):
        return PlanResult(False, reason="goal (%.2f, %.2f) is outside the map"
                          % (goal_xy[0], goal_xy[1]), failure=INVALID_GOAL)
    goal_exact = True
    if costmap.lethal[goal]:
        moved = costmap.nearest_free(goal, costmap.params.default_tolerance)
        if moved is None:
            return PlanResult(False, reason="goal (%.2f, %.2f) is in an obstacle or too close "
                              "to one (no free cell within %.2f m)"
                              % (goal_xy[0], goal_xy[1], costmap.params.default_tolerance),
                              failure=INVALID_GOAL)
        goal, goal_exact = moved, False
    if costmap.lethal[start]:
        costmap = copy.copy(costmap)  # a cached costmap stays as it is
        _escape_start(costmap, start)
    dist, window, (r0, c0), rounds = windowed_cost_to_goal(costmap, start, goal,
                                                           costmap.params.max_rounds)
    start_w, goal_w = (start[0] - r0, start[1] - c0), (goal[0] - r0, goal[1] - c0)
    if dist[start_w] >= LETHAL:
        return PlanResult(False, reason="no path from (%.2f, %.2f) to goal (%.2f, %.2f): the "
                          "goal is not reachable" % (start_xy[0], start_xy[1], goal_xy[0],
                                                     goal_xy[1]), rounds=rounds,
                          failure=UNREACHABLE)
    cells = descend(dist, window, start_w, goal_w) + (r0, c0)
    if tuple(cells[-1]) != tuple(goal):
        return PlanResult(False, reason="path extraction stalled", rounds=rounds,
                          failure=UNREACHABLE)
    pts = costmap.to_world(cells[:, 0], cells[:, 1])
    pts[0] = start_xy[:2]
    if goal_exact:
        pts[-1] = goal_xy[:2]
    return PlanResult(True, pts, float(dist[start_w]) / UNIT * costmap.resolution, "", rounds)


def path_length(path: np.ndarray) -> float:
    """Length [m] of a polyline (N, 2)."""
    if len(path) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
