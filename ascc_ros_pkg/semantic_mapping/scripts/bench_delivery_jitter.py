#!/usr/bin/env python3
"""The activity recognizer's node path under late timer ticks: the old scheme (the
emulator renders each sample at its tick's own time; the recognizer takes the newest
sample of each sensor at each of its ticks) against the current one (the emulator renders
each sample at its own time on the sensors' clock, `emulator.SampleClock`; the recognizer
uses every sample once and in order, `alignment.SampleAligner`).

The model is trained as `test/activity.test` trains it (persons 0-5, extended features,
3 s windows, the gait region). Each person follows activity.test's script (walking 15 s,
carrying 15 s, sitting 25 s, bending 15 s); both nodes' timer ticks are late by an
exponential delay of the given mean (the sensors' samples reach the recognizer when the
emulator's tick sends them). Printed per mean delay and scheme: the share of the
windows ending more than 5 s into each activity that come out as expected (walking and
sitting recognized, carrying and bending unknown), over the persons and delay draws.
Person 104 is activity.test's; 100-103 are held out like it (`train_activity`'s test
persons).

    python ascc_ros_pkg/semantic_mapping/scripts/bench_delivery_jitter.py
        [--persons 100 101 102 103 104] [--draws 3] [--delays-ms 0 10 20 50]
"""
import argparse
import sys

import numpy as np

from semantic_mapping.activity import UNKNOWN, RecognizerConfig, window_features
from semantic_mapping.alignment import SampleAligner
from semantic_mapping.body_signals import Person, render_at, segments_with_transitions
from semantic_mapping.power import PowerParams, hold_asleep
from semantic_mapping.training import train

SCRIPT = [("walking", 15.0), ("carrying", 15.0), ("sitting", 25.0), ("bending", 15.0)]
EXPECTED = {"walking": "walking", "carrying": UNKNOWN, "sitting": "sitting",
            "bending": UNKNOWN}
SETTLE_S = 5.0
CONFIG = RecognizerConfig(window_s=3.0, features="extended", hidden=(32,),
                          region_features=("thigh_dvar_z", "waist_mean_z", "waist_var_z"),
                          region_quantile=0.0005, region_fit="pure", region_margin=2.0)


def signals(person, segments, t):
    """Both sensors' accelerations at times t, with the power scheme (a sleeping sensor
    sends nothing: its last sample held), as the emulator sends them."""
    data = render_at(segments, person, t)
    return [hold_asleep(data["%s_accel" % position], CONFIG.rate_hz, PowerParams())
            for position in ("waist", "thigh")]


def late(times, mean_s, rng):
    """Tick times each late by an exponential delay, in order."""
    if mean_s <= 0.0:
        return times.copy()
    return np.maximum.accumulate(times + rng.exponential(mean_s, times.size))


def old_scheme(person, segments, n, mean_s, rng):
    period = 1.0 / CONFIG.rate_hz
    t_emu = late(np.arange(n) * period, mean_s, rng)      # rendered at the tick's time
    waist, thigh = signals(person, segments, t_emu)
    t_rec = late(np.arange(n) * period + 0.5 * period, mean_s, rng)
    idx = np.searchsorted(t_emu, t_rec, side="right") - 1  # the newest sample at each tick
    ok = idx >= 0
    return waist[idx[ok]], thigh[idx[ok]], t_rec[ok]


def new_scheme(person, segments, n, mean_s, rng):
    period = 1.0 / CONFIG.rate_hz
    t = np.arange(n) * period
    waist, thigh = signals(person, segments, t)             # at the sensors' own times
    t_sent = late(t, mean_s, rng)                           # sent when the tick comes
    t_rec = late(t + 0.5 * period, mean_s, rng)
    al = SampleAligner(("waist", "thigh"), CONFIG.rate_hz, 0.25, 2.0)
    rows_w, rows_t, stamps = [], [], []
    k = 0
    for tick in t_rec:
        while k < n and t_sent[k] <= tick:
            al.add("waist", waist[k], t_sent[k])
            al.add("thigh", thigh[k], t_sent[k])
            k += 1
        for w, th in al.rows(tick):
            rows_w.append(w)
            rows_t.append(th)
            stamps.append(tick)
    return np.array(rows_w), np.array(rows_t), np.array(stamps)


def shares(rec, segments, waist, thigh, stamps):
    """{activity: (windows as expected, windows)} over the settled windows."""
    feats, ends = window_features(waist, thigh, CONFIG)
    labels, _ = rec.recognize(feats, kind=CONFIG.kind)
    labels = np.asarray(labels, dtype=object)
    t_end = stamps[ends - 1]
    out = {}
    for seg in segments:
        if seg.activity not in EXPECTED:
            continue  # a transition
        m = (t_end > seg.start + SETTLE_S) & (t_end < seg.end)
        out[seg.activity] = (int(np.sum(labels[m] == EXPECTED[seg.activity])), int(m.sum()))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--persons", type=int, nargs="+", default=[100, 101, 102, 103, 104])
    ap.add_argument("--draws", type=int, default=3, help="delay draws per person")
    ap.add_argument("--delays-ms", type=float, nargs="+", default=[0.0, 10.0, 20.0, 50.0])
    args = ap.parse_args(argv)
    print("training on persons 0-5 ...", flush=True)
    rec = train([0, 1, 2, 3, 4, 5], CONFIG)
    print("| mean tick delay | scheme | " + " | ".join(EXPECTED) + " |")
    print("|---|---|" + "---|" * len(EXPECTED))
    for delay_ms in args.delays_ms:
        for name, scheme in (("newest sample per tick (old)", old_scheme),
                             ("every sample once (now)", new_scheme)):
            total = {a: [0, 0] for a in EXPECTED}
            for person_seed in args.persons:
                person = Person.from_seed(person_seed)
                segments = segments_with_transitions(SCRIPT, person)
                n = int(segments[-1].end * CONFIG.rate_hz)
                for draw in range(args.draws):
                    rng = np.random.default_rng([person_seed, draw, int(delay_ms * 10)])
                    w, t, stamps = scheme(person, segments, n, delay_ms / 1000.0, rng)
                    for a, (good, count) in shares(rec, segments, w, t, stamps).items():
                        total[a][0] += good
                        total[a][1] += count
            print("| %g ms | %s | %s |" % (delay_ms, name, " | ".join(
                "%.1f %%" % (100.0 * g / max(c, 1)) for g, c in total.values())), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
