#!/usr/bin/env python3
"""Separate machines, for real: each robot and the workstation in its own Linux network
namespace (needs root), both setups of thesis 3.2, one robot's link cut mid-run.

    sudo -E python ascc_ros_pkg/colloc_fusion/scripts/netns_colloc.py
        [--setups centralized distributed] [--method thesis|information|ci]

Namespaces cf_ws (workstation, 10.77.0.1: roscore, the simulator, centralized fusion) and
cf_robotA/B/C (10.77.0.11-13: the robot's Create driver, camera, amcl, detector,
target_estimator, distributed fusion), each with one veth on a bridge in cf_br; every
process gets ROS_MASTER_URI=http://10.77.0.1:11311 and its own ROS_IP; no address outside
10.77.0.0/24 is used. Per setup, a monitor inside cf_ws waits until the fusion (the
workstation's, or robotA's and robotC's own) uses all three robots, measures each robot
link's traffic for --measure-s, cuts robotB's link (ip link set down), requires the
fusion to go on from robotA and robotC (robotB left out) and to take robotB back after
the link returns. Prints one JSON line per setup; exit status 0 when every check passed.
The namespaces are removed at the end (also on failure).
"""
import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
WORLD = os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds", "three_robots.yaml")
ROBOTS = {"robotA": ("10.77.0.11", "2.5 1.5 0.9"), "robotB": ("10.77.0.12", "6.5 1.5 2.2"),
          "robotC": ("10.77.0.13", "2.8 4.8 -0.6")}
WS_IP = "10.77.0.1"
MASTER = "http://%s:11311" % WS_IP
BRIDGE_NS = "cf_br"
TMP = "/tmp/cf_netns"


def sh(*cmd, check=True):
    return subprocess.run(list(cmd), check=check, capture_output=True, text=True)


def ns_of(host):
    return "cf_ws" if host == "ws" else "cf_" + host


def setup_network():
    teardown_network()
    sh("ip", "netns", "add", BRIDGE_NS)
    sh("ip", "-n", BRIDGE_NS, "link", "add", "br0", "type", "bridge")
    sh("ip", "-n", BRIDGE_NS, "link", "set", "br0", "up")
    hosts = [("ws", WS_IP)] + [(r, ip) for r, (ip, _) in ROBOTS.items()]
    for i, (host, ip) in enumerate(hosts):
        ns = ns_of(host)
        sh("ip", "netns", "add", ns)
        a, b = "cfv%da" % i, "cfv%db" % i  # made in the root namespace, moved at once
        sh("ip", "link", "add", a, "type", "veth", "peer", "name", b)
        sh("ip", "link", "set", a, "netns", ns)
        sh("ip", "link", "set", b, "netns", BRIDGE_NS)
        sh("ip", "-n", ns, "link", "set", a, "name", "eth0")
        sh("ip", "-n", ns, "addr", "add", ip + "/24", "dev", "eth0")
        sh("ip", "-n", ns, "link", "set", "eth0", "up")
        sh("ip", "-n", ns, "link", "set", "lo", "up")
        sh("ip", "-n", BRIDGE_NS, "link", "set", b, "master", "br0")
        sh("ip", "-n", BRIDGE_NS, "link", "set", b, "up")


def teardown_network():
    for ns in [BRIDGE_NS, "cf_ws"] + ["cf_" + r for r in ROBOTS]:
        sh("ip", "netns", "del", ns, check=False)


def start(host, ip, cmd, log_name):
    env = dict(os.environ, ROS_MASTER_URI=MASTER, ROS_IP=ip,
               ROS_HOME=os.path.join(TMP, host), ROS_LOG_DIR=os.path.join(TMP, host, "log"))
    env.pop("ROS_HOSTNAME", None)
    os.makedirs(env["ROS_LOG_DIR"], exist_ok=True)
    log = open(os.path.join(TMP, log_name + ".log"), "w")
    return subprocess.Popen(["ip", "netns", "exec", ns_of(host)] + cmd, env=env, stdout=log,
                            stderr=subprocess.STDOUT, start_new_session=True)


def stop(procs):
    for p in reversed(procs):
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGINT)
    for p in reversed(procs):
        try:
            p.wait(30.0)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


def run_setup(setup, method, args):
    links = os.path.join(TMP, "links")
    os.makedirs(links, exist_ok=True)
    procs = [start("ws", WS_IP, ["roscore", "-p", "11311"], setup + "_roscore")]
    try:
        procs.append(start("ws", WS_IP, [
            "roslaunch", "--wait", "ascc_sim", "sim.launch", "world:=" + WORLD,
            "robots:=robotA robotB robotC", "drivers:=false", "wait_for_drivers_s:=60",
            "link_dir:=" + links, "seed:=%d" % args.seed], setup + "_sim"))
        deadline = time.monotonic() + 120.0  # the robots' nodes must start on sim time
        while sh("ip", "netns", "exec", "cf_ws", "env", "ROS_MASTER_URI=" + MASTER,
                 "ROS_IP=" + WS_IP, "rosparam", "get", "/use_sim_time",
                 check=False).stdout.strip() != "true":
            if time.monotonic() > deadline:
                raise RuntimeError("the simulator's launch did not set /use_sim_time")
            time.sleep(0.5)
        for robot, (ip, pose) in ROBOTS.items():
            x, y, a = pose.split()
            procs.append(start(robot, ip, [
                "roslaunch", "--wait", "colloc_fusion", "sim_robot.launch", "robot:=" + robot,
                "x:=" + x, "y:=" + y, "a:=" + a, "world:=" + WORLD, "driver:=true",
                "link_dir:=" + links, "setup:=" + setup, "method:=" + method,
                "seed:=%d" % args.seed], setup + "_" + robot))
        if setup == "centralized":
            procs.append(start("ws", WS_IP, ["rosrun", "colloc_fusion", "fusion",
                                             "_method:=" + method], setup + "_fusion"))
            topics = ["fused_target"]
        else:
            topics = ["robotA/fused_target", "robotC/fused_target"]
        monitor = subprocess.run(
            ["ip", "netns", "exec", "cf_ws", sys.executable, os.path.abspath(__file__),
             "--monitor", "--topics"] + topics + ["--measure-s", str(args.measure_s),
                                                  "--cut-s", str(args.cut_s)],
            env=dict(os.environ, ROS_MASTER_URI=MASTER, ROS_IP=WS_IP),
            capture_output=True, text=True, timeout=args.timeout_s)
        sys.stderr.write(monitor.stderr[-3000:])
        lines = [ln for ln in monitor.stdout.splitlines() if ln.startswith("{")]
        result = json.loads(lines[-1]) if lines else {"ok": False, "error": "no result"}
        result["setup"] = setup
        return result
    finally:
        stop(procs)


def link_bytes(robot):
    out = json.loads(sh("ip", "-n", "cf_" + robot, "-s", "-j", "link", "show", "eth0").stdout)
    st = out[0]["stats64"]
    return st["tx"]["bytes"], st["rx"]["bytes"]


def monitor(args):
    """Runs inside cf_ws: waits, measures, cuts robotB's link, checks, restores."""
    import rospy
    from std_msgs.msg import String

    rospy.init_node("netns_monitor", disable_signals=True)
    latest = {}

    def cb(msg, topic):
        latest[topic] = json.loads(msg.data)

    for t in args.topics:
        rospy.Subscriber(t + "/status", String, cb, callback_args=t, queue_size=10)
    three, two = ["robotA", "robotB", "robotC"], ["robotA", "robotC"]

    def wait(robots, timeout_s, what):
        deadline = time.monotonic() + timeout_s
        while not all(latest.get(t, {}).get("robots") == robots for t in args.topics):
            if time.monotonic() > deadline:
                raise AssertionError("%s: not within %.0f s wall; last status %s"
                                     % (what, timeout_s, latest))
            time.sleep(0.1)
        return rospy.get_time()

    result = {"ok": False, "topics": args.topics}
    try:
        wait(three, 300.0, "fusing three robots")
        while rospy.get_time() < 15.0:
            time.sleep(0.2)
        before = {r: link_bytes(r) for r in ROBOTS}
        t0 = time.monotonic()
        time.sleep(args.measure_s)
        dt = time.monotonic() - t0
        result["link_kB_per_s"] = {
            r: {"tx": round((link_bytes(r)[0] - before[r][0]) / dt / 1e3, 1),
                "rx": round((link_bytes(r)[1] - before[r][1]) / dt / 1e3, 1)}
            for r in ROBOTS}
        result["three_robots_status"] = {t: latest[t] for t in args.topics}
        sh("ip", "-n", "cf_robotB", "link", "set", "eth0", "down")
        t_cut = rospy.get_time()
        t_two = wait(two, 60.0, "fusing robotA and robotC after robotB's link is cut")
        result["left_out_after_cut_s"] = round(t_two - t_cut, 2)
        result["reason"] = {t: latest[t]["left_out"].get("robotB") for t in args.topics}
        n0 = {t: latest[t]["stamp"] for t in args.topics}
        time.sleep(args.cut_s)
        assert all(latest[t]["stamp"] > n0[t] and latest[t]["robots"] == two
                   for t in args.topics), "fusion stalled while robotB was cut: %s" % latest
        sh("ip", "-n", "cf_robotB", "link", "set", "eth0", "up")
        t_up = rospy.get_time()
        t_back = wait(three, 120.0, "robotB back after its link returned")
        result["back_after_link_up_s"] = round(t_back - t_up, 2)
        result["ok"] = True
    except AssertionError as err:
        result["error"] = str(err)
    finally:
        sh("ip", "-n", "cf_robotB", "link", "set", "eth0", "up", check=False)
    print(json.dumps(result), flush=True)
    rospy.signal_shutdown("done")
    return 0 if result["ok"] else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--setups", nargs="+", default=["centralized", "distributed"],
                    choices=["centralized", "distributed"])
    ap.add_argument("--method", default="thesis")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--measure-s", type=float, default=10.0, help="[s wall] traffic")
    ap.add_argument("--cut-s", type=float, default=10.0, help="[s wall] robotB cut off")
    ap.add_argument("--timeout-s", type=float, default=900.0)
    ap.add_argument("--monitor", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--topics", nargs="*", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.monitor:
        return monitor(args)
    if os.geteuid() != 0:
        print("netns_colloc: needs root (network namespaces)", file=sys.stderr)
        return 2
    shutil.rmtree(TMP, ignore_errors=True)
    os.makedirs(TMP)
    ok = True
    try:
        setup_network()
        for setup in args.setups:
            res = run_setup(setup, args.method, args)
            print(json.dumps(res), flush=True)
            ok = ok and res.get("ok", False)
    finally:
        teardown_network()
    print("netns_colloc: %s (logs in %s)" % ("PASSED" if ok else "FAILED", TMP))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
