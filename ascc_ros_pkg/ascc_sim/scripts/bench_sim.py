#!/usr/bin/env python3
"""Benchmark of ascc_sim: prints the pure-core costs and the real-time factor achieved
end to end (simulator + irobot_create_2_1 drivers, real_time_factor 0 = flat out).

    bench_sim.py [--sim-seconds 30] [--skip-ros]

Pure core: ray casting [ms per scan] and one physics step [us per robot] on the shipped
worlds (CPU time, best of 5). End to end: for 1 robot (office) and 3 robots
(three_robots) it starts its own roslaunch (own master on a free port), drives the robots
in circles through cmd_vel, runs ``--sim-seconds`` of simulated time and reports the
achieved real-time factor, whether the drivers kept up (the lag of their last odom
behind the simulator's clock, bytes dropped on the pty links) and the CPU time used by
the simulator and by the drivers.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from ascc_common.ports import free_port

CONFIGS = {
    "1 robot (office)": ("office.yaml", "/"),
    "3 robots (three_robots)": ("three_robots.yaml", "robotA robotB robotC"),
}


def worlds_dir() -> str:
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "worlds")


def best_ms(fn, n: int = 50, rep: int = 5) -> float:
    best = float("inf")
    for _ in range(rep):
        t0 = time.process_time()
        for _ in range(n):
            fn()
        best = min(best, (time.process_time() - t0) / n * 1e3)
    return best


def bench_core() -> None:
    print("pure core (CPU time, best of 5)")
    for name in ("office", "corridor", "lab", "apartment"):
        print("  %-10s ray cast %.2f ms/scan, full scan (circles, noise) %.2f ms, "
              "physics step + virtual Create %.0f us" % ((name,) + bench_world(name)))


def bench_world(name: str):
    """(ray cast [ms], full scan [ms], physics step [us]) in world ``name``."""
    from ascc_sim.sim import Simulation
    from ascc_sim.world import load_world
    from irobot_create_2_1 import protocol
    from irobot_create_2_1.virtual_create import VirtualCreate

    world = load_world(os.path.join(worlds_dir(), name + ".yaml"))
    robot = world.robots[0].name
    create = VirtualCreate()
    create.feed(protocol.start() + protocol.full() + protocol.stream([6])
                + protocol.drive_direct(150, 200))
    sim = Simulation(world, {robot: create}, seed=1)
    x, y, yaw = sim.laser_pose(robot)
    cast_ms = best_ms(lambda: sim.laser.caster.cast(x, y, yaw + sim.laser.angles))
    scan_ms = best_ms(lambda: sim.scan(robot))

    def step():
        sim.step(0.01)
        create.read_output()

    return cast_ms, scan_ms, best_ms(step, n=200) * 1e3


def cpu_of(pids) -> float:
    """User + system CPU seconds of processes (from /proc), 0 for vanished ones."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0.0
    for pid in pids:
        try:
            with open("/proc/%d/stat" % pid) as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick
        except (OSError, IndexError, ValueError):
            pass
    return total


def child_pids(parent: int, node: str):
    """PIDs of the children of ``parent`` running ROS node ``node``."""
    out = subprocess.run(["pgrep", "-P", str(parent)], capture_output=True, text=True)
    pids = []
    for pid in (int(p) for p in out.stdout.split()):
        try:
            with open("/proc/%d/cmdline" % pid, "rb") as f:
                if b"__name:=" + node.encode() + b"\0" in f.read() + b"\0":
                    pids.append(pid)
        except OSError:
            pass
    return pids


def run_child(world: str, robots: str, sim_seconds: float, port: int) -> dict:
    """One end-to-end run, in its own process (rospy can init only once). Starts a master
    first and joins it before /use_sim_time is set, so this process stays on wall time
    and does not have to take the /clock messages."""
    import rosgraph

    os.environ["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % port
    if not os.environ.get("ROS_IP") and not os.environ.get("ROS_HOSTNAME"):
        os.environ["ROS_IP"] = "127.0.0.1"  # master and nodes on loopback only
    stats_file = tempfile.mktemp(prefix="ascc_sim_bench_", suffix=".json")
    procs = [subprocess.Popen(["roscore", "-p", str(port)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        deadline = time.monotonic() + 60
        while not rosgraph.is_master_online():
            if time.monotonic() > deadline or procs[0].poll() is not None:
                raise RuntimeError("roscore did not come up on port %d" % port)
            time.sleep(0.2)
        import rospy

        rospy.init_node("bench_sim", disable_signals=True)
        procs.append(subprocess.Popen(
            ["roslaunch", "ascc_sim", "sim.launch",
             "world:=" + os.path.join(worlds_dir(), world), "robots:=" + robots,
             "real_time_factor:=0", "max_sim_time_s:=%g" % sim_seconds,
             "stats_file:=" + stats_file, "cmd_timeout_s:=2.0",
             "wait_for_scan_subscribers:=true"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        return _measure(procs[1], robots, stats_file)
    finally:
        for proc in reversed(procs):
            if proc.poll() is None:
                proc.terminate()
                proc.wait(30)
        if os.path.exists(stats_file):
            os.unlink(stats_file)


def _measure(launch, robots: str, stats_file: str) -> dict:
    import rospy
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import LaserScan

    prefixes = ["" if ns == "/" else ns + "/" for ns in robots.split()]
    last = {p: [0.0] for p in prefixes}
    subs = [rospy.Subscriber(p + "odom", Odometry,
                             lambda m, p=p: last[p].__setitem__(0, m.header.stamp.to_sec()),
                             queue_size=100) for p in prefixes]
    # Someone must listen to the scans: the simulator skips the scans nobody takes.
    scans = [0]
    subs += [rospy.Subscriber(p + "scan", LaserScan,
                              lambda m: scans.__setitem__(0, scans[0] + 1), queue_size=10)
             for p in prefixes]
    pubs = [rospy.Publisher(p + "cmd_vel", Twist, queue_size=1) for p in prefixes]
    circle = Twist()
    circle.linear.x, circle.angular.z = 0.15, 0.4
    cpu_sim = cpu_drv = 0.0
    while launch.poll() is None:  # the simulator ends the launch at max_sim_time_s
        for pub in pubs:
            pub.publish(circle)  # wall-time rate, ahead of the drivers' 2 s watchdog
        time.sleep(0.02)
        if not os.path.exists(stats_file):
            cpu_sim = max(cpu_sim, cpu_of(child_pids(launch.pid, "simulator")))
            cpu_drv = max(cpu_drv, cpu_of(child_pids(launch.pid, "driver")))
    for sub in subs:
        sub.unregister()
    if not os.path.exists(stats_file):
        raise RuntimeError("the simulator wrote no statistics (did it start?)")
    with open(stats_file) as f:
        stats = json.load(f)
    stats["driver_odom_lag_s"] = {p or "/": stats["sim_time_s"] - last[p][0]
                                  for p in prefixes}
    stats["scans_received"] = scans[0]
    stats["cpu_simulator_s"] = cpu_sim
    stats["cpu_drivers_s"] = cpu_drv
    return stats


def bench_ros(sim_seconds: float) -> None:
    print("end to end: simulator + drivers, real_time_factor 0, %.0f s of simulated time"
          % sim_seconds)
    for label, (world, robots) in CONFIGS.items():
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", world,
                              robots, str(sim_seconds), str(free_port())],
                             capture_output=True, text=True, timeout=1200)
        if out.returncode != 0:
            print("  %s: FAILED\n%s" % (label, out.stderr[-2000:]))
            continue
        s = json.loads(out.stdout.strip().splitlines()[-1])
        lag = max(s["driver_odom_lag_s"].values())
        dropped = sum(r["dropped_bytes"] for r in s["robots"].values())
        moved = np.mean([r["distance_m"] for r in s["robots"].values()])
        print("  %s:\n    real-time factor %.1f (%.0f s sim in %.1f s wall; simulator loop "
              "CPU %.2f s -> %.0f on a core of its own)\n    drivers: last odom %.2f s behind "
              "the clock, %d bytes dropped on the links, CPU %.1f s (whole run)\n"
              "    robots drove %.1f m each, %d scans received"
              % (label, s["achieved_real_time_factor"], s["sim_time_s"], s["wall_time_s"],
                 s["cpu_time_s"], s["sim_time_s"] / max(s["cpu_time_s"], 1e-9), lag,
                 dropped, s["cpu_drivers_s"], moved, s["scans_received"]))


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--child":
        world, robots, seconds, port = argv[1], argv[2], float(argv[3]), int(argv[4])
        print(json.dumps(run_child(world, robots, seconds, port)))
        return 0
    ap = argparse.ArgumentParser(description="ascc_sim benchmark")
    ap.add_argument("--sim-seconds", type=float, default=30.0,
                    help="simulated time per end-to-end run [s] (default 30)")
    ap.add_argument("--skip-ros", action="store_true", help="only the pure-core numbers")
    args = ap.parse_args(argv)
    print("machine: %d CPUs, load average %.2f, Python %s" % (
        os.cpu_count() or 0, os.getloadavg()[0], sys.version.split()[0]))
    bench_core()
    if not args.skip_ros:
        bench_ros(args.sim_seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
