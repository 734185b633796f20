#!/usr/bin/env python3
"""Benchmark of the operator GUI (issue 15): does it render a 4000 x 4000 map update and
10 fps video without stalling, and the glass-to-glass latency in the simulator.

    python ascc_ros_pkg/telepresence/scripts/bench_gui.py [--sim] [--sim-s 40] [--json F]

Offscreen (QT_QPA_PLATFORM=offscreen), the widgets of ``telepresence.gui``:
  * map: a 4000 x 4000 OccupancyGrid (0.05 m: 200 m x 200 m) serialised as the map topic
    carries it; per update the adapter's thread (numpy deserialisation, grid_image: grey
    table, area resize, flip) and the UI thread (set_map: QImage; repaint of the
    640 x 640 widget). For comparison rospy's default deserialisation (a tuple).
  * video: JPEG frames of the Q24's full size (1280 x 960) and the simulated camera's
    (640 x 480): decode + show_frame (conversion, repaint).
  * stall: 10 s of the window's event loop with 10 fps video and a 4000 x 4000 map update
    every 2 s, both from a feeder thread through Qt signals as in the node; the longest gap
    between two ticks of a 10 ms timer is the longest time the UI did not respond.
  * --sim: launch/sim/telepresence.launch (own master) and the node's window and adapter
    for --sim-s seconds: each video frame's age at display (display - stamp, sim clock),
    and the simulator's real-time factor meanwhile.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import threading
import time

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
from PyQt5.QtCore import QTimer  # noqa: E402
from PyQt5.QtWidgets import QApplication  # noqa: E402

from ascc_common.grid import GridInfo  # noqa: E402
from ascc_common.ports import free_port  # noqa: E402
from telepresence.gui.widgets import MapWidget, VideoWidget  # noqa: E402
from telepresence.gui.window import AdapterSignals  # noqa: E402
from telepresence.teleop import decode_jpeg, grid_image, percentiles  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.realpath(__file__)),
                                    "..", "..", ".."))


def ms(values):
    p50, p95, mx = percentiles(values)
    return {"median_ms": 1000 * p50, "p95_ms": 1000 * p95, "max_ms": 1000 * mx}


def big_map(n=4000, seed=0):
    """A 4000 x 4000 office-like grid: unknown outside, free rooms, walls, noise."""
    rng = np.random.default_rng(seed)
    grid = np.full((n, n), -1, dtype=np.int8)
    grid[200:n - 200, 200:n - 200] = 0
    grid[200:n - 200:100, 200:n - 200] = 100
    grid[200:n - 200, 200:n - 200:120] = 100
    grid[rng.random((n, n)) < 0.01] = 50
    return grid


def serialised_map(grid):
    from io import BytesIO

    from nav_msgs.msg import OccupancyGrid
    msg = OccupancyGrid()
    msg.header.frame_id = "map"
    msg.info.resolution = 0.05
    msg.info.height, msg.info.width = grid.shape
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.ravel()
    buf = BytesIO()
    msg.serialize_numpy(buf, np)
    return buf.getvalue()


def deserialise(raw):
    from nav_msgs.msg import OccupancyGrid
    msg = OccupancyGrid()
    msg.deserialize_numpy(raw, np)
    info = GridInfo.from_msg_info(msg.info)
    return np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width), info


def bench_map(app, raw, repeats):
    from nav_msgs.msg import OccupancyGrid
    w = MapWidget()
    w.resize(640, 640)
    w.show()
    app.processEvents()
    parts = {"deserialise": [], "render": [], "ui_set_map": [], "ui_repaint": [],
             "total": [], "ui_total": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        grid, info = deserialise(raw)  # the adapter's thread
        t1 = time.perf_counter()
        image, _ = grid_image(grid, w.side_px())  # the adapter's thread
        t2 = time.perf_counter()
        w.set_map(grid, info, image)  # the UI thread from here
        t3 = time.perf_counter()
        w.repaint()
        t4 = time.perf_counter()
        for k, v in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t4 - t0, t4 - t2)):
            parts[k].append(v)
    t0 = time.perf_counter()
    OccupancyGrid().deserialize(raw)
    default = time.perf_counter() - t0
    w.close()
    out = {k: ms(v) for k, v in parts.items()}
    out["rospy_default_deserialise_ms"] = 1000 * default
    return out


def jpeg(width, height, seed=0):
    rng = np.random.default_rng(seed)
    img = cv2.resize(rng.integers(0, 255, (height // 8, width // 8, 3), dtype=np.uint8),
                     (width, height), interpolation=cv2.INTER_LINEAR)
    cv2.putText(img, "ASCCbot", (width // 4, height // 2), cv2.FONT_HERSHEY_SIMPLEX, 3,
                (255, 255, 255), 5)
    return cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 80])[1].tobytes()


def bench_video(app, repeats):
    out = {}
    for width, height in ((1280, 960), (640, 480)):
        data = jpeg(width, height)
        w = VideoWidget(clock=time.time)
        w.resize(640, 480)
        w.show()
        app.processEvents()
        dec, show = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            bgr = decode_jpeg(data)
            t1 = time.perf_counter()
            w.show_frame(bgr, time.time())
            t2 = time.perf_counter()
            dec.append(t1 - t0)
            show.append(t2 - t1)
        w.close()
        out["%dx%d" % (width, height)] = {"jpeg_bytes": len(data), "decode": ms(dec),
                                          "show": ms(show)}
    return out


def bench_stall(app, raw, seconds):
    """The event loop under 10 fps video + a 4000 x 4000 map every 2 s."""
    video, mapw = VideoWidget(clock=time.time), MapWidget()
    video.resize(640, 480)
    mapw.resize(640, 640)
    video.show()
    mapw.show()
    feeder = AdapterSignals()
    feeder.frame.connect(video.show_frame)
    feeder.grid.connect(mapw.set_map)
    side = mapw.side_px()
    data = jpeg(1280, 960)
    stop = threading.Event()

    def feed():  # the subscriber threads' work: decode / deserialise, then a signal
        n = 0
        while not stop.is_set():
            feeder.frame.emit(decode_jpeg(data), time.time())
            if n % 20 == 0:  # as the node's adapter: the image made in its thread
                grid, info = deserialise(raw)
                feeder.grid.emit(grid, info, grid_image(grid, side)[0])
            n += 1
            stop.wait(0.1)

    ticks = []
    timer = QTimer()
    timer.timeout.connect(lambda: ticks.append(time.perf_counter()))
    timer.start(10)
    thread = threading.Thread(target=feed, daemon=True)
    thread.start()
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        app.processEvents()
        time.sleep(0.001)
    stop.set()
    thread.join()
    timer.stop()
    gaps = np.diff(ticks)
    ages = list(video.stats.ages)
    return {"seconds": seconds, "frames_shown": len(ages), "fps": len(ages) / seconds,
            "tick_gap": ms(gaps), "frame_age": ms(ages)}


def bench_sim(app, seconds):
    """Glass-to-glass in the simulator: the node's own window and adapter."""
    uri = "http://127.0.0.1:%d" % free_port()
    env = dict(os.environ, ROS_MASTER_URI=uri, ROS_IP="127.0.0.1")
    launch = subprocess.Popen(
        ["roslaunch", os.path.join(ROOT, "launch", "sim", "telepresence.launch"), "gui:=false",
         "episodes:=rest"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        os.environ["ROS_MASTER_URI"] = uri
        os.environ["ROS_IP"] = "127.0.0.1"
        import rospy

        from telepresence.ros.operator_gui_node import make_window
        from telepresence.teleop import check_master
        deadline = time.time() + 60
        while not check_master(uri, 0.5)[0]:
            if time.time() > deadline:
                raise RuntimeError("no master at %s" % uri)
            time.sleep(0.5)
        rospy.init_node("operator_gui", disable_signals=True)
        _, window, watch = make_window(uri, "bench")
        deadline = time.time() + 60
        while len(window.video.stats.ages) < 5 and time.time() < deadline:
            app.processEvents()
            time.sleep(0.005)
        window.video.stats.ages.clear()
        sim0, wall0 = rospy.get_time(), time.time()
        while time.time() - wall0 < seconds:
            app.processEvents()
            time.sleep(0.005)
        rtf = (rospy.get_time() - sim0) / (time.time() - wall0)
        ages = list(window.video.stats.ages)
        watch.stop()
        window.close()
        return {"seconds_wall": seconds, "frames_shown": len(ages),
                "fps_sim": len(ages) / max(1e-9, seconds * rtf), "real_time_factor": rtf,
                "age_at_display_sim_s": ms(ages)}
    finally:
        launch.terminate()
        launch.wait(30)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--stall-s", type=float, default=10.0)
    ap.add_argument("--sim", action="store_true", help="also the simulator's glass-to-glass")
    ap.add_argument("--sim-s", type=float, default=40.0)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    app = QApplication.instance() or QApplication(sys.argv[:1])
    raw = serialised_map(big_map())
    res = {"machine": {"cpu": platform.processor() or platform.machine(),
                       "cores": os.cpu_count(), "python": platform.python_version(),
                       "load_1min": os.getloadavg()[0]}}
    res["map_4000x4000"] = bench_map(app, raw, args.repeats)
    res["video"] = bench_video(app, args.repeats * 5)
    res["stall"] = bench_stall(app, raw, args.stall_s)
    if args.sim:
        res["sim"] = bench_sim(app, args.sim_s)
    res["machine"]["load_1min_end"] = os.getloadavg()[0]
    text = json.dumps(res, indent=2, sort_keys=True)
    print(text)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
