"""frontiers_cli: offline frontier candidates and utilities for a map_server map.

    rosrun frontier_detector frontiers_cli MAP.yaml --robot X Y [--repeat N]
        [--strategy utility|nearest] [--entropy H] [--top K]

X Y are the robot's position in map metres. Prints the scenario, one line per candidate
(goal x y [m], cells, path length [m], U_I, U_N, U_L, U; the chosen one marked '*'), the
time each phase took (best of N runs, per phase) and, as the last line,
`total_ms=<best total time>` (the fastest whole run: phases 1-3 + utility; map loading
excluded). Exit status: 0 ok or nothing left to explore, 2 unreadable input, 3 the map or
the robot position is unusable (status printed).
"""

from __future__ import annotations

import argparse
import sys
from typing import List, Optional

from ascc_common.map_io import load_map

from .frontiers import STATUS_NO_FRONTIERS, STATUS_OK
from .goal_selection import STATUS_ALL_BLACKLISTED, STATUS_NO_GAIN, Plan, PlannerParams, plan

PHASES = ("phase1", "phase2", "phase3", "utility")


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="frontiers_cli", description=__doc__.split("\n\n")[0])
    ap.add_argument("map_yaml", help="map_server YAML file (image + resolution + origin)")
    ap.add_argument("--robot", nargs=2, type=float, required=True, metavar=("X", "Y"),
                    help="robot position in map metres")
    ap.add_argument("--repeat", type=int, default=1, help="runs; timings are the best (1)")
    ap.add_argument("--strategy", choices=("utility", "nearest"), default="utility")
    ap.add_argument("--entropy", type=float, default=None, help="pose entropy [nats]")
    ap.add_argument("--top", type=int, default=0,
                    help="print only the K best candidates (0: all)")
    return ap


def _candidate_lines(result: Plan, top: int) -> List[str]:
    s = result.scores
    fr = result.frontiers
    if s is None:
        return []
    order = sorted(range(s.total.size), key=lambda i: -s.total[i])
    if top > 0:
        order = order[:top]
    lines = ["  idx        x        y  cells   path_m    U_I    U_N    U_L        U"]
    for i in order:
        mark = "*" if i == s.best else (" " if result.allowed[i] else "x")
        lines.append(
            f"{mark}{i:4d} {result.goals_xy[i, 0]:8.2f} {result.goals_xy[i, 1]:8.2f} "
            f"{int(fr.cluster_cells[i]):6d} {s.path_m[i]:8.2f} {s.info[i]:6.3f} "
            f"{s.nav[i]:6.3f} {s.loc[i]:6.3f} {s.total[i]:8.3f}")
    return lines


def main(argv: Optional[List[str]] = None) -> int:
    args = _parser().parse_args(argv)
    if args.repeat < 1:
        print("error: --repeat must be >= 1", file=sys.stderr)
        return 2
    try:
        grid, info = load_map(args.map_yaml)
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    params = PlannerParams(strategy=args.strategy)
    best = {k: float("inf") for k in PHASES}
    best_total = float("inf")
    result = None
    for _ in range(args.repeat):
        result = plan(grid, info, (args.robot[0], args.robot[1]), params, args.entropy)
        for k in PHASES:
            best[k] = min(best[k], result.timings_ms.get(k, 0.0))
        best_total = min(best_total, result.timings_ms["total"])
    assert result is not None
    fr = result.frontiers
    print(f"map: {grid.shape[1]} x {grid.shape[0]} cells at {info.resolution} m, "
          f"origin ({info.origin_x}, {info.origin_y})")
    print(f"status: {result.status}")
    if fr.robot_rc is not None:
        print(f"robot cell (row, col): {fr.robot_rc}")
    print(f"phase1 candidates: {len(fr.phase1_rc)}  phase2: {len(fr.phase2_rc)}  "
          f"phase3 clusters: {fr.n_candidates}")
    if result.scenario is not None:
        sc = result.scenario
        print(f"scenario: {sc.name} (w_S={sc.w_scenario}, width {sc.width_m:.2f} m, "
              f"elongation {sc.elongation:.2f}); w_E={result.scores.w_entropy:.3f}")
    for line in _candidate_lines(result, args.top):
        print(line)
    if result.goal_xy is not None:
        print(f"goal: x={result.goal_xy[0]:.3f} y={result.goal_xy[1]:.3f} "
              f"(candidate {result.best}, strategy {args.strategy})")
    print(f"timings (best of {args.repeat}): "
          + " ".join(f"{k}_ms={best[k]:.2f}" for k in PHASES))
    print(f"total_ms={best_total:.2f}")
    if result.status in (STATUS_OK, STATUS_NO_FRONTIERS, STATUS_ALL_BLACKLISTED, STATUS_NO_GAIN):
        return 0
    return 3


if __name__ == "__main__":
    sys.exit(main())
