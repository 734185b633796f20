#!/usr/bin/env python3
"""CPU budget of the robot-side stack (issue 24, part 3): driver, mapper, navigator,
explorer, at a real-time factor of 1 in the corridor.

Runs `launch/explore_demo.launch` (its own roslaunch on a free master port) for
--duration-s of simulated time (the exploration monitor ends the launch then, or earlier
when the explorer is done) and samples /proc/<pid>/stat of the launch's node processes
(children of that roslaunch, matched by their `__name:=`) every --period-s: CPU time
(user + system, all threads) and resident memory. Prints per node
  * mean CPU in % of one core over the run after --warmup-s (start-up excluded),
  * the worst --window-s window (60 s) of that node,
  * peak RSS [MB],
for the robot-side stack (the nodes that run on the robot: driver (irobot_create_2_1),
slam_gmapping, move_base, frontier_explorer), their total (mean and worst window of the
sum), and, for reference, the other nodes (simulator, measuring nodes); also the achieved
real-time factor (simulated / wall time) and the machine's load average, since on a
shared machine a starved simulator runs slower than asked and every node then does less
per wall second. Writes OUT/cpu.json (summary and samples) and the run's report.

Also runs `cpu_probe`, a rospy node that does nothing (init_node, spin) on the run's master
under simulated time: its share is what every rospy node of the run pays for being one
(its /clock subscription at the simulator's 100 Hz, rospy's own threads), none of which
exists on the robot, where there is no /clock. A node's own work is its share minus
about that floor.

--wall-clock runs the simulator on the wall clock instead (sim.launch use_sim_time:=false:
no /clock, the simulator stamps with the wall clock at a real-time factor of 1), so the
nodes run as on the robot; the probe then shows rospy's floor without /clock.

The measuring nodes must not make the robot's nodes work: without --record there is no
bag recorder (whose subscriptions to /tf, odom, scan and map cost the driver and the mapper
a connection each), the exploration monitor leaves /tf once it has the laser's mount and
does not count bumps (count_bumps:=false: its sensorPacket subscription would make the
driver build a sensor packet every 0.1 s).

    rosrun ascc_eval bench_cpu.py [--duration-s 600] [--world corridor] [--rtf 1]
        [--strategy utility] [--seed 0] [--window-s 60] [--warmup-s 20] [--out DIR]
        [--record] [--wall-clock]
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import time

from ascc_common.ports import free_port
from ascc_eval.launching import loopback_env

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.realpath(__file__)),
                                    "..", "..", ".."))
# Robot-side nodes: what the budget covers (not the simulator, not the measuring).
ROBOT_NODES = (("driver", "driver"), ("mapper", "slam_gmapping"),
               ("navigator", "move_base"), ("explorer", "frontier_explorer"))
TICK = os.sysconf("SC_CLK_TCK")
PROBE = "cpu_probe"
PROBE_CODE = "import rospy; rospy.init_node('%s'); rospy.spin()" % PROBE
PAGE = os.sysconf("SC_PAGE_SIZE")


def read_stat(pid: int):
    """(ppid, cpu seconds user + system, rss bytes) of a process, or None if it is gone."""
    try:
        with open("/proc/%d/stat" % pid, "rb") as f:
            data = f.read().decode("ascii", "replace")
    except OSError:
        return None
    fields = data[data.rindex(")") + 2:].split()        # after "pid (comm) "
    ppid = int(fields[1])
    cpu = (int(fields[11]) + int(fields[12])) / TICK     # utime, stime
    return ppid, cpu, int(fields[21]) * PAGE             # rss in pages


def node_name(pid: int):
    try:
        with open("/proc/%d/cmdline" % pid, "rb") as f:
            args = f.read().split(b"\0")
    except OSError:
        return None
    for a in args:
        if a.startswith(b"__name:="):
            return a[len(b"__name:="):].decode()
    return None


def launch_nodes(root_pid: int):
    """{node name: (cpu s, rss bytes)} of the node processes descending from root_pid."""
    stats = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            st = read_stat(int(entry))
            if st is not None:
                stats[int(entry)] = st
    children = {}
    for pid, (ppid, _, _) in stats.items():
        children.setdefault(ppid, []).append(pid)
    out, todo = {}, list(children.get(root_pid, []))
    while todo:
        pid = todo.pop()
        todo.extend(children.get(pid, []))
        name = node_name(pid)
        if name is not None and name not in out:
            out[name] = stats[pid][1:]
    return out


def window_max(t, cpu, window_s):
    """Largest mean CPU fraction over any interval of at least window_s (sample times)."""
    best, j = None, 0
    for i in range(len(t)):
        while j < len(t) and t[j] - t[i] < window_s:
            j += 1
        if j == len(t):
            break
        rate = (cpu[j] - cpu[i]) / (t[j] - t[i])
        best = rate if best is None else max(best, rate)
    return best


def summarise(samples, warmup_s, window_s):
    """Per node: mean %, worst window %, peak RSS MB; plus the robot stack's total."""
    t0 = samples[0]["t"]
    rows = [s for s in samples if s["t"] - t0 >= warmup_s] or samples
    names = sorted({n for s in rows for n in s["nodes"]})
    robot = [n for _, n in ROBOT_NODES]
    result = {}
    for name in names + ["robot_stack"]:
        members = robot if name == "robot_stack" else [name]
        pts = [(s["t"], sum(s["nodes"][m][0] for m in members),
                sum(s["nodes"][m][1] for m in members)) for s in rows
               if all(m in s["nodes"] for m in members)]
        if len(pts) < 2:
            continue
        t = [p[0] for p in pts]
        c = [p[1] for p in pts]
        worst = window_max(t, c, window_s)
        result[name] = {"mean_pct": 100.0 * (c[-1] - c[0]) / (t[-1] - t[0]),
                        "worst_window_pct": None if worst is None else 100.0 * worst,
                        "peak_rss_mb": max(p[2] for p in pts) / 1e6,
                        "seconds": t[-1] - t[0]}
    return result


def sim_time_s(run_dir):
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            return float(json.load(f).get("time_s"))
    except (OSError, ValueError, TypeError):
        return None


def run_and_sample(cmd, env, log_path, start, duration_s, period_s):
    """Run the launch (and the probe once the simulator is up) and sample its nodes every
    period_s until it ends; [{"t": s since start, "nodes": {name: (cpu s, rss)}}]."""
    samples = []
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT)
        probe = None
        deadline = start + 3.0 * duration_s + 300.0          # a starved run: give up
        try:
            while proc.poll() is None and time.time() < deadline:
                nodes = launch_nodes(proc.pid)
                if probe is None and "simulator" in nodes:
                    # Started with the simulator: roslaunch has set /use_sim_time by then.
                    probe = subprocess.Popen(
                        [sys.executable, "-c", PROBE_CODE, "__name:=" + PROBE], env=env,
                        stdout=log, stderr=subprocess.STDOUT)
                st = None if probe is None else read_stat(probe.pid)
                if nodes and st is not None:
                    nodes[PROBE] = st[1:]
                if nodes:
                    samples.append({"t": time.time() - start, "nodes": nodes})
                time.sleep(period_s)
        finally:
            if probe is not None:
                probe.send_signal(signal.SIGINT)
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                try:
                    proc.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    proc.kill()
            try:
                if probe is not None:
                    probe.wait(timeout=10)
            except subprocess.TimeoutExpired:
                probe.kill()
    return samples


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration-s", type=float, default=600.0,
                    help="simulated seconds to run (the monitor's max_time_s)")
    ap.add_argument("--world", default="corridor")
    ap.add_argument("--rtf", default="1", help="the simulator's real-time factor cap")
    ap.add_argument("--strategy", default="utility")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--period-s", type=float, default=1.0, help="sampling period (wall)")
    ap.add_argument("--window-s", type=float, default=60.0, help="worst-window length")
    ap.add_argument("--warmup-s", type=float, default=20.0,
                    help="wall seconds after the first sample left out (start-up)")
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "bench_cpu"))
    ap.add_argument("--record", action="store_true",
                    help="also record run.bag (explore_demo.launch's bag_recorder): its "
                         "subscriptions make the driver and the mapper send more")
    ap.add_argument("--wall-clock", action="store_true",
                    help="the simulator on the wall clock (no /clock), as on the robot; "
                         "needs --rtf 1")
    args = ap.parse_args()
    if args.wall_clock and float(args.rtf) != 1.0:
        ap.error("--wall-clock needs --rtf 1 (the simulator stamps with the wall clock)")
    run_dir = os.path.join(args.out, "%s_%s_seed%d" % (args.world, args.strategy, args.seed))
    os.makedirs(run_dir, exist_ok=True)
    port = free_port()
    env = loopback_env(port)
    cmd = ["roslaunch", "-p", str(port), os.path.join(ROOT, "launch", "explore_demo.launch"),
           "world:=%s" % args.world, "strategy:=%s" % args.strategy, "seed:=%d" % args.seed,
           "real_time_factor:=%s" % args.rtf, "output_dir:=%s" % run_dir,
           "max_time_s:=%g" % args.duration_s, "record:=%s" % str(args.record).lower(),
           "use_sim_time:=%s" % str(not args.wall_clock).lower(), "count_bumps:=false"]
    load0 = os.getloadavg()
    print("%s: %s for %.0f s simulated at rtf %s (%s), load average %.1f %.1f %.1f"
          % (args.world, args.strategy, args.duration_s, args.rtf,
             "wall clock, no /clock" if args.wall_clock else "simulated time, /clock",
             *load0))
    start = time.time()
    samples = run_and_sample(cmd, env, os.path.join(run_dir, "launch.log"), start,
                             args.duration_s, args.period_s)
    wall = time.time() - start
    load1 = os.getloadavg()
    if len(samples) < 3:
        print("too few samples (%d); see %s" % (len(samples), os.path.join(run_dir,
                                                                         "launch.log")))
        return 1
    summary = summarise(samples, args.warmup_s, args.window_s)
    sim = sim_time_s(run_dir)
    rtf = None if sim is None else sim / max(1e-9, samples[-1]["t"] - samples[0]["t"])
    print("wall %.0f s, simulated %s s (achieved real-time factor %s), load average at "
          "the end %.1f %.1f %.1f" % (wall, "?" if sim is None else "%.0f" % sim,
                                      "?" if rtf is None else "%.2f" % rtf, *load1))
    print("%-22s %10s %14s %12s" % ("node", "mean_%", "worst_%d_s_%%" % args.window_s,
                                    "peak_rss_MB"))
    order = [n for _, n in ROBOT_NODES] + ["robot_stack"]
    others = sorted(n for n in summary if n not in order)
    for name in order + others:
        s = summary.get(name)
        if s is None:
            print("%-22s %10s" % (name, "missing"))
            continue
        worst = s["worst_window_pct"]
        print("%-22s %10.1f %14s %12.0f" % (name, s["mean_pct"],
                                            "-" if worst is None else "%.1f" % worst,
                                            s["peak_rss_mb"]))
        if name == "robot_stack":
            print("-- not robot-side (%s: an idle rospy node, the floor of every node "
                  "%s):" % (PROBE, "on the wall clock" if args.wall_clock
                            else "under simulated time"))
    with open(os.path.join(args.out, "cpu.json"), "w") as f:
        json.dump({"args": vars(args), "wall_s": wall, "sim_s": sim, "rtf": rtf,
                   "load_start": load0, "load_end": load1, "summary": summary,
                   "samples": samples}, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
