"""The command-line tools (no rospy): ``fuse_estimates``, ``thesis_tables`` and
``measure_landmarks`` (its usage: ``--help``).

    rosrun colloc_fusion fuse_estimates FILE.csv [--method thesis|information|ci]

reads a CSV with the header ``set,robot,x,y,ux,uy`` (x, y [m]; ux, uy the variances
[m^2], as in thesis Table 3.1) and prints ``set,x,y``, one row per set in the order of
first appearance, 6 decimals. A row with a non-finite coordinate, a non-positive or
non-finite uncertainty, a missing field or a robot already seen in its set is rejected
with a message naming the line on stderr; its set is fused from its valid rows. A set with
no valid row is not printed and the exit status is 2 (also for an unreadable file or a
wrong header); otherwise 0. The estimates' covariances are diag(ux, uy).

    rosrun colloc_fusion thesis_tables

reruns Table 3.1 -> Table 3.2 from the package's data/thesis_table_3_1.csv (thesis's fusion,
eq. 3.1-3.5) and prints our values beside the printed ones (data/thesis_table_3_2.csv)
with the differences; the differences against the Vicon are recomputed from ours. A cell
differing by more than ROUNDING_M (it does not follow from Table 3.1) is marked "*".
"""
from __future__ import annotations

import argparse
import collections
import csv
import math
import os
import sys
from typing import Dict, List, Optional, Tuple

import numpy as np

from .estimate import TargetEstimate
from .fusion import CI_CRITERIA, METHODS, fuse

HEADER = ["set", "robot", "x", "y", "ux", "uy"]
PKG_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TABLE_3_1 = os.path.join(PKG_DIR, "data", "thesis_table_3_1.csv")
TABLE_3_2 = os.path.join(PKG_DIR, "data", "thesis_table_3_2.csv")
# [m] a printed cell further than this from our value does not follow from Table 3.1: the
# cells that do agree within 7e-5 m (the thesis presumably fused unrounded values; Table
# 3.1 prints 4-5 digits), the others differ by 1e-3 m or more
ROUNDING_M = 5e-4


class CsvError(ValueError):
    """The file cannot be read as an estimates CSV at all."""


def _row_estimate(row: List[str]) -> Tuple[str, TargetEstimate]:
    """(set, estimate) of a CSV row; ValueError saying what is wrong."""
    if len(row) != len(HEADER):
        raise ValueError("expected %d fields (%s), got %d" % (len(HEADER), ",".join(HEADER),
                                                              len(row)))
    name, robot = row[0].strip(), row[1].strip()
    if not name or not robot:
        raise ValueError("empty set or robot")
    vals = {}
    for key, text in zip(HEADER[2:], row[2:]):
        try:
            vals[key] = float(text)
        except ValueError:
            raise ValueError("%s %r is not a number" % (key, text.strip())) from None
    for key in ("x", "y"):
        if not math.isfinite(vals[key]):
            raise ValueError("coordinate %s = %r is not finite" % (key, vals[key]))
    for key in ("ux", "uy"):
        if not (math.isfinite(vals[key]) and vals[key] > 0.0):
            raise ValueError("uncertainty %s = %r must be positive and finite"
                             % (key, vals[key]))
    return name, TargetEstimate(robot, vals["x"], vals["y"],
                                np.diag([vals["ux"], vals["uy"]]), 0.0)


def read_sets(lines, source: str = "-", warn=None
              ) -> Tuple[Dict[str, List[TargetEstimate]], List[str]]:
    """The valid estimates of each set (sets in the order of first appearance, a set with
    no valid row present with an empty list) and the rejection messages naming the lines.
    CsvError when the header is wrong."""
    rows = csv.reader(lines)
    header = next(rows, None)
    if header is None or [h.strip() for h in header] != HEADER:
        raise CsvError("%s:1: header must be %s, got %s"
                       % (source, ",".join(HEADER), ",".join(header or [])))
    sets: Dict[str, List[TargetEstimate]] = collections.OrderedDict()
    errors: List[str] = []
    for lineno, row in enumerate(rows, start=2):
        if not row or not "".join(row).strip():
            continue
        name = row[0].strip()
        try:
            name, est = _row_estimate(row)
            if any(e.robot == est.robot for e in sets.get(name, [])):
                raise ValueError("robot %s already in set %s" % (est.robot, name))
        except ValueError as err:
            errors.append("%s:%d: row rejected (set %s): %s" % (source, lineno, name, err))
            sets.setdefault(name, [])
            continue
        sets.setdefault(name, []).append(est)
    return sets, errors


def fuse_estimates_main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="fuse_estimates",
                                 description="Fuse per-robot target estimates, one row per "
                                             "set (thesis eq. 3.1-3.5 or a covariance-"
                                             "based fusion).")
    ap.add_argument("file", metavar="FILE.csv", help="set,robot,x,y,ux,uy (ux, uy in m^2)")
    ap.add_argument("--method", choices=METHODS, default="thesis")
    ap.add_argument("--ci-criterion", choices=CI_CRITERIA, default="trace",
                    help="ci: minimise the trace or the determinant of the covariance")
    args = ap.parse_args(argv)
    try:
        with open(args.file, newline="") as f:
            sets, errors = read_sets(f, args.file)
    except (OSError, UnicodeDecodeError, CsvError, csv.Error) as err:
        print("fuse_estimates: error: %s" % err, file=sys.stderr)
        return 2
    for msg in errors:
        print("fuse_estimates: %s" % msg, file=sys.stderr)
    status = 0
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["set", "x", "y"])
    for name, ests in sets.items():
        if not ests:
            print("fuse_estimates: error: set %s has no valid row" % name, file=sys.stderr)
            status = 2
            continue
        fused = fuse(ests, args.method, args.ci_criterion)
        out.writerow([name, "%.6f" % fused.x, "%.6f" % fused.y])
    return status


def thesis_tables_rows(table_3_1: str = TABLE_3_1, table_3_2: str = TABLE_3_2):
    """[(set, ours: dict, printed: dict)] with keys x_fusion, dx, y_fusion, dy (ours from
    Table 3.1 and the printed Vicon values) and x_vicon, y_vicon."""
    with open(table_3_1, newline="") as f:
        sets, errors = read_sets(f, table_3_1)
    if errors:
        raise CsvError("; ".join(errors))
    with open(table_3_2, newline="") as f:
        printed = {r["set"]: {k: float(v) for k, v in r.items() if k != "set"}
                   for r in csv.DictReader(f)}
    rows = []
    for name, ests in sets.items():
        fused = fuse(ests, "thesis")
        p = printed[name]
        ours = {"x_fusion": fused.x, "x_vicon": p["x_vicon"], "dx": fused.x - p["x_vicon"],
                "y_fusion": fused.y, "y_vicon": p["y_vicon"], "dy": fused.y - p["y_vicon"]}
        rows.append((name, ours, p))
    return rows


def thesis_tables_main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="thesis_tables",
                                 description="Thesis Table 3.1 -> Table 3.2 (eq. 3.1-3.5), "
                                             "ours beside the printed values.")
    ap.add_argument("--table-3-1", default=TABLE_3_1, help="inputs (set,robot,x,y,ux,uy)")
    ap.add_argument("--table-3-2", default=TABLE_3_2, help="printed results")
    args = ap.parse_args(argv)
    try:
        rows = thesis_tables_rows(args.table_3_1, args.table_3_2)
    except (OSError, CsvError, KeyError, ValueError) as err:
        print("thesis_tables: error: %s" % err, file=sys.stderr)
        return 2
    print("Table 3.2 recomputed from Table 3.1 (thesis eq. 3.1-3.5) [m]; "
          "'diff' = ours - printed")
    print("%-4s %-9s %10s %10s %10s" % ("set", "cell", "ours", "printed", "diff"))
    flagged = 0
    for name, ours, printed in rows:
        for key in ("x_fusion", "dx", "y_fusion", "dy"):
            diff = ours[key] - printed[key]
            flag = abs(diff) > ROUNDING_M
            flagged += flag
            print("%-4s %-9s %10.5f %10.5f %+10.5f%s"
                  % (name, key, ours[key], printed[key], diff, "  *" if flag else ""))
    print("* %d printed cell(s) differ from what their own inputs give by more than "
          "%.0e m" % (flagged, ROUNDING_M))
    return 0


def measure_landmarks_main(argv: Optional[List[str]] = None) -> int:
    """measure_landmarks: the desk corners in a map and the truth -> map calibration."""
    from ascc_common.map_io import MapError, load_map
    from ascc_sim.world import WorldError, load_world

    from .calibration import CalibrationError
    from .landmarks import calibrate, measure

    ap = argparse.ArgumentParser(
        prog="measure_landmarks",
        description="Measure the calibration landmarks (desk corners) in a map and fit the "
                    "truth (Vicon) -> map transform (thesis 3.4.1).")
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--map", help="map_server YAML of the robots' map")
    src.add_argument("--world-map", metavar="WORLD",
                     help="an ascc_sim world: its ground-truth map (what the simulated "
                          "robots' amcl uses)")
    ap.add_argument("--world", help="ascc_sim world YAML whose 'landmark' objects are the "
                                    "truth positions (default: --world-map)")
    ap.add_argument("--guesses", help="CSV name,x,y: rough landmark positions in the map "
                                      "(default: the truth positions)")
    ap.add_argument("--radius-m", type=float, default=0.3, help="[m] search radius")
    args = ap.parse_args(argv)
    try:
        if not (args.world or args.world_map):
            raise ValueError("give --world (the landmarks' truth positions)")
        world = load_world(args.world or args.world_map)
        truth = {o.name: (o.pose.x, o.pose.y) for o in world.objects if o.type == "landmark"}
        if args.map:
            occupancy, info = load_map(args.map)
        else:
            occupancy, info = world.truth_map.occupancy, world.truth_map.info
        guesses = dict(truth)
        if args.guesses:
            with open(args.guesses, newline="") as f:
                guesses = {r["name"]: (float(r["x"]), float(r["y"]))
                           for r in csv.DictReader(f)}
        found, failed = measure(occupancy, info, guesses, args.radius_m)
        for name, why in failed.items():
            print("measure_landmarks: %s not measured: %s" % (name, why), file=sys.stderr)
        fit, names = calibrate(truth, found)
    except (OSError, ValueError, KeyError, MapError, CalibrationError, WorldError) as err:
        print("measure_landmarks: error: %s" % err, file=sys.stderr)
        return 2
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["name", "x_map", "y_map", "x_truth", "y_truth", "residual_m"])
    for name, res in zip(names, fit.residuals_m):
        out.writerow([name, "%.4f" % found[name][0], "%.4f" % found[name][1],
                      "%.4f" % truth[name][0], "%.4f" % truth[name][1], "%.4f" % res])
    print("# truth -> map: theta %.5f rad, t (%.4f, %.4f) m, rms residual %.4f m over %d"
          % (fit.theta, fit.tx, fit.ty, fit.rms_m, len(names)))
    return 0
