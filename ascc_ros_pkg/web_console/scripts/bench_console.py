#!/usr/bin/env python3
"""Benchmark of the browser console in the simulator (issue 17's quality goals).

Starts its own ``roslaunch launch/sim/office.launch web_console:=true`` (own master on a
free port) and measures, on loopback:
  * video: frames per second reaching a page and their age (glass-to-glass: the camera
    frame's stamp to its arrival at the page: the server's age at sending + half the
    ping round trip), beside the camera's own rate and age at a ROS subscriber;
  * the server's CPU (web_console process, % of one core) with 0, 1 and 10 pages
    watching the video;
  * stop latency: a page drives (teleop, 20 Hz), then closes its socket mid-lease ("tab
    closed": from the close) or falls silent with the socket open ("network cut": from
    its last command, the worst case); time to the first zero command on ``cmd_vel``
    (the mux's output: the driver's input), ``--trials`` of each.
Then, as the simulated camera renders slower than 10 fps on a loaded machine, a second
console (namespace ``replay``) is fed one of its frames at 10 fps: video and CPU again.
Pages are web_console.client.ConsoleClient (the page's protocol over tornado's client).

  python ascc_ros_pkg/web_console/scripts/bench_console.py [--seconds 20] [--trials 20]
       [--json FILE]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np

from ascc_common.ports import free_port

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
NODE = "/web_console"


def cpu_seconds(pid: int) -> float:
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def node_pid(node: str) -> int:
    from xmlrpc.client import ServerProxy

    import rosgraph
    uri = rosgraph.Master("/bench_console").lookupNode(node)
    return ServerProxy(uri).getPid("/bench_console")[2]


def stats(values, scale=1.0):
    a = np.asarray(values, dtype=float) * scale
    if a.size == 0:
        return {"n": 0}
    return {"n": int(a.size), "median": round(float(np.median(a)), 1),
            "p95": round(float(np.percentile(a, 95)), 1), "max": round(float(a.max()), 1)}


def rtt_s(page) -> float:
    samples = []
    for i in range(5):
        t0 = time.monotonic()
        page.send({"type": "ping", "id": 1000 + i})
        page.wait(lambda c, i=i: [m for m in c.messages("pong") if m["id"] == 1000 + i], 2.0)
        samples.append(time.monotonic() - t0)
    return float(np.median(samples))


def bench_video(url, seconds, ns=""):
    import rospy
    from sensor_msgs.msg import CompressedImage

    from web_console.client import ConsoleClient
    ros_ages, lock = [], threading.Lock()

    def on_image(msg):
        with lock:
            stamp = msg.header.stamp.to_sec()
            ros_ages.append((time.monotonic(), round(stamp, 6), rospy.get_time() - stamp))
    sub = rospy.Subscriber(ns + "camera/image_raw/compressed", CompressedImage, on_image,
                           queue_size=1, buff_size=2 ** 22)
    page = ConsoleClient(url, keep_payload=False)
    half_rtt = rtt_s(page) / 2.0
    t0 = time.monotonic()
    time.sleep(seconds)
    t1 = time.monotonic()
    frames = [f for f in page.frames if f[1] == b"V" and t0 <= f[0] < t1]
    page.close()
    sub.unregister()
    with lock:
        ros = [(s, a) for t, s, a in ros_ages if t0 <= t < t1]
    # the same frame at a ROS subscriber and at the page: what the console adds
    at_ros = dict(ros)
    added = [f[2]["age_s"] + half_rtt - at_ros[round(f[2]["stamp"], 6)] for f in frames
             if round(f[2]["stamp"], 6) in at_ros]
    return {"page_fps": round(len(frames) / (t1 - t0), 2),
            "page_age_ms": stats([f[2]["age_s"] + half_rtt for f in frames], 1000.0),
            "camera_fps_at_ros": round(len(ros) / (t1 - t0), 2),
            "camera_age_ms_at_ros": stats([a for _, a in ros], 1000.0),
            "console_adds_ms": stats(added, 1000.0),
            "rtt_ms": round(2000.0 * half_rtt, 2)}


def bench_cpu(url, pid, seconds, counts=(0, 1, 10), ns=""):
    """The console's CPU with 0, 1, 10 pages, and beside it whether the robot keeps its
    cycles: the driver's odometry rate (its ~publish_rate_hz, 30 Hz cap)."""
    import rospy
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import CompressedImage

    from web_console.client import ConsoleClient
    odom, frames = [], []
    subs = [rospy.Subscriber("odom", Odometry, lambda m: odom.append(time.monotonic()),
                             queue_size=100),
            rospy.Subscriber(ns + "camera/image_raw/compressed", CompressedImage,
                             lambda m: frames.append(time.monotonic()), queue_size=1,
                             buff_size=2 ** 22)]
    out = {}
    for n in counts:
        pages = [ConsoleClient(url, keep_payload=False) for _ in range(n)]
        time.sleep(2.0)
        c0, t0 = cpu_seconds(pid), time.monotonic()
        n0 = [len(p.frames) for p in pages]
        time.sleep(seconds)
        c1, t1 = cpu_seconds(pid), time.monotonic()
        fps = [(len(p.frames) - k) / (t1 - t0) for p, k in zip(pages, n0)]
        odom_hz = sum(1 for t in odom if t0 <= t < t1) / (t1 - t0)
        camera_hz = sum(1 for t in frames if t0 <= t < t1) / (t1 - t0)
        out["%d_pages" % n] = {"cpu_percent": round(100.0 * (c1 - c0) / (t1 - t0), 1),
                               "min_page_fps": round(min(fps), 2) if fps else None,
                               "mean_page_fps": round(float(np.mean(fps)), 2) if fps else None,
                               "camera_fps_at_ros": round(camera_hz, 2),
                               "driver_odom_hz": round(odom_hz, 1),
                               "load_1min": round(os.getloadavg()[0], 2)}
        for p in pages:
            p.close()
        time.sleep(1.0)
    for sub in subs:
        sub.unregister()
    return out


def bench_stop(url, trials):
    import rospy
    from geometry_msgs.msg import Twist

    from web_console.client import ConsoleClient
    cmds, lock = [], threading.Lock()

    def on_cmd(msg):
        with lock:
            cmds.append((time.monotonic(), msg.linear.x, msg.angular.z))
    sub = rospy.Subscriber("cmd_vel", Twist, on_cmd, queue_size=100)
    out = {}
    for how in ("tab_closed", "network_cut"):
        latencies = []
        for _ in range(trials):
            page = ConsoleClient(url)
            page.wait(lambda c: c.messages("hello"), 5.0)
            end = time.monotonic() + 1.0
            while True:
                page.send({"type": "drive", "linear": 0.1, "angular": 0.0})
                t_last = time.monotonic()
                if t_last >= end:
                    break
                time.sleep(0.05)
            if how == "tab_closed":
                time.sleep(0.02)  # mid-lease
                t_stop = time.monotonic()
                page.close()
            else:  # nothing gets through after the last command: the worst case
                t_stop = t_last
            deadline = t_stop + 2.0
            latency = None
            while latency is None and time.monotonic() < deadline:
                with lock:
                    zeros = [t for t, v, w in cmds if t >= t_stop and v == 0.0 and w == 0.0]
                latency = zeros[0] - t_stop if zeros else None
                time.sleep(0.005)
            latencies.append(latency if latency is not None else float("inf"))
            if how == "network_cut":
                page.close()
            time.sleep(0.5)
        ok = sum(1 for v in latencies if v < 0.3)
        out[how] = dict(stats(latencies, 1000.0), under_300ms="%d/%d" % (ok, trials))
    sub.unregister()
    return out


class Replay:
    """Publishes ``jpeg`` (a frame of the simulated camera) at ``rate_hz`` on
    ``replay/camera/image_raw/compressed``, stamped when published: the console alone,
    without the simulated camera's rendering on the loaded machine."""

    def __init__(self, jpeg, rate_hz=10.0):
        import rospy
        from sensor_msgs.msg import CompressedImage
        self.pub = rospy.Publisher("replay/camera/image_raw/compressed", CompressedImage,
                                   queue_size=1)
        self.msg = CompressedImage(format="bgr8; jpeg compressed bgr8", data=jpeg)
        self.msg.header.frame_id = "camera"
        self.period_s, self.on = 1.0 / rate_hz, True
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        import rospy
        next_t = time.monotonic()
        while self.on:
            self.msg.header.stamp = rospy.Time.now()
            self.pub.publish(self.msg)
            next_t += self.period_s
            time.sleep(max(0.0, next_t - time.monotonic()))


def one_frame():
    import rospy
    from sensor_msgs.msg import CompressedImage
    msg = rospy.wait_for_message("camera/image_raw/compressed", CompressedImage, 30.0)
    return bytes(msg.data)


def bench_replay(seconds):
    """A second console in namespace ``replay`` fed 10 fps of a real simulated frame."""
    import rosgraph
    import rospy
    proc = subprocess.Popen(["rosrun", "web_console", "web_console", "__ns:=replay",
                             "_port:=0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    replay = None
    try:
        deadline = time.monotonic() + 30.0
        while not rosgraph.Master("/bench_console").hasParam("/replay/web_console/bound_port"):
            if time.monotonic() > deadline:
                raise RuntimeError("the replay console did not come up")
            time.sleep(0.2)
        url = "ws://127.0.0.1:%d/ws" % rospy.get_param("/replay/web_console/bound_port")
        jpeg = one_frame()
        replay = Replay(jpeg)
        time.sleep(2.0)
        out = {"frame_bytes": len(jpeg), "video": bench_video(url, seconds, "replay/"),
               "cpu": bench_cpu(url, node_pid("/replay/web_console"), seconds,
                                ns="replay/")}
    finally:
        if replay is not None:
            replay.on = False
        proc.terminate()
        proc.wait(30.0)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="each video/CPU window [s]")
    ap.add_argument("--trials", type=int, default=20, help="stop-latency trials per kind")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    port = free_port()
    os.environ["ROS_MASTER_URI"] = "http://localhost:%d" % port
    launch = subprocess.Popen(
        ["roslaunch", "-p", str(port), os.path.join(ROOT, "launch", "sim", "office.launch"),
         "web_console:=true", "console_port:=0"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        import rospy
        deadline = time.monotonic() + 90.0
        while True:
            try:
                import rosgraph
                if rosgraph.Master("/bench_console").hasParam(NODE + "/bound_port"):
                    break
            except OSError:
                pass
            if time.monotonic() > deadline or launch.poll() is not None:
                raise RuntimeError("the console did not come up")
            time.sleep(0.5)
        rospy.init_node("bench_console", disable_signals=True)
        url = "ws://127.0.0.1:%d/ws" % rospy.get_param(NODE + "/bound_port")
        time.sleep(5.0)  # the camera and mapper settle
        result = {"machine": "%d cores, load %.2f at start" % (os.cpu_count(),
                                                                os.getloadavg()[0]),
                  "video": bench_video(url, args.seconds),
                  "cpu": bench_cpu(url, node_pid(NODE), args.seconds),
                  "stop": bench_stop(url, args.trials),
                  "replay_10fps": bench_replay(args.seconds)}
    finally:
        launch.terminate()
        try:
            launch.wait(30.0)
        except subprocess.TimeoutExpired:
            launch.kill()
    text = json.dumps(result, indent=2)
    print(text)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
