"""Exploration reports: coverage against a ground truth, path length, PNG writers.

Coverage (`coverage`): the reachable area of a ground-truth map is the set of its FREE
cells the robot's footprint can occupy when its centre moves from the start through cells
at least `clearance_m` from every occupied cell (8-connected), i.e. that set of centres
dilated by clearance_m again (clearance_m = 0: all FREE cells connected to the start). A
reachable cell is covered when the explored map marks it known (FREE or OCCUPIED; a
thick-walled map still covers the room). Maps may differ in origin and resolution: truth
cells are compared at their centres' world positions.

That map coverage also measures the SLAM map's accuracy: where the map has drifted (0.4 m
after a 100 m loop), the truth's cells along the walls fall outside the mapped corridor.
**Seen coverage** (`SeenArea`) measures the exploration alone: a reachable truth cell is
seen once a ray of the laser (`LaserGeometry`: range, field of view, mount), cast from the
robot's *true* pose through the truth, has reached it. Map accuracy is measured separately
(ascc_navigation.grid.map_agreement).

Writers use matplotlib's Agg backend (no display needed): `write_map_png` (map, robot path,
goals, candidates, robot), `write_coverage_plot` (coverage vs time, one curve per run).
`ExplorationRecord` collects a whole run (maps, true poses, goals, bumps) and writes its
summary JSON and both PNGs; `compose` puts a map's geometry into the truth's frame.
No ROS import.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Sequence, Tuple

import cv2
import numpy as np

from ascc_common import pose2d
from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_common.map_io import save_map
from ascc_common.params import param
from ascc_common.pose2d import wrap_angle
from frontier_detector.frontiers import disk_kernel, snap_to_mask, traversable_mask


def reachable_area(truth: np.ndarray, info: GridInfo, start_xy: Tuple[float, float],
                   clearance_m: float = 0.18, snap_m: float = 0.5) -> np.ndarray:
    """Boolean mask over `truth`: FREE cells the robot's footprint can reach from start."""
    truth = np.ascontiguousarray(truth, dtype=np.int8)
    radius = clearance_m / info.resolution
    centres = traversable_mask(truth, radius)
    ix, iy = info.world_to_cell(*start_xy)
    snap = snap_to_mask(centres, iy, ix, int(math.ceil(snap_m / info.resolution)))
    if snap is None:
        return np.zeros(truth.shape, bool)
    mask = np.zeros((truth.shape[0] + 2, truth.shape[1] + 2), np.uint8)
    flags = 8 | cv2.FLOODFILL_MASK_ONLY | cv2.FLOODFILL_FIXED_RANGE | (255 << 8)
    cv2.floodFill(centres, mask, (snap[1], snap[0]), 0, 0, 0, flags)
    reached = mask[1:-1, 1:-1]
    if radius > 0.0:
        reached = cv2.dilate(reached, disk_kernel(radius))
    return (reached > 0) & (truth == FREE)


def coverage(explored: np.ndarray, explored_info: GridInfo, truth: np.ndarray,
             truth_info: GridInfo, start_xy: Tuple[float, float], clearance_m: float = 0.18,
             reachable: Optional[np.ndarray] = None) -> float:
    """Fraction [0, 1] of the truth's reachable area that the explored map knows.

    Pass a precomputed `reachable` (from reachable_area) when calling this repeatedly.
    """
    if reachable is None:
        reachable = reachable_area(truth, truth_info, start_xy, clearance_m)
    rows, cols = np.nonzero(reachable)
    if rows.size == 0:
        return 0.0
    x, y = truth_info.cell_to_world(cols, rows)
    ex, ey = explored_info.world_to_cell(x, y)
    h, w = explored.shape
    inside = (ey >= 0) & (ey < h) & (ex >= 0) & (ex < w)
    known = np.zeros(rows.size, bool)
    vals = explored[ey[inside], ex[inside]]
    known[inside] = (vals == FREE) | (vals == OCCUPIED)
    return float(np.count_nonzero(known)) / float(rows.size)


def scan_truth(truth: np.ndarray, known: np.ndarray, rc: Tuple[int, int], heading: float,
               range_cells: int, fov: float, n_rays: int) -> None:
    """Copy truth into known along rays from cell rc until (and including) the first obstacle.

    `n_rays` rays spread evenly over `fov` [rad] around `heading` [rad], each `range_cells`
    long; cells off the map end a ray.
    """
    h, w = truth.shape
    theta = heading + np.linspace(-fov / 2.0, fov / 2.0, n_rays)
    s = np.arange(0, range_cells + 1)
    rr = np.rint(rc[0] + np.sin(theta)[:, None] * s[None, :]).astype(np.int64)
    cc = np.rint(rc[1] + np.cos(theta)[:, None] * s[None, :]).astype(np.int64)
    inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    vals = np.where(inside, truth[rr.clip(0, h - 1), cc.clip(0, w - 1)], OCCUPIED)
    occ = vals == OCCUPIED
    before = np.zeros_like(occ)
    before[:, 1:] = np.logical_or.accumulate(occ, axis=1)[:, :-1]
    seen = inside & ~before
    known[rr[seen], cc[seen]] = truth[rr[seen], cc[seen]]


@dataclass
class MonitorParams:
    """The exploration_monitor node's parameters (private)."""

    robot: str = param("asccbot", "robot name in ground_truth/<robot>/...")
    label: str = param("exploration", "run label (file names, plots)")
    output_dir: Optional[str] = param(None, "directory of the report files (unset: "
                                            "~out_dir)")
    out_dir: str = param("", "older name of ~output_dir (\"\": no files)")
    max_time_s: float = param(0.0, "[s] end the run after this much time; 0: no limit")
    shutdown_when_finished: bool = param(True, "exit when the run ends")
    clearance_m: float = param(0.18, "[m] footprint radius for the reachable area")
    progress_period_s: float = param(10.0, "[s wall] period of the progress log line")
    file_stem: str = param("", "stem of the report files (\"\": the file-safe label)")
    robot_frame: str = param("base_link", "frame of the truth pose (the laser's mount)")
    period_s: float = param(1.0, "[s] coverage period")
    count_bumps: bool = param(True, "count bumper hits from the driver's sensorPacket (false: "
                                    "not subscribed, so the driver builds no packets for the "
                                    "monitor, as in CPU measurements; bumps null)")
    map_pose_in_truth: Optional[List[float]] = param(
        None, "[m, m, rad] the explored map's frame in the truth frame (unset: the robot's "
              "start pose)", length=3)

    def output_directory(self) -> str:
        """``output_dir``, unset: ``out_dir``."""
        return self.out_dir if self.output_dir is None else self.output_dir


@dataclass
class LaserGeometry:
    """What the laser can see: range [m], field of view [rad], mount ahead of the robot's
    centre [m]. Defaults: the Hokuyo URG-04LX as ascc_sim models it (the monitor reads the
    real values from the scan and TF)."""

    range_m: float = 4.094
    fov_rad: float = math.radians(240.0)
    offset_x_m: float = 0.05


class SeenArea:
    """Seen coverage: which reachable truth cells the laser has reached from true poses.

    `add(x, y, yaw)` casts the laser's rays through the truth (one ray per half cell at full
    range, so no cell within range is skipped) when the robot moved at least `min_move_m`
    or turned at least `min_turn_rad` since the last cast; `coverage()` is the seen share
    of `reach` (a mask over the truth, see reachable_area).
    """

    def __init__(self, truth: np.ndarray, info: GridInfo, reach: np.ndarray,
                 laser: LaserGeometry, min_move_m: float = 0.1, min_turn_rad: float = 0.1):
        self.truth, self.info, self.reach, self.laser = truth, info, reach, laser
        self.min_move_m, self.min_turn_rad = min_move_m, min_turn_rad
        self.known = np.full(truth.shape, UNKNOWN, np.int8)
        self.range_cells = max(1, int(math.ceil(laser.range_m / info.resolution)))
        self.n_rays = max(2, int(math.ceil(2.0 * laser.fov_rad * self.range_cells)) + 1)
        self.last: Optional[Tuple[float, float, float]] = None
        self.casts = 0

    def add(self, x: float, y: float, yaw: float) -> bool:
        """Cast from the true pose (x, y, yaw) of the robot; True if it cast."""
        if self.last is not None:
            lx, ly, lyaw = self.last
            turn = abs(wrap_angle(yaw - lyaw))
            if math.hypot(x - lx, y - ly) < self.min_move_m and turn < self.min_turn_rad:
                return False
        self.last = (x, y, yaw)
        lx = x + self.laser.offset_x_m * math.cos(yaw)
        ly = y + self.laser.offset_x_m * math.sin(yaw)
        ix, iy = self.info.world_to_cell(lx, ly)
        scan_truth(self.truth, self.known, (iy, ix), yaw,
                   self.range_cells, self.laser.fov_rad, self.n_rays)
        self.casts += 1
        return True

    def coverage(self) -> float:
        n = int(np.count_nonzero(self.reach))
        if n == 0:
            return 0.0
        return float(np.count_nonzero(self.reach & (self.known != UNKNOWN))) / float(n)


def path_length(xy: Sequence[Sequence[float]]) -> float:
    """Length [m] of a polyline of (x, y) points."""
    a = np.asarray(xy, dtype=float).reshape(-1, 2)
    if a.shape[0] < 2:
        return 0.0
    return float(np.hypot(*np.diff(a, axis=0).T).sum())


def time_to_coverage(times_s: Sequence[float], cover: Sequence[float],
                     levels: Iterable[float] = (0.90, 0.95, 0.99)) -> Dict[float, Optional[float]]:
    """First time [s] each coverage level is reached (None if never)."""
    t = np.asarray(times_s, dtype=float)
    c = np.asarray(cover, dtype=float)
    out: Dict[float, Optional[float]] = {}
    for level in levels:
        hit = np.nonzero(c >= level - 1e-12)[0]
        out[level] = float(t[hit[0]]) if hit.size else None
    return out


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def map_image(grid: np.ndarray) -> np.ndarray:
    """Grey image of a trinary grid (free white, unknown grey, occupied black), row 0 first."""
    img = np.full(grid.shape, 0.8, dtype=np.float32)
    img[grid == FREE] = 1.0
    img[grid == OCCUPIED] = 0.0
    img[(grid != FREE) & (grid != OCCUPIED) & (grid != UNKNOWN)] = 0.5
    return img


def write_map_png(path: str, grid: np.ndarray, info: GridInfo,
                  path_xy: Optional[Sequence[Sequence[float]]] = None,
                  goals_xy: Optional[Sequence[Sequence[float]]] = None,
                  candidates_xy: Optional[Sequence[Sequence[float]]] = None,
                  robot_xy: Optional[Tuple[float, float]] = None, title: str = "") -> None:
    """Map with the robot's path (blue), goals sent (numbered red circles), candidates
    (orange dots) and the robot (green triangle), in map metres (unrotated origin)."""
    plt = _pyplot()
    h, w = grid.shape
    xmin, ymin, xmax, ymax = info.bounds
    extent = (xmin, xmax, ymin, ymax)
    fig, ax = plt.subplots(figsize=(8, 8 * h / max(w, 1) + 0.5), dpi=100)
    ax.imshow(map_image(grid), cmap="gray", vmin=0, vmax=1, origin="lower", extent=extent,
              interpolation="nearest")
    if candidates_xy is not None and len(candidates_xy):
        c = np.asarray(candidates_xy, dtype=float).reshape(-1, 2)
        ax.plot(c[:, 0], c[:, 1], ".", color="orange", ms=4, label="candidates")
    if path_xy is not None and len(path_xy):
        p = np.asarray(path_xy, dtype=float).reshape(-1, 2)
        ax.plot(p[:, 0], p[:, 1], "-", color="tab:blue", lw=1.2,
                label=f"path {path_length(p):.1f} m")
    if goals_xy is not None and len(goals_xy):
        g = np.asarray(goals_xy, dtype=float).reshape(-1, 2)
        ax.plot(g[:, 0], g[:, 1], "o", mfc="none", mec="red", ms=8, label="goals")
        for i, (x, y) in enumerate(g):
            ax.annotate(str(i + 1), (x, y), fontsize=7, color="red",
                        xytext=(3, 3), textcoords="offset points")
    if robot_xy is not None:
        ax.plot([robot_xy[0]], [robot_xy[1]], "^", color="green", ms=10, label="robot")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_coverage_plot(path: str, runs: Dict[str, Tuple[Sequence[float], Sequence[float]]],
                        levels: Sequence[float] = (0.90, 0.95, 0.99), title: str = "",
                        styles: Optional[Dict[str, dict]] = None) -> None:
    """Coverage [%] vs time [s], one curve per run label, dashed lines at `levels`.

    `styles` maps a label to matplotlib line keywords (colour, width, ...); a label styled
    with `"label": None` is drawn but left out of the legend (several seeds, one entry).
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=100)
    for label, (t, c) in runs.items():
        kw = dict((styles or {}).get(label, {}))
        kw.setdefault("label", label)
        if kw["label"] is None:
            kw["label"] = "_nolegend_"
        ax.plot(np.asarray(t, float), 100.0 * np.asarray(c, float), **kw)
    for level in levels:
        ax.axhline(100.0 * level, ls="--", lw=0.8, color="grey")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("coverage of reachable area [%]")
    ax.set_ylim(0, 101)
    if title:
        ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def resample(grid: np.ndarray, info: GridInfo, target: GridInfo,
             shape: Tuple[int, int]) -> np.ndarray:
    """`grid` (on `info`) looked up at the centres of the cells of another grid (`target`,
    `shape`; both infos in one frame): nearest cell, UNKNOWN outside."""
    rows, cols = np.indices(shape)
    x, y = target.cell_to_world(cols.ravel(), rows.ravel())
    ex, ey = info.world_to_cell(x, y)
    h, w = grid.shape
    inside = (ey >= 0) & (ey < h) & (ex >= 0) & (ex < w)
    img = np.full(rows.size, UNKNOWN, np.int8)
    img[inside] = grid[ey[inside], ex[inside]]
    return img.reshape(shape)


def compose(pose: Tuple[float, float, float], info: GridInfo) -> GridInfo:
    """`info` (a map's geometry in its own frame) expressed in a parent frame in which that
    frame sits at pose = (x, y, yaw). E.g. gmapping's map frame inside the simulator's."""
    x, y, yaw = pose2d.compose(pose, (info.origin_x, info.origin_y, info.origin_yaw))
    return dataclasses.replace(info, origin_x=float(x), origin_y=float(y),
                               origin_yaw=float(yaw))


class ExplorationRecord:
    """What an exploration run did, measured against a ground truth (no ROS).

    Feed it the explored map (`add_map`, with its GridInfo already in the truth's frame, see
    `compose`), the true robot poses (`add_pose`), the goals sent (`add_goal`) and
    bumper hits (`add_bump`); `summary()` gives coverage, path length, time to 90/95/99 %;
    `write()` saves summary JSON, map+path+goals PNG and coverage-vs-time PNG.
    With a `LaserGeometry` (at construction or `set_laser`), poses with a yaw also feed the
    seen coverage (`SeenArea`): `seen_coverage` and its times in the summary.
    Times are whatever clock the caller uses (simulated seconds in the simulator).
    """

    def __init__(self, truth: np.ndarray, truth_info: GridInfo, start_xy: Tuple[float, float],
                 clearance_m: float = 0.18, label: str = "run",
                 laser: Optional[LaserGeometry] = None):
        self.truth, self.truth_info, self.label = truth, truth_info, label
        self.start_xy = start_xy
        self.reach = reachable_area(truth, truth_info, start_xy, clearance_m)
        self.series: list = []  # (time [s], coverage, seen coverage or None): one append
        self.seen: Optional[SeenArea] = None
        if laser is not None:
            self.set_laser(laser)
        self.poses: list = []
        self.goals: list = []
        self.bumps = 0
        self.t0: Optional[float] = None
        self.last_map: Optional[Tuple[np.ndarray, GridInfo]] = None

    def _rel(self, t: float) -> float:
        if self.t0 is None:
            self.t0 = t
        return t - self.t0

    def add_map(self, t: float, grid: np.ndarray, info_in_truth: GridInfo) -> float:
        c = coverage(grid, info_in_truth, self.truth, self.truth_info, self.start_xy,
                     reachable=self.reach)
        seen = self.seen.coverage() if self.seen is not None else None
        self.series.append((self._rel(t), c, seen))
        self.last_map = (grid, info_in_truth)
        return c

    def curve(self) -> Tuple[list, list]:
        """(times [s], coverages) from one snapshot of the series (the monitor's timer may
        append meanwhile)."""
        series = list(self.series)
        return [s[0] for s in series], [s[1] for s in series]

    def seen_curve(self) -> Tuple[list, list]:
        """(times [s], seen coverages) of the map updates since the laser was set."""
        series = [s for s in list(self.series) if s[2] is not None]
        return [s[0] for s in series], [s[2] for s in series]

    def set_laser(self, laser: LaserGeometry) -> None:
        """Start measuring seen coverage (poses before this call are not cast)."""
        self.seen = SeenArea(self.truth, self.truth_info, self.reach, laser)

    def add_pose(self, t: float, x: float, y: float, yaw: Optional[float] = None) -> None:
        self._rel(t)
        if not self.poses or math.hypot(x - self.poses[-1][0], y - self.poses[-1][1]) > 0.01:
            self.poses.append((float(x), float(y)))
        if yaw is not None and self.seen is not None:
            self.seen.add(float(x), float(y), float(yaw))

    def add_goal(self, x: float, y: float) -> None:
        self.goals.append((float(x), float(y)))

    def add_bump(self) -> None:
        self.bumps += 1

    def summary(self) -> Dict[str, object]:
        times, covers = self.curve()
        levels = time_to_coverage(times, covers)
        seen_t, seen_c = self.seen_curve()
        seen_levels = time_to_coverage(seen_t, seen_c)
        return {
            "label": self.label,
            "final_coverage": covers[-1] if covers else 0.0,
            "path_m": path_length(self.poses),
            "time_s": times[-1] if times else 0.0,
            "time_to_coverage_s": {f"{k:.2f}": v for k, v in levels.items()},
            "seen_coverage": self.seen.coverage() if self.seen is not None else None,
            "time_to_seen_coverage_s": {f"{k:.2f}": v for k, v in seen_levels.items()},
            "goals": len(self.goals),
            "bumps": self.bumps,
            "reachable_m2": float(self.reach.sum()) * self.truth_info.resolution ** 2,
        }

    def file_stem(self) -> str:
        """The label made safe as a file name ("office / utility" -> "office_utility")."""
        import re

        return re.sub(r"[^A-Za-z0-9_.-]+", "_", self.label).strip("_") or "run"

    def write(self, out_dir: str, extra: Optional[Dict[str, object]] = None,
              stem: Optional[str] = None) -> Dict[str, object]:
        """Write <stem>.json, <stem>_map.png, <stem>_coverage.png and the last explored map
        as <stem>_explored.yaml/.pgm (map_server format, truth frame); returns the summary.
        The stem defaults to the file-safe label."""
        import json
        import os

        os.makedirs(out_dir, exist_ok=True)
        s = self.summary()
        if extra:
            s.update(extra)
        base = os.path.join(out_dir, stem or self.file_stem())
        with open(base + ".json", "w", encoding="utf-8") as f:
            times, covers = self.curve()
            seen_t, seen_c = self.seen_curve()
            json.dump(dict(s, times_s=times, coverage=covers, seen_times_s=seen_t,
                           seen=seen_c), f, indent=1)
        if self.last_map is not None:
            # Draw the explored map resampled into the truth's grid.
            grid, info = self.last_map
            save_map(base + "_explored.yaml", grid, info)
            img = resample(grid, info, self.truth_info, self.truth.shape)
            write_map_png(base + "_map.png", img, self.truth_info,
                          self.poses, self.goals, robot_xy=self.poses[-1] if self.poses
                          else None, title=f"{self.label}: {s['path_m']:.1f} m, "
                          f"{100 * float(s['final_coverage']):.1f} %")
        runs = {"map coverage": (times, covers)}
        styles = {"map coverage": {"color": "tab:blue"}}
        if seen_t:
            runs["seen coverage"] = (seen_t, seen_c)
            styles["seen coverage"] = {"color": "tab:green", "ls": ":"}
        write_coverage_plot(base + "_coverage.png", runs, title=self.label, styles=styles)
        return s
