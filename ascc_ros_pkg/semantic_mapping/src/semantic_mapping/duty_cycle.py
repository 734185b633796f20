"""``rosrun semantic_mapping duty_cycle [--day FILE] [--seeds S ...] [--window-s W]
[--threshold-mps2 T] [--sleep-after-s H] [--battery-h B]``: the duty cycle of the
power-aware sensor nodes (thesis 5.4.1) over a scripted day.

Renders the day (default ``config/scripted_day.yaml``, the thesis's ten-minute experiment)
for each person (seed) with `body_signals`, applies the sleep/wake rule of `power` to each
sensor's acceleration and prints, per person and sensor, the duty cycle (fraction of the
time the VN-100 and the XBee are on), the number of wake-ups and the battery life
estimated as ``battery_h / duty`` (sleep current neglected). The last line is
``duty_cycle: waist W thigh T`` (the means over the persons). Exit status 0, or 2 for a
bad argument or day file (the message names it).
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import List, Optional, Sequence, Tuple

from .body_signals import LEAN_DEG, POSITIONS, RATE_HZ, Person, render
from .models import DEFAULT_MODELS, read_yaml
from .power import PowerParams, awake_mask, duty_cycle, wake_ups

DEFAULT_DAY = os.path.join(os.path.dirname(DEFAULT_MODELS), "scripted_day.yaml")
THESIS_DUTY = 0.3875  # 5.4.1, a node on the wrist; printed for comparison only


def load_day(path: str) -> List[Tuple[str, float]]:
    doc = read_yaml(path)
    day = doc.get("day") if isinstance(doc, dict) else None
    if not isinstance(day, list) or not day:
        raise ValueError("%s: day: expected a list of [activity, seconds]" % path)
    out = []
    for i, item in enumerate(day):
        ok = (isinstance(item, list) and len(item) == 2 and item[0] in LEAN_DEG
              and isinstance(item[1], (int, float)) and item[1] > 0)
        if not ok:
            raise ValueError("%s: day[%d]: expected [activity, seconds > 0] with an activity "
                             "of %s, got %r" % (path, i, ", ".join(sorted(LEAN_DEG)), item))
        out.append((item[0], float(item[1])))
    return out


def report(day: Sequence[Tuple[str, float]], seeds: Sequence[int], params: PowerParams,
           battery_h: float) -> List[str]:
    lines = ["seed  sensor  duty_cycle  wake_ups  battery_h"]
    sums = {p: 0.0 for p in POSITIONS}
    for seed in seeds:
        data = render(day, Person.from_seed(seed))
        for pos in POSITIONS:
            awake = awake_mask(data["%s_accel" % pos], RATE_HZ, params)
            d = duty_cycle(awake)
            sums[pos] += d
            lines.append("%-5d %-7s %10.4f %9d %10.1f" % (seed, pos, d, wake_ups(awake),
                                                         battery_h / max(d, 1e-9)))
    mean = {p: sums[p] / len(seeds) for p in POSITIONS}
    lines.append("thesis 5.4.1 (one node on the wrist): duty cycle %.4f" % THESIS_DUTY)
    lines.append("duty_cycle: " + " ".join("%s %.4f" % (p, mean[p]) for p in POSITIONS))
    return lines


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="duty_cycle", description=__doc__.split("\n\n")[1])
    ap.add_argument("--day", default=DEFAULT_DAY, help="day script YAML")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4],
                    help="persons (default 0 1 2 3 4)")
    defaults = PowerParams()
    ap.add_argument("--window-s", type=float, default=defaults.window_s)
    ap.add_argument("--threshold-mps2", type=float, default=defaults.motion_threshold_mps2)
    ap.add_argument("--sleep-after-s", type=float, default=defaults.sleep_after_s)
    ap.add_argument("--battery-h", type=float, default=5.0,
                    help="battery life always on [h] (5.4.1: 5 h)")
    args = ap.parse_args(argv)
    if min(args.window_s, args.threshold_mps2, args.sleep_after_s, args.battery_h) <= 0:
        ap.error("--window-s, --threshold-mps2, --sleep-after-s and --battery-h must be > 0")
    try:
        day = load_day(args.day)
    except (OSError, ValueError) as e:
        print("duty_cycle: %s" % e, file=sys.stderr)
        return 2
    params = PowerParams(args.window_s, args.threshold_mps2, args.sleep_after_s)
    total = sum(d for _, d in day)
    print("duty cycle over %s (%.0f s scripted, + transitions), %g Hz; window %g s, "
          "threshold %g m/s^2, asleep after %g s" % (args.day, total, RATE_HZ, args.window_s,
                                                     args.threshold_mps2, args.sleep_after_s))
    print("\n".join(report(day, args.seeds, params, args.battery_h)))
    return 0
