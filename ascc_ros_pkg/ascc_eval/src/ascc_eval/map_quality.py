"""Map quality against a world's floor plan, as the thesis reports it (2.5.2, figs. 2.11-2.12).

    rosrun ascc_eval map_quality MAP.yaml --world WORLD.yaml [--map-pose X Y YAW]
        [--png OUT.png] [--json OUT.json] [--no-placement] [--tiles M]

MAP.yaml is a saved map (map_server format: ``rosrun map_server map_saver``, or a
benchmark's ``*_explored.yaml``); WORLD.yaml an ascc_sim world, whose map is the floor
plan (walls and built-in obstacles; furniture is not part of it). ``--map-pose`` is the
pose of the map's frame in the world's frame; by default the world's first robot's start
pose (a mapper started with the robot: gmapping's map frame = odom at start). Use
``--map-pose 0 0 0`` for maps already in the world's frame (``*_explored.yaml``).

Prints:
  * agreement: the map's known cells against the world's truth (walls, obstacles and
    furniture), ``ascc_navigation.grid.map_agreement``;
  * walls seen: the floor plan's wall faces (occupied cells with a free 4-neighbour) that
    the map knows, and how many of those it marks occupied: at the cell, and within
    ``wall_tolerance_cells``;
  * best placement (``best_placement``; ``--no-placement`` skips it): the rigid pose near
    ``--map-pose`` at which the most of the map's known cells agree with the truth, that
    share there and at ``--map-pose``, and the walls there. A map whose frame ended up
    off (a mapper's estimate shifted early in the run) but whose shape is right agrees
    poorly at ``--map-pose`` and well there. The agreement and walls above stay those at
    ``--map-pose``: the map as the robot uses it;
  * sides: the outline of the free space connected to the start (outer boundary and
    holes, e.g. the corridor loop's outer and inner walls), simplified to a polygon
    (``cv2.approxPolyDP``, recesses and counters shallower than ``side_epsilon_m``
    ignored; edges shorter than ``min_side_m`` dropped). Along each polygon edge a line is
    fitted to the wall faces within ``band_m`` of it, on the floor plan and on the map
    alike (RANSAC for the largest straight face within ``inlier_m``, then total least
    squares; the edge's ends, where the next wall starts, are left out). A side's length
    runs between the intersections with its neighbours' lines, on both; so do the corner
    angles (interior angle of the outline, degrees);
  * with ``--tiles M``, where each part of the map lies off its true place
    (``local_placements``): the map cut into M-metre tiles, each placed on its own; each
    tile's displacement (map minus plan, metres). A side mapped 0.2 m too long shows as
    every tile after it displaced by 0.2 m;
  * and writes a PNG of the map over the floor plan: plan walls grey, map occupied red,
    map free light blue, fitted sides (plan green, map blue), corners, and with
    ``--tiles`` each tile's displacement as a purple arrow (``ARROW_GAIN`` times its
    length).

No ROS import (the command runs without a master).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional, Sequence, Tuple

import cv2
import numpy as np

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_common.map_io import MapError, load_map
from ascc_common.params import param
from ascc_navigation.grid import map_agreement

from .report import compose, reachable_area, resample


@dataclass
class QualityParams:
    """Outline simplification and line fitting (``ascc_common.params``)."""

    side_epsilon_m: float = param(0.7, "[m] outline simplification: recesses shallower "
                                  "than this are not sides")
    min_side_m: float = param(2.0, "[m] outline edges shorter than this are not sides")
    band_m: float = param(1.0, "[m] wall faces within this of a side are fitted to it")
    inlier_m: float = param(0.15, "[m] refit on the faces within this of the first fit")
    end_margin_m: float = param(0.5, "[m] a side's ends left out of its fit (corners)")
    min_points: int = param(20, "fewer faces than this: side not measured")
    wall_tolerance_cells: int = param(1, "wall faces also count within this many cells")
    placement_search_m: float = param(1.0, "[m] best placement: farthest shift tried from "
                                      "the map's given pose, in x and in y", ge=0.0)
    placement_search_rad: float = param(0.035, "[rad] best placement: farthest turn tried",
                                        ge=0.0)


@dataclass
class Line:
    """A fitted line: a point on it and its unit direction, world metres."""

    point: np.ndarray
    direction: np.ndarray
    n_points: int = 0
    rms_m: float = 0.0

    def intersect(self, other: Line) -> Optional[np.ndarray]:
        d1, d2 = self.direction, other.direction
        den = d1[0] * d2[1] - d1[1] * d2[0]
        if abs(den) < 1e-9:
            return None
        diff = other.point - self.point
        t = (diff[0] * d2[1] - diff[1] * d2[0]) / den
        return self.point + t * d1


@dataclass
class Outline:
    """One closed boundary of the free space: polygon vertices (world m) and, per edge
    i (vertex i -> i + 1), the plan's and the map's fitted lines (None: not measured)."""

    vertices: np.ndarray
    plan_lines: List[Optional[Line]] = field(default_factory=list)
    map_lines: List[Optional[Line]] = field(default_factory=list)

    def corners(self, lines: Sequence[Optional[Line]]) -> List[Optional[np.ndarray]]:
        """Corner k joins side k - 1 and side k."""
        n = len(lines)
        out = []
        for k in range(n):
            a, b = lines[k - 1], lines[k]
            out.append(None if a is None or b is None else a.intersect(b))
        return out

    def side_lengths(self, lines: Sequence[Optional[Line]]) -> List[Optional[float]]:
        c = self.corners(lines)
        n = len(lines)
        return [None if c[k] is None or c[(k + 1) % n] is None
                else float(np.hypot(*(c[(k + 1) % n] - c[k]))) for k in range(n)]

    def corner_angles_deg(self, lines: Sequence[Optional[Line]]) -> List[Optional[float]]:
        """Interior angle at corner k, from the turn between sides k - 1 and k (the lines'
        directions follow the outline)."""
        out = []
        sign = 1.0 if _signed_area(self.vertices) > 0 else -1.0
        for k in range(len(lines)):
            a, b = lines[k - 1], lines[k]
            if a is None or b is None:
                out.append(None)
                continue
            turn = math.atan2(a.direction[0] * b.direction[1] - a.direction[1] * b.direction[0],
                              float(a.direction @ b.direction))
            out.append(180.0 - sign * math.degrees(turn))
        return out


def _signed_area(v: np.ndarray) -> float:
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def wall_faces(grid: np.ndarray) -> np.ndarray:
    """Boolean mask: OCCUPIED cells with a FREE 4-neighbour (the faces a laser sees)."""
    free = (grid == FREE).astype(np.uint8)
    cross = np.array([[0, 1, 0], [1, 0, 1], [0, 1, 0]], np.uint8)
    near_free = cv2.dilate(free, cross, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return (grid == OCCUPIED) & (near_free > 0)


def face_points(grid: np.ndarray, info: GridInfo) -> np.ndarray:
    """(N, 2) world positions [m] of a grid's wall-face cell centres."""
    rows, cols = np.nonzero(wall_faces(grid))
    x, y = info.cell_to_world(cols, rows)
    return np.stack([np.atleast_1d(x), np.atleast_1d(y)], axis=1)


def outlines(plan: np.ndarray, info: GridInfo, start_xy: Tuple[float, float],
             p: QualityParams) -> List[Outline]:
    """The boundaries of the plan's free space connected to start_xy, as polygons whose
    edges are at least min_side_m long (world metres)."""
    reach = reachable_area(plan, info, start_xy, clearance_m=0.0).astype(np.uint8)
    found = cv2.findContours(reach, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    contours = found[-2]
    out = []
    for c in contours:
        approx = cv2.approxPolyDP(c, p.side_epsilon_m / info.resolution, True)[:, 0, :]
        x, y = info.cell_to_world(approx[:, 0], approx[:, 1])
        v = np.stack([np.atleast_1d(x), np.atleast_1d(y)], axis=1)
        v = _drop_short_edges(v, p.min_side_m)
        if v.shape[0] >= 3:
            out.append(Outline(v))
    return out


def _drop_short_edges(v: np.ndarray, min_len: float) -> np.ndarray:
    """Remove edges shorter than min_len: the vertex pair is replaced by the intersection
    of the neighbouring edges' lines (or their midpoint if parallel), until none is left."""
    v = v.copy()
    while v.shape[0] >= 3:
        n = v.shape[0]
        lens = np.hypot(*(np.roll(v, -1, axis=0) - v).T)
        k = int(np.argmin(lens))
        if lens[k] >= min_len:
            break
        a0, a1 = v[k - 1], v[k]                      # edge before
        b0, b1 = v[(k + 1) % n], v[(k + 2) % n]      # edge after
        pa = Line(a0, (a1 - a0) / max(np.hypot(*(a1 - a0)), 1e-9))
        pb = Line(b0, (b1 - b0) / max(np.hypot(*(b1 - b0)), 1e-9))
        x = pa.intersect(pb)
        if x is None or np.hypot(*(x - 0.5 * (a1 + b0))) > 2.0 * min_len:
            x = 0.5 * (a1 + b0)
        keep = [i for i in range(n) if i not in (k, (k + 1) % n)]
        insert = keep.index(k - 1 if k > 0 else n - 1) + 1
        v = np.insert(v[keep], insert, x, axis=0)
    return v


def fit_side(points: np.ndarray, a: np.ndarray, b: np.ndarray, p: QualityParams,
             ransac_tries: int = 300) -> Optional[Line]:
    """Line through the wall faces along segment a -> b (direction kept from a to b).

    The faces within band_m of the segment (its ends left out) go into a RANSAC (pairs of
    faces, lines within 20 deg of the segment, the most faces within inlier_m wins; seeded,
    so repeatable), then total least squares on that line's inliers, twice. The largest
    straight face wins over a counter or a pillar in front of the wall.
    """
    length = float(np.hypot(*(b - a)))
    if length <= 2.0 * p.end_margin_m:
        return None
    u = (b - a) / length
    normal = np.array([-u[1], u[0]])
    rel = points - a
    t, d = rel @ u, rel @ normal
    sel = (np.abs(d) <= p.band_m) & (t >= p.end_margin_m) & (t <= length - p.end_margin_m)
    pts = points[sel]
    if pts.shape[0] < p.min_points:
        return None
    rng = np.random.default_rng(0)
    i, j = rng.integers(0, pts.shape[0], (2, ransac_tries))
    dirs = pts[j] - pts[i]
    norm = np.hypot(dirs[:, 0], dirs[:, 1])
    ok = (norm > 1e-9)
    ok[ok] = np.abs(dirs[ok] @ u) / norm[ok] >= math.cos(math.radians(20.0))
    if not ok.any():
        return None
    i, dirs, norm = i[ok], dirs[ok], norm[ok]
    nrm = np.stack([-dirs[:, 1], dirs[:, 0]], axis=1) / norm[:, None]
    # distance of every face to every sampled line: |n_k . (p - p_k)|
    dist = np.abs(pts @ nrm.T - np.einsum("kj,kj->k", nrm, pts[i])[None, :]).T
    inl = dist <= p.inlier_m
    inliers = pts[inl[int(np.argmax(inl.sum(axis=1)))]]
    line = None
    for _ in range(2):
        if inliers.shape[0] < p.min_points:
            return None
        centre = inliers.mean(axis=0)
        _, _, vt = np.linalg.svd(inliers - centre, full_matrices=False)
        direction = vt[0] if float(vt[0] @ u) >= 0.0 else -vt[0]
        line = Line(centre, direction)
        n_line = np.array([-direction[1], direction[0]])
        inliers = pts[np.abs((pts - centre) @ n_line) <= p.inlier_m]
    assert line is not None
    n_line = np.array([-line.direction[1], line.direction[0]])
    resid = (inliers - line.point) @ n_line
    return Line(line.point, line.direction, int(inliers.shape[0]),
                float(np.sqrt(np.mean(resid ** 2))) if resid.size else 0.0)


def wall_agreement(plan: np.ndarray, plan_info: GridInfo, grid: np.ndarray,
                   map_info: GridInfo, tolerance_cells: int) -> Dict[str, float]:
    """The plan's wall faces the map knows (`seen`), and of those the fraction the map
    marks OCCUPIED at the face (`exact`) and within tolerance_cells (`within`).
    map_info must be in the plan's frame."""
    rows, cols = np.nonzero(wall_faces(plan))
    x, y = plan_info.cell_to_world(cols, rows)
    mx, my = map_info.world_to_cell(np.atleast_1d(x), np.atleast_1d(y))
    h, w = grid.shape
    inside = (mx >= 0) & (mx < w) & (my >= 0) & (my < h)
    vals = np.full(rows.size, UNKNOWN, np.int8)
    vals[inside] = grid[my[inside], mx[inside]]
    occ = (grid == OCCUPIED).astype(np.uint8)
    size = 2 * max(0, tolerance_cells) + 1
    occ_near = cv2.dilate(occ, np.ones((size, size), np.uint8))
    known = (grid != UNKNOWN).astype(np.uint8)
    known_near = cv2.dilate(known, np.ones((size, size), np.uint8))
    seen = np.zeros(rows.size, bool)
    seen[inside] = known_near[my[inside], mx[inside]] > 0
    within = np.zeros(rows.size, bool)
    within[inside] = occ_near[my[inside], mx[inside]] > 0
    n_seen = int(seen.sum())
    return {"faces": int(rows.size), "seen": n_seen,
            "seen_fraction": n_seen / rows.size if rows.size else float("nan"),
            "exact": float((seen & (vals == OCCUPIED)).sum()) / n_seen if n_seen else float("nan"),
            "within": float((seen & within).sum()) / n_seen if n_seen else float("nan")}


def agreed_share(agreement: Dict[str, float]) -> float:
    """Of a ``map_agreement`` result: the map's known cells that agree with the truth, the
    ones off the truth's known area counted as disagreeing (nan for an empty map)."""
    total = agreement["known"] + agreement["unmatched"]
    return agreement["agree"] / total if total else float("nan")


# best_placement's pattern search: first steps [m, m, rad], halved this many times (the
# last: 1.25 cm and 0.03 deg, a quarter of a 5 cm cell at 25 m)
PLACEMENT_STEP = (0.2, 0.2, 0.008)
PLACEMENT_HALVINGS = 4


def best_placement(grid: np.ndarray, info: GridInfo, truth: np.ndarray, truth_info: GridInfo,
                   map_pose: Tuple[float, float, float] = (0.0, 0.0, 0.0),
                   params: Optional[QualityParams] = None) -> Dict[str, object]:
    """Where the map fits the truth best: the rigid pose of the map's frame, within
    ``placement_search_m`` / ``_rad`` of ``map_pose``, that maximises ``agreed_share``
    (the map's known cells that agree with the truth, cells off the truth's known area
    counted as disagreeing, so that no placement gains by pushing cells off it); a pattern
    search (each coordinate stepped both ways while the share rises, then the steps
    halved). A SLAM map's frame is anchored by the mapper's first poses: a map whose shape
    is right but whose frame ended up a few decimetres off (the whole estimate shifted
    early in the run) disagrees with the plan along every wall. The share there, against
    the one at ``map_pose``, says how much of the disagreement is the frame's place and how
    much the map's shape. Returns ``pose``, ``offset`` (pose - map_pose: x, y [m], yaw
    [rad]), ``agreed_share`` there and ``agreed_share_given`` at ``map_pose``."""
    p = params or QualityParams()
    start = np.asarray(map_pose, float)
    bound = np.array([p.placement_search_m, p.placement_search_m, p.placement_search_rad])

    def share(pose):
        return agreed_share(map_agreement(grid, info, truth, truth_info, tuple(pose)))

    pose, best = start.copy(), share(start)
    given = best
    step = np.asarray(PLACEMENT_STEP, float)
    for _ in range(PLACEMENT_HALVINGS + 1):
        improved = True
        while improved:
            improved = False
            for k in range(3):
                for sign in (-1.0, 1.0):
                    trial = pose.copy()
                    trial[k] += sign * step[k]
                    if abs(trial[k] - start[k]) > bound[k] + 1e-12:
                        continue
                    a = share(trial)
                    if a > best:
                        pose, best, improved = trial, a, True
        step = step / 2.0
    offset = pose - start
    return {"pose": [float(v) for v in pose], "offset": [float(v) for v in offset],
            "agreed_share": float(best), "agreed_share_given": float(given)}


def local_placements(grid: np.ndarray, info: GridInfo, truth: np.ndarray, truth_info: GridInfo,
                     map_pose: Tuple[float, float, float] = (0.0, 0.0, 0.0),
                     tile_m: float = 10.0, min_known_share: float = 0.05,
                     params: Optional[QualityParams] = None) -> List[Dict[str, object]]:
    """Where each part of the map fits the truth best: the map's grid cut into square tiles
    of ``tile_m`` (an unrotated grid's at whole multiples of it in its frame), each tile with at
    least ``min_known_share`` of a whole tile's cells known placed on its own
    (``best_placement``, translation only: a turn about the map's frame would move a far
    tile by the turn times its distance). A map whose frame is right but whose shape is
    not (a side mapped too long moves every wall after it) shows, tile by tile, how far and
    which way each part of it lies off its true place. Along a straight corridor with no
    feature a tile's shift along it is not observable: the search then leaves it at zero.
    Returns one dict per tile: ``centre`` (x, y of the tile's known cells' centre, in the
    truth's frame [m]), ``known`` (cells), ``displacement`` (the tile's place in the map
    minus its place in the truth, x and y [m]: the opposite of the shift that fits it),
    ``share`` (its known cells that agree there) and ``share_given`` (at ``map_pose``)."""
    p = params or QualityParams()
    p_local = replace(p, placement_search_rad=0.0)
    n = max(1, int(round(tile_m / info.resolution)))
    known = grid != UNKNOWN
    height, width = grid.shape

    def edges(origin, size):
        first = int(round((math.ceil(origin / tile_m - 1e-9) * tile_m - origin)
                          / info.resolution)) % n
        return sorted({0, size} | set(range(first, size, n)))

    tiles = []
    rows_e, cols_e = edges(info.origin_y, height), edges(info.origin_x, width)
    for r0, r1 in zip(rows_e[:-1], rows_e[1:]):
        for c0, c1 in zip(cols_e[:-1], cols_e[1:]):
            tile_known = known[r0:r1, c0:c1]
            k = int(tile_known.sum())
            if k == 0 or k < min_known_share * n * n:
                continue
            sub_info = info.grown(-c0, -r0, c1 - width, r1 - height)   # the tile's cells
            pl = best_placement(grid[r0:r1, c0:c1], sub_info, truth, truth_info, map_pose,
                                p_local)
            rows, cols = np.nonzero(tile_known)
            x, y = compose(map_pose, sub_info).cell_to_world(cols, rows)
            tiles.append({"centre": [float(np.mean(x)), float(np.mean(y))],
                          "known": k,
                          "displacement": [-pl["offset"][0], -pl["offset"][1]],
                          "share": pl["agreed_share"], "share_given": pl["agreed_share_given"]})
    return tiles


@dataclass
class Quality:
    agreement: Dict[str, float]
    walls: Dict[str, float]
    outlines: List[Outline]
    # best_placement, with the wall agreement there (None: not searched)
    placement: Optional[Dict[str, object]] = None
    # local_placements (None: not searched)
    tiles: Optional[List[Dict[str, object]]] = None

    def sides(self) -> List[Dict[str, object]]:
        rows = []
        for i, o in enumerate(self.outlines):
            lp, lm = o.side_lengths(o.plan_lines), o.side_lengths(o.map_lines)
            ap, am = o.corner_angles_deg(o.plan_lines), o.corner_angles_deg(o.map_lines)
            for k in range(len(o.plan_lines)):
                pm, mm = lp[k], lm[k]
                rows.append({"outline": i, "side": k, "plan_m": pm, "map_m": mm,
                             "error_pct": (None if pm is None or mm is None or not pm
                                           else 100.0 * (mm - pm) / pm),
                             "corner": k, "plan_deg": ap[k], "map_deg": am[k]})
        return rows

    def outer_index(self) -> Optional[int]:
        """Index of the outer boundary: the outline enclosing the largest area."""
        if not self.outlines:
            return None
        return int(np.argmax([abs(_signed_area(o.vertices)) for o in self.outlines]))

    def outer_side_errors_pct(self) -> List[Optional[float]]:
        """Each side of the outer boundary: map minus plan length, in % of the plan's
        (None where a side was not measured)."""
        k = self.outer_index()
        return [r["error_pct"] for r in self.sides() if r["outline"] == k]


def measure(grid: np.ndarray, info: GridInfo, plan: np.ndarray, plan_info: GridInfo,
            truth: np.ndarray, start_xy: Tuple[float, float],
            map_pose: Tuple[float, float, float] = (0.0, 0.0, 0.0),
            params: Optional[QualityParams] = None, place: bool = False,
            tile_m: Optional[float] = None) -> Quality:
    """All numbers for a map (grid, info in its own frame at map_pose in the plan's frame);
    with ``place``, also its ``best_placement`` and the walls' agreement there (the
    sides and corners do not depend on the placement); with ``tile_m``, its tiles'
    ``local_placements``."""
    p = params or QualityParams()
    minfo = compose(map_pose, info)
    agreement = map_agreement(grid, info, truth, plan_info, map_pose)
    walls = wall_agreement(plan, plan_info, grid, minfo, p.wall_tolerance_cells)
    plan_pts = face_points(plan, plan_info)
    map_pts = face_points(grid, minfo)
    outs = outlines(plan, plan_info, start_xy, p)
    for o in outs:
        n = o.vertices.shape[0]
        for k in range(n):
            a, b = o.vertices[k], o.vertices[(k + 1) % n]
            o.plan_lines.append(fit_side(plan_pts, a, b, p))
            o.map_lines.append(fit_side(map_pts, a, b, p))
    placement = None
    if place:
        placement = best_placement(grid, info, truth, plan_info, map_pose, p)
        placement["walls"] = wall_agreement(plan, plan_info, grid,
                                            compose(tuple(placement["pose"]), info),
                                            p.wall_tolerance_cells)
    tiles = None
    if tile_m is not None:
        tiles = local_placements(grid, info, truth, plan_info, map_pose, tile_m, params=p)
    return Quality(agreement, walls, outs, placement, tiles)


def _fmt(v: Optional[float], spec: str) -> str:
    return "-" if v is None else format(v, spec)


def report_lines(q: Quality) -> List[str]:
    a, w = q.agreement, q.walls
    lines = [f"agreement: {100 * a['accuracy']:.1f} % of {a['known']} known cells "
             f"(free {100 * a['free_accuracy']:.1f} %, occupied "
             f"{100 * a['occupied_accuracy']:.1f} %, {a['unmatched']} off the truth)",
             f"walls seen: {w['seen']} of {w['faces']} wall-face cells "
             f"({100 * w['seen_fraction']:.1f} %); occupied in the map: "
             f"{100 * w['exact']:.1f} % at the cell, {100 * w['within']:.1f} % within tolerance",
             "outline side   plan_m    map_m  diff_m  diff_%  | corner  plan_deg  map_deg  "
             "diff_deg"]
    if q.placement is not None:
        pl = q.placement
        dx, dy, dyaw = pl["offset"]
        pw = pl["walls"]
        lines.insert(2, f"best placement: {100 * pl['agreed_share']:.1f} % of all known cells "
                        f"agree (here {100 * pl['agreed_share_given']:.1f} %) with the map "
                        f"moved by ({dx:+.3f}, {dy:+.3f}) m and {math.degrees(dyaw):+.2f} deg; "
                        f"walls occupied there: {100 * pw['exact']:.1f} % at the cell, "
                        f"{100 * pw['within']:.1f} % within tolerance")
    for r in q.sides():
        pm, mm, pd, md = r["plan_m"], r["map_m"], r["plan_deg"], r["map_deg"]
        dm = None if pm is None or mm is None else mm - pm
        dp = r["error_pct"]
        dd = None if pd is None or md is None else md - pd
        lines.append(f"{r['outline']:7d} {r['side']:4d} {_fmt(pm, '8.2f')} {_fmt(mm, '8.2f')} "
                     f"{_fmt(dm, '7.2f')} {_fmt(dp, '7.2f')}  | {r['corner']:6d} "
                     f"{_fmt(pd, '9.1f')} {_fmt(md, '8.1f')} {_fmt(dd, '9.2f')}")
    if q.tiles is not None:
        lines.append("tile   centre_x centre_y  known  map-plan_x map-plan_y  agree_%  "
                     "agree_there_%")
        for i, t in enumerate(q.tiles):
            lines.append(f"{i:4d} {t['centre'][0]:10.2f} {t['centre'][1]:8.2f} "
                         f"{t['known']:6d} {t['displacement'][0]:+11.3f} "
                         f"{t['displacement'][1]:+10.3f} {100 * t['share_given']:8.1f} "
                         f"{100 * t['share']:14.1f}")
    return lines


# the overlay draws each tile's displacement this many times its length
ARROW_GAIN = 20.0


def write_overlay(path: str, q: Quality, grid: np.ndarray, info: GridInfo, plan: np.ndarray,
                  plan_info: GridInfo, map_pose: Tuple[float, float, float],
                  max_side_px: int = 1600) -> None:
    """PNG of the map over the floor plan (north up), fitted sides and corners; the longer
    side max_side_px pixels (small maps enlarged at most 4x)."""
    on_plan = resample(grid, compose(map_pose, info), plan_info, plan.shape)
    img = np.full(plan.shape + (3,), 215, np.uint8)                  # BGR, unknown
    img[plan == FREE] = (255, 255, 255)
    img[plan == OCCUPIED] = (110, 110, 110)
    img[on_plan == FREE] = (250, 225, 200)
    img[on_plan == OCCUPIED] = (30, 30, 220)
    scale = min(4.0, max_side_px / max(plan.shape))       # small maps enlarged, up to 4x
    if scale != 1.0:
        img = cv2.resize(img, (int(round(plan.shape[1] * scale)),
                               int(round(plan.shape[0] * scale))),
                         interpolation=cv2.INTER_AREA if scale < 1.0 else cv2.INTER_NEAREST)
    img = np.ascontiguousarray(img[::-1])                             # row 0 = top

    def px(xy: np.ndarray) -> Tuple[int, int]:
        cx, cy = plan_info.world_to_cell(float(xy[0]), float(xy[1]))
        return int(round(cx * scale)), int(round(img.shape[0] - 1 - cy * scale))

    thick = max(1, int(round(scale)))
    for o in q.outlines:
        for lines, colour in ((o.plan_lines, (40, 170, 40)), (o.map_lines, (200, 80, 0))):
            corners = o.corners(lines)
            n = len(lines)
            for k in range(n):
                a, b = corners[k], corners[(k + 1) % n]
                if a is not None and b is not None:
                    cv2.line(img, px(a), px(b), colour, thick, cv2.LINE_AA)
            for c in corners:
                if c is not None:
                    cv2.circle(img, px(c), 3 * thick, colour, thick, cv2.LINE_AA)
    for t in q.tiles or []:       # each tile's displacement, map minus plan, ARROW_GAIN x
        a = np.asarray(t["centre"], float)
        b = a + ARROW_GAIN * np.asarray(t["displacement"], float)
        cv2.circle(img, px(a), 2 * thick, (160, 0, 160), -1, cv2.LINE_AA)
        if np.hypot(*(b - a)) > 1e-9:
            cv2.arrowedLine(img, px(a), px(b), (160, 0, 160), thick, cv2.LINE_AA,
                            tipLength=0.25)
    if not cv2.imwrite(path, img):
        raise OSError(f"cannot write {path}")


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="map_quality", description=__doc__.split("\n\n")[0])
    ap.add_argument("map_yaml", help="the saved map (map_server YAML)")
    ap.add_argument("--world", required=True, help="ascc_sim world YAML (floor plan + start)")
    ap.add_argument("--map-pose", nargs=3, type=float, metavar=("X", "Y", "YAW"),
                    help="pose of the map's frame in the world [m, m, rad] (default: the "
                    "world's first robot's start pose)")
    ap.add_argument("--png", help="overlay PNG (default: MAP_quality.png beside the map)")
    ap.add_argument("--json", help="also write the numbers as JSON here")
    ap.add_argument("--no-placement", action="store_true",
                    help="skip the search for the map's best placement (a few seconds)")
    ap.add_argument("--tiles", type=float, metavar="M",
                    help="also place the map's square tiles of M metres each on its own and "
                    "print each tile's displacement, map minus plan (local_placements; the "
                    "overlay draws them as arrows, %g times their length)" % ARROW_GAIN)
    args = ap.parse_args(argv)
    from ascc_sim.world import WorldError, load_world  # ascc_sim: only for the command
    try:
        world = load_world(args.world)
        grid, info = load_map(args.map_yaml)
    except (WorldError, MapError, OSError) as e:
        print(f"map_quality: {e}", file=sys.stderr)
        return 2
    start = world.robots[0].pose if world.robots else None
    if args.map_pose is not None:
        pose = tuple(args.map_pose)
    elif start is not None:
        pose = (start.x, start.y, start.yaw)
    else:
        pose = (0.0, 0.0, 0.0)
    start_xy = (start.x, start.y) if start is not None else pose[:2]
    plan, pinfo = world.map.occupancy, world.map.info
    q = measure(grid, info, plan, pinfo, world.truth_map.occupancy, start_xy, pose,
                place=not args.no_placement, tile_m=args.tiles)
    print(f"map {args.map_yaml}: {grid.shape[1]} x {grid.shape[0]} cells at "
          f"{info.resolution} m, frame at ({pose[0]:.3f}, {pose[1]:.3f}, {pose[2]:.4f}) in "
          f"world {world.name}")
    for line in report_lines(q):
        print(line)
    png = args.png or (args.map_yaml.rsplit(".", 1)[0] + "_quality.png")
    write_overlay(png, q, grid, info, plan, pinfo, pose)
    print(f"overlay: {png}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"agreement": q.agreement, "walls": q.walls, "sides": q.sides(),
                       "placement": q.placement, "tiles": q.tiles}, f, indent=1)
    return 0
