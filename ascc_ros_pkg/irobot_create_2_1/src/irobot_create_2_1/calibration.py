"""Calibration of the odometry's distance scale with the laser (no ROS; the node is
ros/calibrate_odometry_node.py).

The robot stands facing a flat wall, drives straight towards it and back on odometry,
and stops between runs. At every stop the laser's perpendicular distance to the wall
(a line fitted to the end points within ``half_width_rad`` of straight ahead, averaged
over the scans taken while at rest) is compared with the odometry's distance between the
stops. The wall is the ruler: the laser measures distance on its own scale, unlike the
wheels, whose scale error (a few tenths of a percent on a Create) is the one odometry
error a scan matcher cannot remove along a featureless corridor. The factor true /
odometry distance is the driver's ``~odom_linear_scale_correction`` (multiplied by the
value the driver ran with).
"""
import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param


@dataclass
class CalibrationParams:
    """Everything the calibrate_odometry node reads (private parameters)."""

    distance_m: float = param(1.5, "[m] odometry distance of each run towards / away from "
                              "the wall", gt=0.0)
    runs: int = param(6, "runs, alternately towards and away from the wall", ge=1)
    speed_m_s: float = param(0.15, "[m/s] driving speed", gt=0.0)
    settle_s: float = param(1.0, "[s] at rest before the wall is measured", ge=0.0)
    measure_s: float = param(2.0, "[s] scans averaged at each stop", gt=0.0)
    half_width_rad: float = param(0.26, "[rad] beams within this of straight ahead measure "
                                  "the wall", gt=0.0, le=1.5)
    min_wall_m: float = param(0.5, "[m] closest the laser may come to the wall", gt=0.0)
    cmd_timeout_s: float = param(1.0, "[s] no odom or scan for this long: stop and abort",
                                 gt=0.0)
    start_delay_s: float = param(0.0, "[s] wait before the first measurement (a recorder "
                                 "starting)", ge=0.0)
    output_file: str = param("", "write 'odom_linear_scale_correction: <value>' here "
                             "(\"\": log only)")
    current_correction: float = param(1.0, "[-] the driver's odom_linear_scale_correction "
                                      "during the runs (the result is multiplied by it)",
                                      gt=0.5, le=1.5)


class WallFit:
    """A line fitted to the wall ahead: ``distance_m`` from the laser along its normal,
    ``angle_rad`` of the normal in the laser frame (0: the wall is square to the beam
    straight ahead), ``rms_m`` of the points about it, ``points`` used."""

    __slots__ = ("distance_m", "angle_rad", "rms_m", "points")

    def __init__(self, distance_m: float, angle_rad: float, rms_m: float, points: int):
        self.distance_m = distance_m
        self.angle_rad = angle_rad
        self.rms_m = rms_m
        self.points = points


def fit_wall(ranges: Sequence[float], angle_min: float, angle_increment: float,
             range_min: float, range_max: float, half_width_rad: float,
             min_points: int = 10, min_outlier_m: float = 0.02) -> Optional[WallFit]:
    """The wall straight ahead of the laser: total least squares line through the valid
    end points within ``half_width_rad`` of the beam at 0 rad, refitted once without the
    points further from the first line than three times its rms (at least
    ``min_outlier_m``: a chair leg, a door frame). None if fewer than
    ``min_points`` remain or the line does not face the laser (its normal more than
    ``half_width_rad`` off the beam ahead)."""
    r = np.asarray(ranges, dtype=float)
    a = angle_min + angle_increment * np.arange(r.size)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r >= range_min) & (r <= range_max) & (np.abs(a) <= half_width_rad)
    if ok.sum() < min_points:
        return None
    pts = np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])])
    fit = None
    for _ in range(2):
        centre = pts.mean(axis=0)
        _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
        normal = vt[-1]
        if normal[0] < 0.0:
            normal = -normal                       # pointing away from the laser
        resid = (pts - centre) @ normal
        fit = (float(centre @ normal), float(math.atan2(normal[1], normal[0])), resid)
        keep = np.abs(resid) <= max(3.0 * float(np.sqrt(np.mean(resid * resid))),
                                    min_outlier_m)
        if keep.all() or keep.sum() < min_points:
            break
        pts = pts[keep]
    distance, angle, resid = fit
    if pts.shape[0] < min_points or abs(angle) > half_width_rad:
        return None
    return WallFit(distance, angle, float(np.sqrt(np.mean(resid * resid))), int(pts.shape[0]))


class Stop:
    """The robot at rest: the odometry pose (x, y, theta) and the wall's mean fit."""

    __slots__ = ("odom", "distance_m", "angle_rad", "scans")

    def __init__(self, odom: Tuple[float, float, float], fits: List[WallFit]):
        if not fits:
            raise ValueError("no scan saw the wall at this stop")
        self.odom = odom
        self.distance_m = float(np.mean([f.distance_m for f in fits]))
        self.angle_rad = float(np.mean([f.angle_rad for f in fits]))
        self.scans = len(fits)


def run_ratio(a: Stop, b: Stop) -> Tuple[float, float]:
    """Distance between two stops by the laser and by the odometry [m]. The laser's is the
    change of the perpendicular distance to the wall, divided by the cosine of the angle
    between the travel and the wall's normal (from the fits and the odometry's heading
    change), so a run not quite square to the wall still counts its full length."""
    odom = math.hypot(b.odom[0] - a.odom[0], b.odom[1] - a.odom[1])
    # the travel's direction against the wall normal, in the frame of the first stop
    travel = math.atan2(b.odom[1] - a.odom[1], b.odom[0] - a.odom[0]) - a.odom[2]
    off = math.atan2(math.sin(travel - a.angle_rad), math.cos(travel - a.angle_rad))
    laser = abs(a.distance_m - b.distance_m) / max(abs(math.cos(off)), 1e-6)
    return laser, odom


def scale_factor(stops: Sequence[Stop]) -> Tuple[float, float, List[float]]:
    """Factor true / odometry distance over consecutive stops: the ratio of the summed
    distances, its standard error from the runs' scatter (NaN for one run), and each
    run's ratio."""
    if len(stops) < 2:
        raise ValueError("at least two stops are needed, got %d" % len(stops))
    pairs = [run_ratio(a, b) for a, b in zip(stops, stops[1:])]
    laser = np.array([p[0] for p in pairs])
    odom = np.array([p[1] for p in pairs])
    if not odom.sum() > 0.0:
        raise ValueError("the odometry did not move between the stops")
    ratios = laser / np.maximum(odom, 1e-9)
    factor = float(laser.sum() / odom.sum())
    stderr = float(np.std(ratios, ddof=1) / math.sqrt(len(ratios))) if len(ratios) > 1 \
        else float("nan")
    return factor, stderr, ratios.tolist()
