"""How well a robot follows a walking person, measured on the simulator's ground truth.

The issue's goals for target following (thesis 5.3): on straight segments of the person's
route the robot keeps its distance within +-``band_m`` of the follower's set point (mean
and 95th percentile of the error), it never collides, and it re-acquires the person after
each corner. The distance is the one the follower regulates: from the robot's centre
(``base_link``) to the near surface of the person, i.e. the centre distance minus the
person's radius (the range the laser measures along the line of sight).

A sample is *on a straight segment* when the person walks and has walked in the same
direction (within ``straight_tolerance_rad``) for at least ``settle_s``: long enough for
the robot, a set distance behind, to have turned the previous corner too. A *corner* is a
change of the walking direction by more than ``corner_min_rad``; after each, the record
gives how long the follower was not ``following`` within ``reacquire_window_s`` and
whether it was following again at the window's end.

Beside the truth, a sample may carry what the follower believed at that time: the
detector's best detection and the point the follower steered for, each as a range from
``base_link`` and a bearing. The record compares them with the true distance and bearing,
so that a run that kept the wrong distance shows whether the detector or the tracking
misjudged the person.

Pure: no rospy. ``follow_monitor`` feeds it from topics; the rostest and the benchmark
read its summary.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param
from ascc_common.pose2d import wrap_angle

FOLLOWING = "following"


@dataclass
class FollowMonitorParams:
    """The follow_monitor node's parameters (private)."""

    robot: str = param("asccbot", "robot name in ground_truth/<robot>/...")
    person: str = param("", "name of the followed person in ground_truth/people (\"\": "
                            "the first)")
    label: str = param("follow", "run label (file names, plots)")
    output_dir: str = param("", "directory of the report files (\"\": no files)")
    distance_m: float = param(1.2, "[m] the follower's set point (its ~distance_m)", gt=0.0)
    band_m: float = param(0.3, "[m] allowed error on straight segments", gt=0.0)
    settle_s: float = param(8.0, "[s] walking straight this long makes a straight sample",
                            ge=0.0)
    straight_tolerance_rad: float = param(0.09, "[rad] heading drift still straight "
                                                "(about 5 deg)", gt=0.0)
    corner_min_rad: float = param(0.35, "[rad] heading change that makes a corner", gt=0.0)
    reacquire_window_s: float = param(20.0, "[s] window after a corner to re-acquire",
                                      gt=0.0)
    sample_period_s: float = param(0.1, "[s] period of the samples", gt=0.0)
    max_time_s: float = param(0.0, "[s] end the run after this much time; 0: no limit",
                              ge=0.0)
    end_after_stop_s: float = param(10.0, "[s] end the run when the person has stood "
                                          "this long (longer than any stop on a route: "
                                          "its route ended)", ge=0.0)
    shutdown_when_finished: bool = param(True, "exit when the run ends")
    belief_max_age_s: float = param(0.5, "[s] a detection or followed point older than "
                                         "this is not recorded with a sample", gt=0.0)


@dataclass
class FollowSample:
    t: float  # [s]
    robot: Tuple[float, float, float]  # true pose (x, y, yaw) [m, m, rad]
    person: Tuple[float, float, float]  # (x, y, heading) [m, m, rad]
    person_speed_mps: float
    person_radius_m: float
    state: str  # the follower's state at that time ('' unknown)
    # the follower's belief, when fresh, else NaN: range [m] from base_link's origin and
    # bearing [rad] from base_link's x axis of the detector's best detection, with the
    # detection's range source ('laser', 'size', 'none'; '' no detection), and of the
    # point the follower steered for (target_follower/followed)
    detected_range_m: float = math.nan
    detected_bearing_rad: float = math.nan
    range_source: str = ""
    followed_range_m: float = math.nan
    followed_bearing_rad: float = math.nan


class FollowRecord:
    """Samples of one following run and the summary the issue's goals are judged on."""

    def __init__(self, params: Optional[FollowMonitorParams] = None, label: str = ""):
        self.p = params or FollowMonitorParams()
        self.label = label or self.p.label
        self.samples: List[FollowSample] = []
        self.bump_times: List[float] = []
        self.end_reason = ""

    def add(self, sample: FollowSample) -> None:
        self.samples.append(sample)

    def add_bump(self, t: float) -> None:
        self.bump_times.append(t)

    # -- arrays ---------------------------------------------------------------------
    def arrays(self) -> Dict[str, np.ndarray]:
        s = self.samples
        t = np.array([x.t for x in s], float)
        robot = np.array([x.robot for x in s], float).reshape(-1, 3)
        person = np.array([x.person for x in s], float).reshape(-1, 3)
        speed = np.array([x.person_speed_mps for x in s], float)
        radius = np.array([x.person_radius_m for x in s], float)
        rel = person[:, :2] - robot[:, :2]
        dist = np.hypot(*rel.T) - radius
        bearing = wrap_angle(np.arctan2(rel[:, 1], rel[:, 0]) - robot[:, 2])
        return {"t": t, "robot": robot, "person": person, "speed": speed, "distance": dist,
                "bearing": bearing,
                "state": np.array([x.state for x in s], dtype=object),
                "detected_range": np.array([x.detected_range_m for x in s], float),
                "detected_bearing": np.array([x.detected_bearing_rad for x in s], float),
                "range_source": np.array([x.range_source for x in s], dtype=object),
                "followed_range": np.array([x.followed_range_m for x in s], float),
                "followed_bearing": np.array([x.followed_bearing_rad for x in s], float)}

    def belief_errors(self, a: Optional[Dict[str, np.ndarray]] = None
                      ) -> Dict[str, Optional[float]]:
        """How far the follower's view was from the truth, over the samples that had one:
        the detector's range minus the true distance to the person's surface (median and
        95th percentile of the absolute error [m]), its bearing error [rad], and the same
        for the followed point; with the share of samples that had a detection."""
        a = self.arrays() if a is None else a
        out: Dict[str, Optional[float]] = {}
        has = np.isfinite(a["detected_bearing"])
        out["detection_fraction"] = _r(np.mean(has)) if has.size else None
        for name in ("detected", "followed"):
            for what, err in (
                    ("range", a[name + "_range"] - a["distance"]),
                    ("bearing", wrap_angle(a[name + "_bearing"] - a["bearing"]))):
                e = np.abs(err[np.isfinite(err)])
                unit = "m" if what == "range" else "rad"
                out["%s_%s_error_median_%s" % (name, what, unit)] = (
                    _r(np.median(e)) if e.size else None)
                out["%s_%s_error_p95_%s" % (name, what, unit)] = (
                    _r(np.percentile(e, 95)) if e.size else None)
        return out

    def straight_mask(self, t: np.ndarray, heading: np.ndarray,
                      walking: np.ndarray) -> np.ndarray:
        """Samples where the person has walked straight for at least ``settle_s``."""
        mask = np.zeros(t.shape, bool)
        since = None  # start of the current straight walk
        for k in range(t.size):  # one pass over the samples (not a hot path)
            if not walking[k]:
                since = None
                continue
            if since is None or abs(wrap_angle(heading[k] - heading[since])) > \
                    self.p.straight_tolerance_rad:
                since = k
            mask[k] = t[k] - t[since] >= self.p.settle_s
        return mask

    def corners(self, t: np.ndarray, heading: np.ndarray, walking: np.ndarray) -> List[float]:
        """Times at which the walking direction changed by more than ``corner_min_rad``."""
        out: List[float] = []
        last = None
        for k in np.flatnonzero(walking):
            if last is not None and abs(wrap_angle(heading[k] - last)) > self.p.corner_min_rad:
                out.append(float(t[k]))
            last = heading[k]
        return out

    def summary(self) -> Dict[str, Any]:
        if not self.samples:
            return {"label": self.label, "samples": 0, "end_reason": self.end_reason}
        a = self.arrays()
        t, dist, state = a["t"], a["distance"], a["state"]
        walking = a["speed"] > 1e-3
        heading = a["person"][:, 2]
        straight = self.straight_mask(t, heading, walking)
        err = np.abs(dist[straight] - self.p.distance_m)
        corners = []
        for tc in self.corners(t, heading, walking):
            win = (t >= tc) & (t <= tc + self.p.reacquire_window_s)
            dt = np.diff(t[win], append=t[win][-1] if win.any() else tc)
            lost = float(np.sum(dt[state[win] != FOLLOWING])) if win.any() else 0.0
            end_state = str(state[win][-1]) if win.any() else ""
            corners.append({"t_s": round(tc, 2), "not_following_s": round(lost, 2),
                            "reacquired": end_state == FOLLOWING})
        robot_xy = a["robot"][:, :2]
        person_xy = a["person"][:, :2]
        out = {
            "label": self.label,
            "samples": int(t.size),
            "duration_s": round(float(t[-1] - t[0]), 2),
            "set_distance_m": self.p.distance_m,
            "band_m": self.p.band_m,
            "person_path_m": round(_path_length(person_xy), 2),
            "robot_path_m": round(_path_length(robot_xy), 2),
            "straight_samples": int(straight.sum()),
            "straight_error_mean_m": _r(err.mean()) if err.size else None,
            "straight_error_p95_m": _r(np.percentile(err, 95)) if err.size else None,
            "straight_error_max_m": _r(err.max()) if err.size else None,
            "straight_within_band": _r(np.mean(err <= self.p.band_m)) if err.size else None,
            "distance_min_m": _r(dist.min()),
            "distance_final_m": _r(dist[-1]),
            "following_fraction": _r(np.mean(state == FOLLOWING)),
            "corners": corners,
            "corners_reacquired": sum(c["reacquired"] for c in corners),
            "bumps": len(self.bump_times),
            "end_reason": self.end_reason,
        }
        out.update(self.belief_errors(a))
        return out

    # -- files ------------------------------------------------------------------------
    def write(self, out_dir: str, stem: str = "") -> List[str]:
        """``<stem>.json`` (the summary), ``<stem>.csv`` (the samples: t [s], the robot's
        and the person's true x, y [m] and yaw/heading [rad], the distance [m], the
        follower's state, the person's true bearing from the robot [rad], the detector's
        range [m], bearing [rad] and range source, the followed point's range and bearing;
        empty where the follower had none) and ``<stem>.png`` (paths, and distance over
        time with what the follower saw)."""
        os.makedirs(out_dir, exist_ok=True)
        stem = stem or _file_safe(self.label)
        js = os.path.join(out_dir, stem + ".json")
        with open(js, "w") as f:
            json.dump(self.summary(), f, indent=2)
        files = [js]
        if self.samples:
            a = self.arrays()
            csv_path = os.path.join(out_dir, stem + ".csv")
            with open(csv_path, "w") as f:
                f.write("t_s,robot_x_m,robot_y_m,robot_yaw_rad,person_x_m,person_y_m,"
                        "person_heading_rad,distance_m,state,bearing_rad,detected_range_m,"
                        "detected_bearing_rad,range_source,followed_range_m,"
                        "followed_bearing_rad\n")
                for k in range(a["t"].size):
                    f.write("%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%s,%.4f,%s,%s,%s,%s,%s\n" % (
                        (a["t"][k],) + tuple(a["robot"][k]) + tuple(a["person"][k])
                        + (a["distance"][k], a["state"][k], a["bearing"][k],
                           _csv(a["detected_range"][k]), _csv(a["detected_bearing"][k]),
                           a["range_source"][k], _csv(a["followed_range"][k]),
                           _csv(a["followed_bearing"][k]))))
            files.append(csv_path)
            png = os.path.join(out_dir, stem + ".png")
            self.plot(png)
            files.append(png)
        return files

    def plot(self, path: str, truth_map: Optional[Tuple[np.ndarray, Sequence[float]]] = None
             ) -> None:
        """Paths of robot and person (over the map when given as (grid, extent)) and the
        distance over time with the band and the straight samples."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        a = self.arrays()
        walking = a["speed"] > 1e-3
        straight = self.straight_mask(a["t"], a["person"][:, 2], walking)
        fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5))
        if truth_map is not None:
            grid, extent = truth_map
            ax0.imshow(grid, origin="lower", extent=extent, cmap="gray_r", vmin=-1, vmax=100)
        ax0.plot(a["person"][:, 0], a["person"][:, 1], "-", color="tab:orange", label="person")
        ax0.plot(a["robot"][:, 0], a["robot"][:, 1], "-", color="tab:blue", label="robot")
        ax0.plot(*a["robot"][0, :2], "o", color="tab:blue")
        ax0.set_aspect("equal")
        ax0.set_xlabel("x [m]")
        ax0.set_ylabel("y [m]")
        ax0.legend(loc="best")
        ax0.set_title(self.label)
        t = a["t"] - a["t"][0]
        ax1.plot(t, a["distance"], "-", color="0.5", lw=1, label="distance")
        ax1.plot(t[straight], a["distance"][straight], ".", ms=2, color="tab:blue",
                 label="straight segments")
        if np.isfinite(a["detected_range"]).any():
            ax1.plot(t, a["detected_range"], ".", ms=1.5, color="tab:red",
                     label="detector's range")
        if np.isfinite(a["followed_range"]).any():
            ax1.plot(t, a["followed_range"], "-", lw=0.8, color="tab:purple",
                     label="followed point's range")
        d, b = self.p.distance_m, self.p.band_m
        ax1.axhspan(d - b, d + b, color="tab:green", alpha=0.15, label="set point +- band")
        for c in self.corners(a["t"], a["person"][:, 2], walking):
            ax1.axvline(c - a["t"][0], color="tab:orange", lw=0.8, ls="--")
        ax1.set_xlabel("time [s]")
        ax1.set_ylabel("robot centre to person surface [m]")
        ax1.legend(loc="best")
        fig.tight_layout()
        fig.savefig(path, dpi=80)
        plt.close(fig)


def _path_length(xy: np.ndarray) -> float:
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


def _r(x: float) -> float:
    return round(float(x), 3)


def _csv(x: float) -> str:
    """A CSV cell: 4 decimals, empty for NaN (no value)."""
    return "%.4f" % x if math.isfinite(x) else ""


def _file_safe(label: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in label) or "follow"
