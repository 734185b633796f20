#!/usr/bin/env python3
"""Per-frame cost of the follower's camera-latency path (target_follower.latency), one core.

Replays a synthetic following run (odometry at ``--odom-hz``, detections at ``--frame-hz``,
the robot weaving) through what ``target_follower_node._take_target`` does per frame with
the target: look up the pose at stamp - latency and give the position and the odometry to
``LatencyEstimator.add``. Prints the mean time per frame of

- the odometry hand-over as before (the history kept in Python lists, converted with
  ``np.asarray`` on every frame) and as now (``OdomHistory``'s numpy buffer: views);
- the estimate itself (``add``: a window judged every ``latency_update_s``).

    python ascc_ros_pkg/target_follower/scripts/bench_latency.py [--seconds 120]
"""
import argparse
import platform
import time

import numpy as np

from ascc_common.params import from_params
from target_follower.following import OdomHistory, TargetFollowerParams
from target_follower.latency import LatencyEstimator, poses_at


def run(seconds, odom_hz, frame_hz, latency_s=0.3):
    t = np.arange(0.0, seconds, 1.0 / odom_hz)
    odom = np.column_stack([0.3 * t, 0.15 * np.sin(0.7 * t), -(0.5 / 1.3) * np.cos(1.3 * t)])
    stamps = np.arange(1.0, seconds - 0.1, 1.0 / frame_hz)
    pose = poses_at(t, odom, stamps - latency_s)
    d = np.column_stack([0.3 * (stamps - latency_s) + 1.2, np.zeros_like(stamps)]) - pose[:, :2]
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    det = np.column_stack([stamps, c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
    return t, odom, det


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--odom-hz", type=float, default=50.0)
    ap.add_argument("--frame-hz", type=float, default=10.0)
    args = ap.parse_args()
    p = from_params(TargetFollowerParams, {}.get)
    t, odom, det = run(args.seconds, args.odom_hz, args.frame_hz)
    keep = p.odom_keep_s()
    print("machine: %s, Python %s; odometry %.0f Hz kept %.1f s (%d poses), frames %.0f Hz, "
          "%d frames" % (platform.machine(), platform.python_version(), args.odom_hz, keep,
                         int(keep * args.odom_hz), args.frame_hz, len(det)))
    # the hand-over: lists converted per frame (before) and the buffer's views (now)
    lists_t, lists_p, hist = [], [], OdomHistory(keep)
    conv, views, k = 0.0, 0.0, 0
    for stamp, _, _ in det:
        while k < len(t) and t[k] <= stamp:
            lists_t.append(float(t[k]))
            lists_p.append(tuple(odom[k]))
            while lists_t[0] < t[k] - keep:
                del lists_t[0], lists_p[0]
            hist.add(float(t[k]), tuple(odom[k]))
            k += 1
        c0 = time.perf_counter()
        before = (np.asarray(lists_t), np.asarray(lists_p))
        c1 = time.perf_counter()
        now = (hist.stamps, hist.poses)
        c2 = time.perf_counter()
        assert len(before[0]) == len(now[0])
        conv += c1 - c0
        views += c2 - c1
    n = len(det)
    print("odometry hand-over per frame: lists -> np.asarray %.3f ms, buffer views %.4f ms"
          % (1e3 * conv / n, 1e3 * views / n))
    est = LatencyEstimator(p.latency)
    hist, k, spent = OdomHistory(keep), 0, 0.0
    for stamp, xb, yb in det:
        while k < len(t) and t[k] <= stamp:
            hist.add(float(t[k]), tuple(odom[k]))
            k += 1
        c0 = time.perf_counter()
        hist.pose_at(stamp - est.latency_s)
        est.add(stamp, (xb, yb), hist.stamps, hist.poses)
        spent += time.perf_counter() - c0
    print("latency estimate per frame (pose look-up + add): %.3f ms; %d windows judged, "
          "estimate %.3f s (truth 0.300)" % (1e3 * spent / n, est.windows, est.latency_s))


if __name__ == "__main__":
    main()
