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

Then, on the shared reference (`--reference-dir`, default $ASCC_FRONTIER_BASELINE or
../shared/bench/frontier_baseline from the repository's top level; skipped with a message
if absent), exactly as its README says: `bfs_frontiers.cpp` built with `g++ -O2`, its
`make_map.py` grid of --reference-size cells (4000), `to_mapserver.py`'s YAML + PGM loaded
with ascc_common.map_io.load_map, the same robot cell; best of --repeat for both, in the
same run, and the ratio ours / C++ (the issue's figure: under 0.5 is the goal); ours also
as CPU time (time.process_time, best and mean of --repeat), and the C++ search's mean CPU
time (the process CPU time of a run with 11 searches minus that of a run with 1), so that
the CPU ratio can be given beside the wall-time one: steadier on a loaded machine. Ours
is timed interleaved with the C++ runs (which empty the caches), so it is also measured
the way the C++ search is (plans in a row, "alike"). OpenCV runs single-threaded while
timing, as the C++ search does.

`--against REV` (with --only compare) checks a change of the search against the package at
git revision REV (its src/frontier_detector extracted beside this one): identical plans
(status, candidates, path lengths, scores, goal) on --maps random partially explored
offices per strategy, then both versions' CPU time per plan and per part (phases 1-3,
utility) on the reference map, alternating, best of --repeat.

    rosrun ascc_eval bench_frontiers.py [--sizes 1000 4000] [--repeat 5]
        [--only synthetic|reference|compare] [--reference-dir DIR] [--reference-size 4000]
        [--against REV] [--maps 50]
"""

import argparse
import importlib
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.map_io import load_map
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


def default_reference_dir() -> str:
    """$ASCC_FRONTIER_BASELINE, else ../shared/bench/frontier_baseline from the repository's
    top level (this script is ascc_ros_pkg/ascc_eval/scripts/ in it)."""
    env = os.environ.get("ASCC_FRONTIER_BASELINE")
    if env:
        return env
    top = os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "..", "..")
    return os.path.normpath(os.path.join(top, "..", "shared", "bench", "frontier_baseline"))


def _run(cmd, cwd: str) -> str:
    return subprocess.run(cmd, cwd=cwd, check=True, capture_output=True, text=True).stdout


CPP_CPU_SEARCHES = 10        # extra searches of the C++ run whose CPU time is measured


def _child_cpu_ms(cmd, cwd: str) -> float:
    """CPU time [ms] (user + system) of one run of cmd."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    _run(cmd, cwd)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return 1e3 * ((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))


def cpp_cpu_per_search(cmd, cwd: str) -> float:
    """Mean CPU time [ms] of one C++ search: runs with 1 + CPP_CPU_SEARCHES searches and with
    1 search (the same start-up and map loading), best of 3 each, difference / searches."""
    one = min(_child_cpu_ms(cmd + ["1"], cwd) for _ in range(3))
    many = min(_child_cpu_ms(cmd + [str(1 + CPP_CPU_SEARCHES)], cwd) for _ in range(3))
    return (many - one) / CPP_CPU_SEARCHES


def ours_cpu_per_plan(run) -> float:
    """Mean CPU time [ms] of one of our plans, measured as the C++ search's is: CPU time of
    1 + CPP_CPU_SEARCHES plans in a row minus that of 1 plan, best of 3 each, divided by
    CPP_CPU_SEARCHES (warm caches on both sides)."""
    def batch(k: int) -> float:
        t0 = time.process_time()
        for _ in range(k):
            run()
        return (time.process_time() - t0) * 1e3
    one = min(batch(1) for _ in range(3))
    many = min(batch(1 + CPP_CPU_SEARCHES) for _ in range(3))
    return (many - one) / CPP_CPU_SEARCHES


def reference(ref_dir: str, n: int, repeat: int, params: PlannerParams) -> int:
    """The shared reference's steps (its README), then ours on its map_server files."""
    need = ("bfs_frontiers.cpp", "make_map.py", "to_mapserver.py")
    missing = [f for f in need if not os.path.isfile(os.path.join(ref_dir, f))]
    if missing:
        print(f"reference: skipped, {ref_dir} has no {', '.join(missing)} "
              "(set --reference-dir or $ASCC_FRONTIER_BASELINE)")
        return 0
    if shutil.which("g++") is None:
        print("reference: skipped, g++ not found on PATH")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        exe = os.path.join(tmp, "bfs")
        _run(["g++", "-O2", "-o", exe, "bfs_frontiers.cpp"], ref_dir)
        raw = os.path.join(tmp, f"map{n}.raw")
        w, h, rx, ry = (int(v) for v in _run([sys.executable, "make_map.py", raw, str(n)],
                                             ref_dir).split())
        base = os.path.join(tmp, f"office{n}")
        x, y = (float(v) for v in _run([sys.executable, "to_mapserver.py", raw, str(n), base,
                                        str(rx)], ref_dir).split())
        grid, info = load_map(base + ".yaml")
        col, row = info.world_to_cell(x, y)
        if (row, col) != (ry, rx):
            print(f"reference: robot ({x}, {y}) m is cell (row {row}, col {col}), "
                  f"not the reference's ({ry}, {rx})")
            return 1
        # Interleaved, so that both see the same machine load. OpenCV single-threaded while
        # timing, as the C++ search is (its worker threads add CPU time and, on a loaded
        # 2-core machine, waits).
        cpp_ms, ours_ms, result, cpp_out = float("inf"), float("inf"), None, ""
        ours_cpu = []
        cmd = [exe, raw, str(w), str(h), str(rx), str(ry)]
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        # One untimed plan first: it loads the compiled (numba) kernels, which the explorer
        # node pays once per process, not per plan; reported apart.
        c0 = time.process_time()
        plan(grid, info, (x, y), params)
        first_cpu = (time.process_time() - c0) * 1e3
        for _ in range(repeat):
            cpp_out = _run(cmd + ["1"], tmp)
            cpp_ms = min(cpp_ms, float(dict(kv.split("=") for kv in cpp_out.split())["best_ms"]))
            t0, c0 = time.perf_counter(), time.process_time()
            res = plan(grid, info, (x, y), params)
            wall = (time.perf_counter() - t0) * 1e3
            ours_cpu.append((time.process_time() - c0) * 1e3)
            if wall < ours_ms:
                ours_ms, result = wall, res
        cpp_cpu = cpp_cpu_per_search(cmd, tmp)
        ours_warm = ours_cpu_per_plan(lambda: plan(grid, info, (x, y), params))
        cv2.setNumThreads(threads)
    t = result.timings_ms
    known = 100.0 * float(np.count_nonzero(grid != -1)) / grid.size
    print(f"reference {ref_dir}: {n} x {n} cells at {info.resolution} m, {known:.1f} % known, "
          f"robot at ({x:.3f}, {y:.3f}) m, best of {repeat} (interleaved)")
    print(f"  C++ bfs_frontiers -O2: {cpp_ms:8.1f} ms   ({cpp_out.strip()})")
    print(f"  ours plan():           {ours_ms:8.1f} ms   (phase1 {t['phase1']:.1f}, phase2 "
          f"{t['phase2']:.1f}, phase3 {t['phase3']:.1f}, utility {t['utility']:.1f}; "
          f"{result.frontiers.n_candidates} candidates, status {result.status})")
    print(f"  ours plan(), CPU time: {min(ours_cpu):8.1f} ms   (process_time, best of {repeat}; "
          f"mean {np.mean(ours_cpu):.1f})")
    print(f"  ours first plan, CPU:  {first_cpu:8.1f} ms   (untimed, first in this process: "
          f"it loads the compiled kernels)")
    print(f"  C++ CPU time:          {cpp_cpu:8.1f} ms   (mean per search: the process CPU time "
          f"of a run with {1 + CPP_CPU_SEARCHES} searches minus one with 1, best of 3 each)")
    print(f"  ours CPU time, alike:  {ours_warm:8.1f} ms   ({1 + CPP_CPU_SEARCHES} plans in a row "
          f"minus 1, best of 3 each: warm caches, as the C++ figure)")
    print(f"  ratio ours / C++:      {ours_ms / cpp_ms:8.2f}   (wall, best of each)")
    print(f"  CPU ratio ours / C++:  {np.mean(ours_cpu) / cpp_cpu:8.2f}   (mean CPU per search; "
          f"ours interleaved with the C++ runs, i.e. after they emptied the caches)")
    print(f"  CPU ratio, alike:      {ours_warm / cpp_cpu:8.2f}   (both measured the same way)")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 2000, 3000, 4000])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--explored", type=float, default=0.8,
                    help="radius of the explored disc as a fraction of half the map side")
    ap.add_argument("--only", choices=("synthetic", "reference", "compare"),
                    help="run only the synthetic sizes, the shared reference, or the "
                         "comparison with --against")
    ap.add_argument("--against", metavar="REV",
                    help="git revision whose frontier_detector the comparison runs beside "
                         "this one")
    ap.add_argument("--maps", type=int, default=50,
                    help="random maps per strategy for the comparison")
    ap.add_argument("--reference-dir", default=default_reference_dir(),
                    help="the shared C++ reference (default: %(default)s)")
    ap.add_argument("--reference-size", type=int, default=4000,
                    help="map side [cells] given to the reference's make_map.py")
    args = ap.parse_args()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, cores {os.cpu_count()}")
    if args.only == "compare":
        if not args.against:
            ap.error("--only compare needs --against REV")
        return compare(args)
    if args.only != "reference":
        synthetic(args)
    if args.only != "synthetic":
        return reference(args.reference_dir, args.reference_size, args.repeat, PlannerParams())
    return 0


def import_revision(rev: str, tmp: str):
    """frontier_detector's goal_selection module at git revision rev, as package fd_<rev>."""
    top = os.path.normpath(os.path.join(os.path.dirname(os.path.realpath(__file__)),
                                        "..", "..", ".."))
    src = "ascc_ros_pkg/frontier_detector/src/frontier_detector"
    name = "fd_" + "".join(ch for ch in rev if ch.isalnum())
    dest = os.path.join(tmp, name)
    os.makedirs(dest)
    files = subprocess.run(["git", "-C", top, "ls-tree", "--name-only", f"{rev}:{src}"],
                           check=True, capture_output=True, text=True).stdout.split()
    for f in files:
        if f.endswith(".py"):
            text = subprocess.run(["git", "-C", top, "show", f"{rev}:{src}/{f}"], check=True,
                                  capture_output=True, text=True).stdout
            with open(os.path.join(dest, f), "w") as fh:
                fh.write(text)
    sys.path.insert(0, tmp)
    return importlib.import_module(name + ".goal_selection")


def plan_differences(a, b) -> list:
    """Names of the plan fields that differ between two plans (exact comparison)."""
    out = []
    if a.status != b.status:
        out.append("status")
    fa, fb = a.frontiers, b.frontiers
    for name in ("phase1_rc", "phase2_rc", "goals_rc", "centroids_rc", "cluster_cells",
                 "observe_only", "unreachable_rc", "phase2_cluster", "traversable", "path_m"):
        va, vb = getattr(fa, name), getattr(fb, name)
        if (va is None) != (vb is None) or (va is not None and not np.array_equal(va, vb)):
            out.append(name)
    if fa.robot_rc != fb.robot_rc:
        out.append("robot_rc")
    if (a.scores is None) != (b.scores is None):
        out.append("scores")
    elif a.scores is not None:
        for name in ("info", "nav", "loc", "path_m", "total"):
            if not np.array_equal(getattr(a.scores, name), getattr(b.scores, name)):
                out.append("scores." + name)
    if a.goal_xy != b.goal_xy or a.goal_yaw != b.goal_yaw:
        out.append("goal")
    return out


def compare(args) -> int:
    """Identical plans of this revision and --against on random maps, then CPU per plan."""
    rng = np.random.default_rng(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        old = import_revision(args.against, tmp)
        n_plans, differing, statuses = 0, [], {}
        for strategy in ("utility", "nearest"):
            for i in range(args.maps):
                n = int(rng.integers(200, 900))
                seed = int(rng.integers(0, 1 << 30))
                grid, robot = make_map(n, seed, float(rng.uniform(0.3, 0.95)))
                info = GridInfo(RESOLUTION, n, n)
                # A robot cell anywhere known now and then, not only the free one.
                if i % 5 == 4:
                    known = np.argwhere(grid != -1)
                    robot = tuple(int(v) for v in known[rng.integers(0, known.shape[0])])
                x, y = info.cell_to_world(np.array([robot[1]]), np.array([robot[0]]))
                xy = (float(x[0]), float(y[0]))
                entropy = float(rng.uniform(0.0, 3.0))
                new_p = PlannerParams(strategy=strategy)
                old_p = old.PlannerParams(strategy=strategy)
                a = plan(grid, info, xy, new_p, entropy)
                b = old.plan(grid, info, xy, old_p, entropy)
                n_plans += 1
                statuses[a.status] = statuses.get(a.status, 0) + 1
                diff = plan_differences(a, b)
                if diff:
                    differing.append((strategy, n, seed, diff))
        print(f"compare with {args.against}: {n_plans} plans on random maps "
              f"(200-900 cells, both strategies), statuses {statuses}: "
              f"{n_plans - len(differing)} identical, {len(differing)} differ")
        for d in differing[:10]:
            print("  differs:", d)
        ref = os.path.join(args.reference_dir, "make_map.py")
        if os.path.isfile(ref):
            n = args.reference_size
            raw = os.path.join(tmp, f"map{n}.raw")
            _, _, rx, ry = (int(v) for v in _run([sys.executable, "make_map.py", raw, str(n)],
                                                 args.reference_dir).split())
            base = os.path.join(tmp, f"office{n}")
            x, y = (float(v) for v in _run([sys.executable, "to_mapserver.py", raw, str(n),
                                            base, str(rx)], args.reference_dir).split())
            grid, info = load_map(base + ".yaml")
            cpu = {"old": float("inf"), "new": float("inf")}
            parts = {"old": {}, "new": {}}
            # The plans time their parts with time.perf_counter: switched to the process's
            # CPU clock for this loop, they give CPU time per part (wall time means little
            # on a loaded machine).
            wall_clock, time.perf_counter = time.perf_counter, time.process_time
            threads = cv2.getNumThreads()
            cv2.setNumThreads(1)                 # single-threaded, as in the reference mode
            for _ in range(args.repeat):
                for key, fn, params in (("old", old.plan, old.PlannerParams()),
                                        ("new", plan, PlannerParams())):
                    t0 = time.process_time()
                    res = fn(grid, info, (x, y), params)
                    cpu[key] = min(cpu[key], (time.process_time() - t0) * 1e3)
                    for name, ms in res.timings_ms.items():
                        parts[key][name] = min(parts[key].get(name, float("inf")), ms)
            time.perf_counter = wall_clock
            cv2.setNumThreads(threads)
            print(f"reference map {n} x {n}: CPU per plan (process_time, best of "
                  f"{args.repeat}, alternating): {args.against} {cpu['old']:.1f} ms, "
                  f"this tree {cpu['new']:.1f} ms")
            for key, label in (("old", args.against), ("new", "this tree")):
                print(f"  {label} per part (CPU, best of {args.repeat}): " + ", ".join(
                    f"{name} {parts[key][name]:.1f}"
                    for name in ("phase1", "phase2", "phase3", "utility")))
    return 1 if differing else 0


def synthetic(args) -> None:
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


if __name__ == "__main__":
    sys.exit(main())
