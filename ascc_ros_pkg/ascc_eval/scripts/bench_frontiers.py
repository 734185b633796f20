#!/usr/bin/env python3
"""Benchmark: candidate generation + utility vs a compiled breadth-first frontier search.

For each map side N (cells at 5 cm; default 1000 2000 3000 4000, i.e. 50 m .. 200 m) it
draws a synthetic office building (rooms, corridors, furniture), makes it partially
explored (known inside a disc of radius --explored x N/2 around a free cell near the
centre, plus unknown unvisited rooms), then times
  * this package's pipeline (frontiers.find_frontiers + scenario + utility, via
    goal_selection.plan),
    best of --repeat runs, per phase;
  * bench/bfs_frontier.cpp compiled with `g++ -O2` into a temporary directory: an
    explore_lite-style BFS frontier search (BFS over free cells from the robot, frontier
    cells, BFS grouping), best of --repeat runs, file I/O excluded.
Prints one line per size and the ratio. Needs g++ on the PATH.

    rosrun ascc_eval bench_frontiers.py [--sizes 1000 4000] [--repeat 5]
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from ascc_common.grid import GridInfo
from frontier_detector.goal_selection import PlannerParams, plan
from frontier_detector.synthetic import first_free_cell_near, office_building, partially_explored

RESOLUTION = 0.05  # [m/cell]


def _cpp_source() -> str:
    here = os.path.dirname(os.path.realpath(__file__))
    candidates = [os.path.join(here, "..", "bench", "bfs_frontier.cpp")]
    try:
        import rospkg

        candidates.append(os.path.join(rospkg.RosPack().get_path("ascc_eval"),
                                       "bench", "bfs_frontier.cpp"))
    except Exception:  # noqa: BLE001 - rospkg missing or package not found: try the others
        pass
    for path in candidates:
        if os.path.isfile(path):
            return os.path.abspath(path)
    raise FileNotFoundError("bench/bfs_frontier.cpp not found")


def compile_baseline(tmp: str) -> str:
    if shutil.which("g++") is None:
        raise RuntimeError("g++ not found on PATH")
    exe = os.path.join(tmp, "bfs_frontier")
    subprocess.run(["g++", "-O2", "-std=c++14", "-o", exe, _cpp_source()], check=True)
    return exe


def make_map(n: int, seed: int, explored: float):
    truth = office_building(n * RESOLUTION, RESOLUTION, seed=seed)
    robot = first_free_cell_near(truth, n // 2, n // 2)
    grid = partially_explored(truth, robot, explored * n / 2.0, seed=seed,
                              unknown_rooms=max(1, n // 100), room_cells=60)
    return grid, robot


def time_python(grid, robot, repeat: int):
    info = GridInfo(RESOLUTION, grid.shape[1], grid.shape[0])
    xy = info.cell_to_world(np.array([robot[1]]), np.array([robot[0]]))
    params = PlannerParams()
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = plan(grid, info, (float(xy[0][0]), float(xy[1][0])), params)
        wall = (time.perf_counter() - t0) * 1e3
        if best is None or wall < best[0]:
            best = (wall, result)
    return best


def time_cpp(exe: str, tmp: str, grid, robot, repeat: int):
    raw = os.path.join(tmp, "map.raw")
    grid.astype(np.int8).tofile(raw)
    out = subprocess.run([exe, raw, str(grid.shape[1]), str(grid.shape[0]), str(robot[1]),
                          str(robot[0]), str(repeat)], check=True, capture_output=True,
                         text=True).stdout
    fields = dict(kv.split("=") for kv in out.split())
    return float(fields["best_ms"]), int(fields["frontiers"]), int(fields["cells"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 3000, 4000])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--explored", type=float, default=0.8,
                    help="radius of the explored disc as a fraction of half the map side")
    args = ap.parse_args()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, cores {os.cpu_count()}")
    print("   N  side_m  known%  p1_ms  p2_ms  p3_ms  util_ms  total_ms  wall_ms  "
          "cand  |  cpp_bfs_ms  cpp_frontiers  |  cpp/py")
    with tempfile.TemporaryDirectory() as tmp:
        exe = compile_baseline(tmp)
        for n in args.sizes:
            grid, robot = make_map(n, args.seed, args.explored)
            wall, res = time_python(grid, robot, args.repeat)
            t = res.timings_ms
            cpp_ms, cpp_fr, _ = time_cpp(exe, tmp, grid, robot, args.repeat)
            known = 100.0 * float(np.count_nonzero(grid != -1)) / grid.size
            print(f"{n:5d} {n * RESOLUTION:6.0f} {known:6.1f} {t['phase1']:6.1f} "
                  f"{t['phase2']:6.1f} {t['phase3']:6.1f} {t['utility']:8.1f} "
                  f"{t['total']:9.1f} {wall:8.1f} {res.frontiers.n_candidates:5d}  |  "
                  f"{cpp_ms:10.1f} {cpp_fr:14d}  |  {cpp_ms / t['total']:6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
