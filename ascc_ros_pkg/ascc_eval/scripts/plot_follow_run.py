#!/usr/bin/env python3
"""Plot one recorded following run (`bench_follow.py --record`: OUT/<world>_seed<n>/run.bag).

Draws, in the map frame, the person's true path, the robot's true path, the follower's
trail (its newest ``target_follower/trail`` in the window, recorded in odom and brought
into the map through the robot's true pose and its odometry at that time) and the
detector's measured target positions (base_link -> map through the true pose), over a
time window; below, against time: the true distance robot -> person's surface, the
detector's range and its error, and the follower's state. Prints the detections whose
measured position is more than ``--bad-m`` from the person's true position (what could
make a bad trail point) and the trail points farther than that from the person's path.

    python ascc_ros_pkg/ascc_eval/scripts/plot_follow_run.py RUN.bag [--t0 S --t1 S]
        [--out PNG] [--title TEXT] [--bad-m 0.25] [--fixture JSON] [--replay-latency]

The bearings are also compared with the truth to measure the camera's latency (the delay
from the frame's exposure to its stamp that best explains the bearing errors). ``--fixture``
writes the window's data for a replay test (target_follower/test/data): the followed
target's measured positions (stamp, base_link), the odometry at 20 Hz, the person's true
path in the odom frame and the latency measured on the truth. ``--replay-latency`` replays
the recorded detections and odometry through target_follower's latency estimate (open
loop: the robot's recorded motion) and prints how far the detections, placed at the true
pose of stamp - latency, are from the person's true path, with the latency at 0 and
estimated (samples after the first 20 s).
"""
import argparse
import json
import math
import sys

import numpy as np
import rosbag

from ascc_common.pose2d import yaw_of


def _pose(p):
    return (p.position.x, p.position.y, yaw_of(p.orientation))


def load(path):
    """The run's series as numpy arrays (times in seconds, sim clock)."""
    truth, odom, person, targets, trails, states = [], [], [], [], [], []
    with rosbag.Bag(path) as bag:
        for topic, msg, _t in bag.read_messages():
            topic = topic.lstrip("/")
            if topic == "ground_truth/asccbot/pose":
                truth.append((msg.header.stamp.to_sec(),) + _pose(msg.pose))
            elif topic == "odom":
                odom.append((msg.header.stamp.to_sec(),) + _pose(msg.pose.pose))
            elif topic == "ground_truth/people" and msg.objects:
                o = msg.objects[0]
                person.append((msg.header.stamp.to_sec(), o.pose.position.x,
                               o.pose.position.y, o.radius))
            elif topic == "target":
                t = msg.header.stamp.to_sec()
                for d in msg.detections[:1]:
                    targets.append((t, d.position.x, d.position.y, d.range_m,
                                    d.bearing_rad, d.range_source, d.confidence))
            elif topic == "target_follower/trail":
                trails.append((msg.header.stamp.to_sec(),
                               [(p.pose.position.x, p.pose.position.y) for p in msg.poses]))
            elif topic == "target_follower/state":
                states.append((_t.to_sec(), msg.data))
    return {"truth": np.array(truth), "odom": np.array(odom), "person": np.array(person),
            "targets": np.array(targets).reshape(-1, 7), "trails": trails, "states": states}


def interp_pose(series, t):
    """(x, y, yaw) of a (t, x, y, yaw) series at times t (yaw unwrapped)."""
    yaw = np.unwrap(series[:, 3])
    return np.stack([np.interp(t, series[:, 0], series[:, 1]),
                     np.interp(t, series[:, 0], series[:, 2]),
                     np.interp(t, series[:, 0], yaw)], axis=-1)


def base_to_map(pose, xy):
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([pose[..., 0] + c * xy[..., 0] - s * xy[..., 1],
                     pose[..., 1] + s * xy[..., 0] + c * xy[..., 1]], axis=-1)


def odom_to_map(run, t, pts):
    """Odom points at time t into the map: map = truth(t) * odom(t)^-1 * p."""
    tr = interp_pose(run["truth"], np.array([t]))[0]
    od = interp_pose(run["odom"], np.array([t]))[0]
    pts = np.asarray(pts, float).reshape(-1, 2)
    c, s = math.cos(od[2]), math.sin(od[2])
    d = pts - od[:2]
    local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=-1)
    return base_to_map(np.broadcast_to(tr, (len(pts), 3)), local)


def detections_in_map(run):
    """(t, x, y, true error [m], range error [m]) of the best detection of each frame."""
    tg = run["targets"]
    tg = tg[np.isfinite(tg[:, 1]) & np.isfinite(tg[:, 2])]
    if not len(tg) or not len(run["person"]):
        return np.zeros((0, 5))
    pose = interp_pose(run["truth"], tg[:, 0])
    xy = base_to_map(pose, tg[:, 1:3])
    pp = run["person"]
    px, py = np.interp(tg[:, 0], pp[:, 0], pp[:, 1]), np.interp(tg[:, 0], pp[:, 0], pp[:, 2])
    err = np.hypot(xy[:, 0] - px, xy[:, 1] - py)
    # the range the detector should have measured: to the person's near surface
    true_rng = np.hypot(px - pose[:, 0], py - pose[:, 1]) - np.interp(tg[:, 0], pp[:, 0], pp[:, 3])
    return np.column_stack([tg[:, 0], xy, err, tg[:, 3] - true_rng])


def bearing_latency(run, t0=-math.inf, t1=math.inf, max_s=1.0, step_s=0.02):
    """(latency [s], rms bearing error at the stamp, rms at that latency [rad]): the delay
    d that makes the detections' bearings best match the true bearing at stamp - d."""
    tg, tr, pp = run["targets"], run["truth"], run["person"]
    tg = tg[np.isfinite(tg[:, 4]) & (tg[:, 0] >= t0) & (tg[:, 0] <= t1)]

    def rms(delay):
        t = tg[:, 0] - delay
        pose = interp_pose(tr, t)
        px, py = np.interp(t, pp[:, 0], pp[:, 1]), np.interp(t, pp[:, 0], pp[:, 2])
        e = np.angle(np.exp(1j * (tg[:, 4] - np.arctan2(py - pose[:, 1], px - pose[:, 0])
                                  + pose[:, 2])))
        return float(np.sqrt(np.mean(e ** 2)))
    delays = np.arange(0.0, max_s, step_s)
    errs = [rms(d) for d in delays]
    i = int(np.argmin(errs))
    return float(delays[i]), errs[0], errs[i]


def write_fixture(run, path, t0, t1, source=""):
    """The window's data for a replay test (module doc), rounded (mm, mrad, ms)."""
    tg, od, pp = run["targets"], run["odom"], run["person"]
    sel = (tg[:, 0] >= t0) & (tg[:, 0] <= t1) & np.isfinite(tg[:, 1])
    grid = np.arange(t0 - 2.0, t1 + 0.5, 0.05)
    odom = interp_pose(od, grid)
    pt = np.arange(t0 - 2.0, t1 + 0.5, 0.2)
    person_map = np.column_stack([np.interp(pt, pp[:, 0], pp[:, 1]),
                                  np.interp(pt, pp[:, 0], pp[:, 2])])
    person_odom = np.array([odom_from_map(run, t, xy) for t, xy in zip(pt, person_map)])
    latency, _, _ = bearing_latency(run, t0, t1)
    data = {"source": "bench_follow.py --record, %s, t = %.1f-%.1f s" % (source, t0, t1),
            "latency_truth_fit_s": round(latency, 3),
            "detections": np.round(tg[sel][:, :3], 3).tolist(),  # t, x, y in base_link
            "odom": np.round(np.column_stack([grid, odom]), 3).tolist(),  # t, x, y, yaw
            "person_odom": np.round(np.column_stack([pt, person_odom]), 3).tolist()}
    with open(path, "w") as f:
        json.dump(data, f, separators=(",", ":"))


def odom_from_map(run, t, xy):
    """A map point at time t in the odom frame: odom(t) * truth(t)^-1 * p."""
    tr = interp_pose(run["truth"], np.array([t]))[0]
    od = interp_pose(run["odom"], np.array([t]))[0]
    c, s = math.cos(tr[2]), math.sin(tr[2])
    d = np.asarray(xy, float) - tr[:2]
    local = np.array([[c * d[0] + s * d[1], -s * d[0] + c * d[1]]])
    return base_to_map(od[None, :], local)[0]


def distance_to_path(points, path):
    """Distance [m] of each point to the polyline ``path``."""
    a, b = path[:-1], path[1:]
    ab = b - a
    ab2 = np.maximum((ab ** 2).sum(axis=1), 1e-12)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        u = np.clip(((p - a) * ab).sum(axis=1) / ab2, 0.0, 1.0)
        out[i] = np.min(np.hypot(*(a + u[:, None] * ab - p).T))
    return out


def replay_latency(run, gate_m=0.25, skip_s=20.0):
    """Print the open-loop replay of the latency estimate (module doc)."""
    import time

    from target_follower.following import OdomHistory, TargetFollowerParams
    from target_follower.latency import LatencyEstimator, LatencyParams
    tg, od, tr, pp = run["targets"], run["odom"], run["truth"], run["person"]
    tg = tg[np.isfinite(tg[:, 1])]
    est = LatencyEstimator(LatencyParams())
    history = OdomHistory(TargetFollowerParams().odom_keep_s())
    lat, k, spent = [], 0, 0.0
    for row in tg:
        while k < len(od) and od[k, 0] <= row[0] + 0.05:  # the odometry that has arrived
            history.add(float(od[k, 0]), tuple(od[k, 1:4]))
            k += 1
        lat.append(est.latency_s)  # the estimate when the frame is placed
        c0 = time.perf_counter()
        est.add(row[0], row[1:3], history.stamps, history.poses)
        spent += time.perf_counter() - c0
    lat = np.array(lat)
    sel = tg[:, 0] > tg[0, 0] + skip_s
    print("detections %d (%.1f Hz); latency estimate after %.0f s: median %.2f s, "
          "5-95 %% %.2f-%.2f s, max %.2f s (over the run %.2f s), largest change between "
          "frames %.2f s; standard error at the end %.3f s; %.2f ms per frame"
          % (len(tg), len(tg) / (tg[-1, 0] - tg[0, 0]), skip_s, np.median(lat[sel]),
             np.percentile(lat[sel], 5), np.percentile(lat[sel], 95), lat[sel].max(),
             lat.max(), np.abs(np.diff(lat)).max(), getattr(est, "latency_std_s", math.nan),
             1e3 * spent / len(tg)))
    for name, delay in (("latency 0", np.zeros(len(tg))), ("estimated", lat)):
        xy = base_to_map(interp_pose(tr, tg[:, 0] - delay), tg[:, 1:3])
        d = distance_to_path(xy[sel], pp[:, 1:3])
        print("  %-10s distance from the person's path: mean %.3f m, p95 %.3f m, "
              "beyond %.2f m: %.1f %%" % (name, d.mean(), np.percentile(d, 95), gate_m,
                                          100.0 * np.mean(d > gate_m)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bag")
    ap.add_argument("--t0", type=float, default=-math.inf)
    ap.add_argument("--t1", type=float, default=math.inf)
    ap.add_argument("--out", default="")
    ap.add_argument("--title", default="")
    ap.add_argument("--bad-m", type=float, default=0.25)
    ap.add_argument("--fixture", default="")
    ap.add_argument("--replay-latency", action="store_true")
    args = ap.parse_args(argv)
    run = load(args.bag)
    if args.replay_latency:
        replay_latency(run)
        return 0
    if args.fixture:
        write_fixture(run, args.fixture, args.t0, args.t1, args.bag)
        print("wrote", args.fixture)
        return 0
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr, pp = run["truth"], run["person"]
    t0 = max(args.t0, tr[0, 0])
    t1 = min(args.t1, tr[-1, 0])
    det = detections_in_map(run)
    win = (det[:, 0] >= t0) & (det[:, 0] <= t1)
    bad = det[win & (det[:, 3] > args.bad_m)]
    print("detections in [%.1f, %.1f] s: %d, farther than %.2f m from the person: %d"
          % (t0, t1, int(win.sum()), args.bad_m, len(bad)))
    lat, rms0, rms1 = bearing_latency(run, t0, t1)
    print("camera latency on the truth: %.2f s (bearing error rms %.3f rad at the stamp, "
          "%.3f rad at stamp - latency)" % (lat, rms0, rms1))
    for row in bad[:40]:
        print("  t=%.2f  at (%.2f, %.2f)  off by %.2f m, range error %+.2f m" % tuple(row))
    trails = [(t, pts) for t, pts in run["trails"] if t0 <= t <= t1 and pts]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8, 10),
                                  gridspec_kw={"height_ratios": [3, 1.3]})
    sel = (tr[:, 0] >= t0) & (tr[:, 0] <= t1)
    psel = (pp[:, 0] >= t0) & (pp[:, 0] <= t1)
    ax.plot(pp[psel, 1], pp[psel, 2], "-", color="tab:orange", lw=2, label="person (truth)")
    ax.plot(tr[sel, 1], tr[sel, 2], "-", color="tab:blue", lw=1.5, label="robot (truth)")
    ax.plot(det[win, 1], det[win, 2], ".", color="tab:green", ms=2,
            label="detections (measured, in map)")
    if len(bad):
        ax.plot(bad[:, 1], bad[:, 2], "x", color="tab:red", ms=5,
                label="detections > %.2f m off" % args.bad_m)
    for i, (t, pts) in enumerate(trails[::max(1, len(trails) // 6)]):
        m = odom_to_map(run, t, pts)
        ax.plot(m[:, 0], m[:, 1], ".-", color="tab:purple", ms=3, lw=0.6, alpha=0.7,
                label="follower's trail (snapshots)" if i == 0 else None)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_xlabel("x [m] (map)")
    ax.set_ylabel("y [m]")
    ax.set_title(args.title or "%s, t = %.0f-%.0f s" % (args.bag, t0, t1), fontsize=9)
    # distances against time
    rp = interp_pose(tr, pp[:, 0])
    dist = np.hypot(pp[:, 1] - rp[:, 0], pp[:, 2] - rp[:, 1]) - pp[:, 3]
    ax2.plot(pp[psel, 0], dist[psel], "-", color="k", lw=1, label="true distance")
    tg = run["targets"]
    tsel = (tg[:, 0] >= t0) & (tg[:, 0] <= t1)
    ax2.plot(tg[tsel, 0], tg[tsel, 3], ".", ms=2, color="tab:green", label="detector's range")
    ax2.axhspan(0.9, 1.5, color="tab:green", alpha=0.08)
    states = [(t, s) for t, s in run["states"] if t0 <= t <= t1]
    for t, s in states:
        ax2.axvline(t, color="0.6", lw=0.5)
        ax2.text(t, ax2.get_ylim()[1], s, rotation=90, fontsize=6, va="top")
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel("[m]")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    out = args.out or args.bag.replace(".bag", ".png")
    fig.savefig(out, dpi=90)
    print("wrote", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
