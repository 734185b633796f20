#!/usr/bin/env python3
"""Gesture recognition benchmark (issue 15's goals): recall, false commands, latency.

The package's templates (recorded with ``record_gesture_template --sim --seed 1``) and the
recognizer's default parameters, on the simulated tracker (telepresence.skeleton_sim,
default imperfections: 1 cm joint noise at 2 m, 5 % dropped frames, missing joints, one
random tracking loss a minute) at 30 Hz, frames through telepresence.gestures.
GestureRecognizer exactly as the node passes them:

* gesture set: scripts of seeds ``--gesture-seed`` + 0, 1, ... (other than the templates'
  seed 1 and the calibration seeds 100-109 that chose the threshold) mixing the two
  commands (3 : 3) with idle motion (1 each), a rest after every episode, until
  ``--gestures`` gestures; each gesture draws its tempo, amplitude, centre and 2-3
  cycles. A gesture is recognized when its own command comes between its start and
  ``--late-s`` after its last cycle; latency = command time - end of the last cycle;
* idle set: ``--idle-min`` minutes of idle motion only (rest, scratch, point, wave,
  walk_past; seeds ``--idle-seed`` + 0, 1, ...): every command is false.

``--noise-m``, ``--drop-prob``, ``--lost-per-min``: a harsher tracker than the default
(robustness rows of the results). Prints the numbers and the machine; ``--json FILE``
writes them.
"""
import argparse
import json
import os
import platform
import time

import numpy as np

from telepresence.gestures import GestureParams, GestureRecognizer, load_template
from telepresence.skeleton_sim import (
    GESTURES,
    IDLE_KINDS,
    KINDS,
    SensorParams,
    SkeletonSource,
    make_script,
)

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RATE_HZ = 30.0


def run(source, recognizer):
    """Every command of the source's frames: [(t, command, error)]; and the frame count
    and processing time [s]."""
    out, n, spent = [], 0, 0.0
    for t in np.arange(0.0, source.end_s, 1.0 / RATE_HZ):
        f = source.frame(float(t))
        if f is None:
            continue
        t0 = time.perf_counter()
        step = recognizer.on_frame(f.t, f.user, f.joints)
        spent += time.perf_counter() - t0
        n += 1
        if step.match is not None:
            out.append((step.match.t, step.match.command, step.match.error_rad2))
    return out, n, spent


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--gestures", type=int, default=200)
    ap.add_argument("--idle-min", type=float, default=30.0)
    ap.add_argument("--gesture-seed", type=int, default=1000)
    ap.add_argument("--idle-seed", type=int, default=2000)
    ap.add_argument("--late-s", type=float, default=0.5)
    ap.add_argument("--noise-m", type=float, default=SensorParams().noise_m)
    ap.add_argument("--drop-prob", type=float, default=SensorParams().drop_prob)
    ap.add_argument("--lost-per-min", type=float, default=SensorParams().lost_per_min)
    ap.add_argument("--json")
    a = ap.parse_args()
    sensor = SensorParams(noise_m=a.noise_m, drop_prob=a.drop_prob,
                          lost_per_min=a.lost_per_min)
    templates = [load_template(os.path.join(PKG, "templates", c + ".yaml")) for c in GESTURES]
    params = GestureParams()
    frames = 0
    spent = 0.0

    hits, late, confused, missed, false_in_gesture_set, latencies = 0, 0, 0, [], 0, []
    n_gestures, seed, gesture_set_s = 0, a.gesture_seed, 0.0
    per_kind = {k: [0, 0] for k in GESTURES}  # recognized, performed
    while n_gestures < a.gestures:
        script = make_script(seed, 120.0, KINDS, weights=[3, 3, 1, 1, 1, 1, 1])
        src = SkeletonSource(script, sensor, seed)
        commands, n, dt = run(src, GestureRecognizer(templates, params))
        frames, spent, gesture_set_s = frames + n, spent + dt, gesture_set_s + src.end_s
        used, counted_until = set(), 0.0
        for e in src.gestures():
            if n_gestures >= a.gestures:
                break
            n_gestures += 1
            counted_until = e.t1
            per_kind[e.kind][1] += 1
            inside = [c for c in commands if e.t0 <= c[0] < e.t1]
            used.update(inside)
            right = [c for c in inside if c[1] == e.kind]
            confused += any(c[1] != e.kind for c in inside)
            if right and right[0][0] <= e.motion_end + a.late_s:
                hits += 1
                per_kind[e.kind][0] += 1
                latencies.append(right[0][0] - e.motion_end)
            elif right:
                late += 1
                missed.append((seed, e.kind, round(e.t0, 2), "late %.2f s"
                               % (right[0][0] - e.motion_end)))
            else:
                missed.append((seed, e.kind, round(e.t0, 2), "none"))
        false_in_gesture_set += sum(1 for c in commands if c not in used
                                    and c[0] < counted_until)
        seed += 1

    idle_s, false_idle, seed, false_list = 0.0, 0, a.idle_seed, []
    while idle_s < 60.0 * a.idle_min:
        script = make_script(seed, min(600.0, 60.0 * a.idle_min - idle_s), IDLE_KINDS)
        src = SkeletonSource(script, sensor, seed)
        commands, n, dt = run(src, GestureRecognizer(templates, params))
        frames, spent, idle_s = frames + n, spent + dt, idle_s + src.end_s
        false_idle += len(commands)
        for c in commands:
            e = src.body.episode_at(c[0])
            false_list.append((seed, round(c[0], 2), c[1], e.kind if e else "-",
                               round(c[2], 4)))
        seed += 1

    lat = np.asarray(latencies)
    result = {
        "gestures": n_gestures, "recognized": hits,
        "recall": hits / n_gestures,
        "per_kind": {k: "%d/%d" % tuple(v) for k, v in per_kind.items()},
        "late": late, "confused": confused, "missed": missed,
        "latency_s": {"median": float(np.median(lat)), "p95": float(np.percentile(lat, 95)),
                      "max": float(lat.max()), "min": float(lat.min())},
        "idle_minutes": idle_s / 60.0, "false_commands_idle": false_idle,
        "false_per_10min_idle": false_idle / (idle_s / 600.0),
        "false_list_idle": false_list,
        "false_commands_between_gestures": false_in_gesture_set,
        "gesture_set_minutes": gesture_set_s / 60.0,
        "threshold_rad2": params.threshold_rad2,
        "sensor": {"noise_m": a.noise_m, "drop_prob": a.drop_prob,
                   "lost_per_min": a.lost_per_min},
        "ms_per_frame": 1000.0 * spent / frames, "frames": frames,
        "machine": "%s, %s, %d cores, Python %s" % (platform.node(), platform.processor()
                                                    or platform.machine(), os.cpu_count(),
                                                    platform.python_version()),
    }
    print("gestures: %d, recognized within %.1f s of their end: %d (recall %.1f %%; %s), "
          "late %d, confused %d" % (n_gestures, a.late_s, hits, 100 * result["recall"],
                                    result["per_kind"], late, confused))
    print("latency after the gesture's last cycle [s]: median %.2f, p95 %.2f, max %.2f, "
          "min %.2f" % tuple(result["latency_s"][k] for k in ("median", "p95", "max", "min")))
    print("idle motion: %.1f min, %d false commands = %.2f per 10 min; between gestures: %d "
          "in %.1f min" % (result["idle_minutes"], false_idle, result["false_per_10min_idle"],
                           false_in_gesture_set, result["gesture_set_minutes"]))
    print("missed: %s" % missed)
    print("false (idle): %s" % false_list)
    print("recognizer: %.3f ms per frame over %d frames; %s" % (result["ms_per_frame"],
                                                              frames, result["machine"]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
