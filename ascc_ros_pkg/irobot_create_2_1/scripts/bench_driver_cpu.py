"""CPU share of the driver node on the simulator's virtual Create (issue 24: under 2 % of
one core at a real-time factor of 1).

Starts `ascc_sim`'s sim.launch (--world, real-time factor --rtf, the driver from this
source tree) on a free master port, an idle rospy node (`cpu_probe`: init_node, spin) on
the same master, and a `cmd_vel` publisher turning the robot on the spot at --cmd-rate-hz;
after --warmup-s it samples /proc/<pid>/stat of the driver and the probe for --duration-s
(wall) and prints each one's CPU time (user + system, all threads) in % of one core. The
probe's share is the floor every rospy node pays under simulated time (its /clock
subscription at the simulator's 100 Hz, rospy's threads); on the robot there is no /clock.

--tf-listeners N adds N idle nodes listening to TF (a tf2 Buffer and TransformListener, as
the mapper, the navigator and the explorer each have: 3 in the exploration stack): the
driver's odom -> base_link transforms go to each, and rospy writes to every subscriber
from its own thread.

--robot runs no simulator: the virtual Create (virtual_create.launch) on wall time, the
driver from create.launch, nothing on /clock: the conditions on the robot, where the
serial stream is the only clock. The probe's share is then rospy's own floor.

With --compare REV, a second simulator (with --robot: a second virtual Create) on another
port runs the driver node of git revision REV (its `ros/driver_node.py`, on this tree's
other modules) at the same time, so both see the same machine load; its share is printed
beside. With --robot, --compare-params "NAME=VALUE ..." runs this tree's driver there
instead, with those private parameters over config/create.yaml (an A/B of a setting).

    python3 ascc_ros_pkg/irobot_create_2_1/scripts/bench_driver_cpu.py [--duration-s 90]
        [--world corridor] [--rtf 1] [--compare 525e5cb] [--tf-listeners 3] [--robot]
        [--compare-params "publish_rate_hz=20"]
"""
import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time

from ascc_common.ports import free_port

TICK = os.sysconf("SC_CLK_TCK")
HERE = os.path.dirname(os.path.realpath(__file__))
TOP = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
PROBE_CODE = "import rospy; rospy.init_node('cpu_probe'); rospy.spin()"
TWIST_CODE = """import rospy, sys
from geometry_msgs.msg import Twist
rospy.init_node('spin_cmd')
pub = rospy.Publisher('cmd_vel', Twist, queue_size=1)
msg = Twist(); msg.angular.z = 0.3
rate = rospy.Rate(float(sys.argv[1]))
while not rospy.is_shutdown():
    pub.publish(msg); rate.sleep()
"""
TF_LISTENER_CODE = """import rospy, tf2_ros
rospy.init_node('tf_listener', anonymous=True)
buf = tf2_ros.Buffer(); listener = tf2_ros.TransformListener(buf)
rospy.spin()
"""
ROBOT_LAUNCH = """<launch>
  <include file="$(find irobot_create_2_1)/launch/virtual_create.launch">
    <arg name="link" value="%(link)s"/>
  </include>
  %(driver)s
</launch>
"""
ROBOT_DRIVER = """<include file="$(find irobot_create_2_1)/launch/create.launch">
    <arg name="port" value="%(link)s"/>
  </include>"""
# create.launch's node, with parameters over its config file (--compare-params)
ROBOT_DRIVER_PARAMS = """<node pkg="irobot_create_2_1" type="driver" name="irobot_create_2_1">
    <rosparam command="load" file="$(find irobot_create_2_1)/config/create.yaml"/>
    <param name="port" value="%(link)s"/>
    %(params)s
  </node>"""
OLD_DRIVER_CODE = """import importlib.util, sys
spec = importlib.util.spec_from_file_location('driver_node_rev', sys.argv[1])
m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m); m.main()
"""


def env_for(port: int):
    env = dict(os.environ)
    env["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % port
    if not env.get("ROS_IP") and not env.get("ROS_HOSTNAME"):
        env["ROS_IP"] = "127.0.0.1"
    return env


def wait_for_clock(port: int, timeout_s: float = 120.0, topic: str = "/clock") -> bool:
    """Wait until the master on port lists a ``topic`` publisher (/clock: the simulator is
    up and /use_sim_time is set, so rospy nodes started now follow simulated time)."""
    import rosgraph
    master = rosgraph.Master("/bench_driver_cpu", master_uri="http://127.0.0.1:%d" % port)
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        try:
            if any(t == topic for t, _ in master.getSystemState()[0]):
                return True
        except Exception:  # noqa: BLE001 - master not up yet
            pass
        time.sleep(1.0)
    return False


def cpu_s(pid: int):
    try:
        with open("/proc/%d/stat" % pid) as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / TICK


def find_driver(root_pid: int, name: bytes = b"driver"):
    """pid of the driver node (``__name:=name``) below a roslaunch process, or None."""
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % entry, "rb") as f:
                args = f.read().split(b"\0")
            with open("/proc/%s/stat" % entry) as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except OSError:
            continue
        if ppid == root_pid and b"__name:=" + name in args:
            return int(entry)
    return None


def start_sim(port, world, rtf, link_dir, log, drivers=True):
    return subprocess.Popen(
        ["roslaunch", "-p", str(port), "ascc_sim", "sim.launch", "world:=" + world,
         "real_time_factor:=%s" % rtf, "link_dir:=" + link_dir,
         "drivers:=%s" % ("true" if drivers else "false")]
        + ([] if drivers else ["wait_for_drivers_s:=0"]),
        env=env_for(port), stdout=log, stderr=subprocess.STDOUT)


def start_runs(args, world, tmp, log, procs):
    """The simulator with this tree's driver and, with --compare, a second one with REV's
    driver node: [(label, master port, roslaunch process, driver pid or None)]; None if a
    simulator did not come up. Every process started is appended to procs."""
    port = free_port()
    if args.robot:
        runs = [("driver (this tree, no simulator)", port,
                 start_robot(port, tmp, "a", log, procs, ROBOT_DRIVER), None)]
        if args.compare_params:
            params = "\n    ".join('<param name="%s" value="%s"/>' % tuple(kv.split("=", 1))
                                   for kv in args.compare_params.split())
            port_b = free_port()
            runs.append(("driver (%s)" % args.compare_params, port_b,
                         start_robot(port_b, tmp, "b", log, procs,
                                     ROBOT_DRIVER_PARAMS.replace("%(params)s", params)), None))
        elif args.compare:
            port_b = free_port()
            start_robot(port_b, tmp, "b", log, procs, "")
            # the old node sets its private parameters in init_node: the master must be up
            if not wait_for_clock(port_b, topic="/virtual_create/ground_truth"):
                return None
            old = start_old_driver(args.compare, port_b, tmp, os.path.join(tmp, "b.pty"), log)
            procs.append(old)
            runs.append(("driver (%s)" % args.compare, port_b, None, old.pid))
        return runs
    sim = start_sim(port, world, args.rtf, os.path.join(tmp, "a"), log)
    procs.append(sim)
    runs = [("driver (this tree)", port, sim, None)]
    if not wait_for_clock(port):
        return None
    if args.compare:
        port_b = free_port()
        sim_b = start_sim(port_b, world, args.rtf, os.path.join(tmp, "b"), log, False)
        procs.append(sim_b)
        if not wait_for_clock(port_b):
            return None
        old = start_old_driver(args.compare, port_b, tmp,
                               os.path.join(tmp, "b", "create.pty"), log)
        procs.append(old)
        runs.append(("driver (%s)" % args.compare, port_b, sim_b, old.pid))
    return runs


def start_robot(port, tmp, name, log, procs, driver):
    """roslaunch of a virtual Create on wall time at tmp/NAME.pty and ``driver`` (launch
    XML, %(link)s = that pty) on the master at ``port``."""
    link = os.path.join(tmp, name + ".pty")
    path = os.path.join(tmp, name + ".launch")
    with open(path, "w") as f:
        f.write(ROBOT_LAUNCH % {"link": link, "driver": driver.replace("%(link)s", link)})
    robot = subprocess.Popen(["roslaunch", "-p", str(port), path], env=env_for(port),
                             stdout=log, stderr=subprocess.STDOUT)
    procs.append(robot)
    return robot


def start_old_driver(rev, port, tmp, link, log):
    """The driver node of git revision ``rev`` (its ros/driver_node.py on this tree's other
    modules, default parameters) on the master at ``port``, serving ``link``."""
    src = subprocess.run(
        ["git", "-C", TOP, "show", rev + ":ascc_ros_pkg/irobot_create_2_1/"
         "src/irobot_create_2_1/ros/driver_node.py"],
        check=True, capture_output=True, text=True).stdout
    path = os.path.join(tmp, "driver_node_rev.py")
    with open(path, "w") as f:
        f.write(src)
    return subprocess.Popen(
        [sys.executable, "-c", OLD_DRIVER_CODE, path, "__name:=driver", "_port:=" + link],
        env=env_for(port), stdout=log, stderr=subprocess.STDOUT)


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration-s", type=float, default=90.0, help="wall seconds measured")
    ap.add_argument("--warmup-s", type=float, default=20.0, help="wall seconds before")
    ap.add_argument("--world", default="corridor", help="ascc_sim world name")
    ap.add_argument("--rtf", default="1", help="the simulator's real-time factor cap")
    ap.add_argument("--cmd-rate-hz", type=float, default=10.0)
    ap.add_argument("--compare", metavar="REV", help="also run REV's driver node alongside")
    ap.add_argument("--tf-listeners", type=int, default=0,
                    help="idle TF listener nodes beside each driver (3 in the stack)")
    ap.add_argument("--robot", action="store_true",
                    help="no simulator: the virtual Create on wall time (as on the robot)")
    ap.add_argument("--compare-params", metavar="'NAME=VALUE ...'",
                    help="with --robot: a second driver of this tree with these parameters")
    args = ap.parse_args()
    if args.compare_params and not args.robot:
        ap.error("--compare-params needs --robot")
    if args.compare_params and args.compare:
        ap.error("--compare and --compare-params: one or the other")
    return args


def main() -> int:
    args = parse_args()
    world = os.path.join(TOP, "ascc_ros_pkg", "ascc_sim", "worlds", args.world + ".yaml")
    tmp = tempfile.mkdtemp(prefix="bench_driver_cpu_")
    procs = []
    log = open(os.path.join(tmp, "log.txt"), "w")
    try:
        runs = start_runs(args, world, tmp, log, procs)
        if runs is None:
            print("a simulator did not start; see %s" % log.name)
            return 1
        probes = []
        for _, p, _, _ in runs:
            for code, extra in ([(TF_LISTENER_CODE, [])] * args.tf_listeners
                                + [(PROBE_CODE, []), (TWIST_CODE, [str(args.cmd_rate_hz)])]):
                procs.append(subprocess.Popen([sys.executable, "-c", code] + extra,
                                              env=env_for(p), stdout=log,
                                              stderr=subprocess.STDOUT))
            probes.append(procs[-2].pid)
        time.sleep(args.warmup_s)
        pids = []
        for (name, _, launch, pid), probe in zip(runs, probes):
            pid = pid or find_driver(launch.pid,
                                     b"irobot_create_2_1" if args.robot else b"driver")
            if pid is None:
                print("no driver process found for %s; see %s" % (name, log.name))
                return 1
            pids += [(name, pid), ("cpu_probe beside it", probe)]
        load0 = os.getloadavg()
        c0 = [cpu_s(pid) for _, pid in pids]
        t0 = time.time()
        time.sleep(args.duration_s)
        c1 = [cpu_s(pid) for _, pid in pids]
        wall = time.time() - t0
        print("%s, %.0f s wall, cmd_vel %.0f Hz, %d TF listener(s), load average %.1f -> %.1f"
              % ("no simulator (wall time)" if args.robot else
                 "%s, rtf %s" % (args.world, args.rtf), wall, args.cmd_rate_hz,
                 args.tf_listeners, load0[0], os.getloadavg()[0]))
        for (name, _), a, b in zip(pids, c0, c1):
            share = "gone" if a is None or b is None else "%.2f %%" % (100.0 * (b - a) / wall)
            print("  %-28s %s of one core" % (name, share))
        return 0
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()


if __name__ == "__main__":
    sys.exit(main())
