"""``rosrun semantic_mapping train_activity [--train-seeds ...] [--test-seeds ...]
[--kind nn|hmm|nn_hmm] [--features thesis|extended] [--variance log|linear]
[--power on|off] [--windows 3,4.5,6] [--region-features F,...] [--region-fit all|pure]
[--region-margin M] [--out MODEL] [--table YAML]``: trains the
activity recognizer (`activity.Recognizer`) on emulator recordings of some persons and
measures it on persons never used in training (thesis 5.4.2).

Recordings: each person (a seed) follows a script of their own (`person_script`: the
activities of 5.5 and fig. 5.15 in sessions, random order and durations from the seed)
rendered by the emulator's signal model (`body_signals.render`, the same code the
`wearable_emulator` node runs, sample for sample), with the power scheme on: while a
sensor sleeps its last sample is held, as `activity_recognizer` holds it (``--power
off``: the sensors always on, for comparison). Held-out
persons' scripts add activities the recognizer never saw (scratching, bending, carrying).

Prints, on the held-out persons' windows lying wholly inside one activity, the accuracy
per activity of each recognizer kind, the confusion matrix of ``--kind``, the observation
model P(O|A) in Table 5.1's layout, and how the unknown activities were reported; the last
line is ``accuracy: <activity>=<a> ...`` for the five activities of 5.5. ``--out`` saves
the trained recognizer (joblib), ``--table`` the P(O|A) table (YAML).
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .activity import (
    ACTIVITIES,
    KINDS,
    UNKNOWN,
    Recognizer,
    RecognizerConfig,
    confusion,
    observation_model,
    window_features,
    window_labels,
)
from .body_signals import UNKNOWN_ACTIVITIES, Person, render
from .power import PowerParams, hold_asleep

FIVE = ACTIVITIES[:5]  # the activities of 5.5, in the thesis's order


def person_script(seed: int, sessions: int = 6,
                  unknown: bool = False) -> List[Tuple[str, float]]:
    """A person's recording: upright, seated and lying sessions in a random order, each
    activity 15-40 s (``unknown``: upright sessions also scratch, bend and carry)."""
    r = np.random.default_rng([seed, 31337])
    upright = ["standing", "walking", "opening_door"]
    if unknown:
        upright += list(UNKNOWN_ACTIVITIES)
    seated = ["sitting", "typing", "eating"]
    script: List[Tuple[str, float]] = []
    kinds = ["upright", "seated", "upright", "lying"] * (sessions // 4 + 1)
    order = r.permutation(len(kinds))[:sessions]
    for i in order:
        group = {"upright": upright, "seated": seated, "lying": ["lying"]}[kinds[i]]
        for activity in r.permutation(group):
            script.append((str(activity), float(r.uniform(15.0, 40.0))))
    return script


_RENDERED: Dict[Tuple[int, bool, float], dict] = {}


def record(seed: int, config: RecognizerConfig, unknown: bool = False,
           power: bool = True):
    """(features, centre labels, pure mask) of one person's rendered recording, the power
    scheme on or off (the rendering is kept for the next call with another window or
    feature set)."""
    key = (seed, unknown, config.rate_hz)
    if key not in _RENDERED:
        _RENDERED[key] = render(person_script(seed, unknown=unknown), Person.from_seed(seed),
                                config.rate_hz)
    data = _RENDERED[key]
    waist, thigh = data["waist_accel"], data["thigh_accel"]
    if power:  # a sleeping sensor's last sample held, as activity_recognizer holds it
        waist, thigh = (hold_asleep(a, config.rate_hz, PowerParams()) for a in (waist, thigh))
    feats, ends = window_features(waist, thigh, config)
    labels, pure = window_labels(data["label"], ends, config)
    return feats, labels, pure


def train(seeds: Sequence[int], config: RecognizerConfig, power: bool = True) -> Recognizer:
    idx = {a: i for i, a in enumerate(config.classes)}
    sequences, pure = [], []
    for seed in seeds:
        feats, labels, p = record(seed, config, power=power)
        sequences.append((feats, np.array([idx[a] for a in labels])))
        pure.append(p)
    return Recognizer(config).fit(sequences, pure)


def evaluate(rec: Recognizer, recordings, kind: str) -> Tuple[List[str], List[str]]:
    """(true, predicted) labels of the windows lying wholly inside one activity."""
    true: List[str] = []
    pred: List[str] = []
    for feats, labels, pure in recordings:
        got, _ = rec.recognize(feats, kind=kind)
        true += list(labels[pure])
        pred += list(np.asarray(got, dtype=object)[pure])
    return true, pred


def straddling_unknown(rec: Recognizer, recordings, kind: str) -> Tuple[float, int]:
    """(share reported unknown, count) of the windows that straddle two activities and
    whose centre lies in a class of the recognizer (the windows the evaluation above
    leaves out: what an activity change costs)."""
    n = unknown = 0
    for feats, labels, pure in recordings:
        got, _ = rec.recognize(feats, kind=kind)
        m = ~pure & np.isin(labels, list(rec.config.classes))
        n += int(m.sum())
        unknown += int(np.sum(np.asarray(got, dtype=object)[m] == UNKNOWN))
    return unknown / max(n, 1), n


def accuracies(true: Sequence[str], pred: Sequence[str],
               classes: Sequence[str]) -> List[Tuple[str, float]]:
    t = np.asarray(true, dtype=object)
    p = np.asarray(pred, dtype=object)
    return [(a, float(np.mean(p[t == a] == a))) for a in classes if np.any(t == a)]


def select(seeds: Sequence[int], windows: Sequence[float], features: Sequence[str],
           folds: int = 3, power: bool = True,
           variance: str = "log") -> Tuple[str, float, str, List[str]]:
    """Model selection on the training persons only, by ``folds``-fold cross-validation
    over persons (each fold's persons validate a recognizer trained on the others; the
    validation windows of all folds are pooled). The (features, window, kind) whose worst
    accuracy over the five activities of 5.5 is highest wins. Returns it and the lines of
    the table."""
    groups = [list(g) for g in np.array_split(np.asarray(seeds), folds)]
    lines = ["model selection: %d-fold cross-validation over the training persons %s"
             % (folds, [g for g in groups])]
    best = (-1.0, features[0], windows[0], KINDS[0])
    for feat in features:
        for w in windows:
            config = RecognizerConfig(window_s=w, features=feat, variance=variance)
            pooled = {kind: ([], []) for kind in KINDS}
            for g in groups:
                rec = train([s for s in seeds if s not in g], config, power)
                val = [record(int(seed), config, power=power) for seed in g]
                for kind in KINDS:
                    t, p = evaluate(rec, val, kind)
                    pooled[kind][0].extend(t)
                    pooled[kind][1].extend(p)
            for kind in KINDS:
                acc = dict(accuracies(*pooled[kind], FIVE))
                worst = min(acc.get(a, 0.0) for a in FIVE)
                lines.append("  %-8s window %.1f s %-7s worst %.3f  (%s)" % (
                    feat, w, kind, worst, ", ".join("%s %.3f" % (a, acc.get(a, 0.0))
                                                    for a in FIVE)))
                if worst > best[0]:
                    best = (worst, feat, w, kind)
    return best[1], best[2], best[3], lines


def _parse_seeds(text: str) -> List[int]:
    out: List[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]
    return out


def _table(counts: np.ndarray, rows: Sequence[str], cols: Sequence[str]) -> List[str]:
    width = max(len(c) for c in cols) + 1
    lines = ["%-14s" % "predicted\\true" + "".join(("%" + str(width) + "s") % c[:width - 1]
                                                   for c in cols)]
    for i, r in enumerate(rows):
        lines.append("%-14s" % r + "".join(("%" + str(width) + "d") % v for v in counts[i]))
    return lines


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="train_activity", description=__doc__.split("\n\n")[1])
    ap.add_argument("--train-seeds", default="0-11", help="training persons (0-11)")
    ap.add_argument("--test-seeds", default="100-104", help="held-out persons (100-104)")
    ap.add_argument("--kind", choices=KINDS,
                    help="recognizer (default: chosen with the window on the training "
                         "persons)")
    ap.add_argument("--features", choices=("thesis", "extended"),
                    help="window features (default: chosen on the training persons)")
    ap.add_argument("--power", choices=("on", "off"), default="on",
                    help="the sensors' sleep/wake scheme (on: as the emulator node runs)")
    ap.add_argument("--variance", choices=("log", "linear"), default="log",
                    help="variance features as log10(variance + 0.01 m^2/s^4) or linear")
    ap.add_argument("--windows", default="3,4.5,6",
                    help="window lengths [s] to choose from (3,4.5,6)")
    ap.add_argument("--range-features", default="none",
                    help="comma-separated window features a window must lie within the "
                         "training range of (for the class the network takes it for) to "
                         "be known; 'none' for none (the default; thigh_var_z was "
                         "scripts/cv_gait.py's choice among single features)")
    ap.add_argument("--range-quantile", type=float, default=0.005,
                    help="the range is [q, 1 - q] of the class's training windows "
                         "(default 0.005)")
    ap.add_argument("--region-features", default="thigh_dvar_z,waist_mean_z,waist_var_z",
                    help="comma-separated window features a window must lie within the "
                         "training region (Mahalanobis ellipse) of (for the class the "
                         "network takes it for) to be known; 'none' for none (default "
                         "thigh_dvar_z,waist_mean_z,waist_var_z, the thigh's swing, the "
                         "waist's lean and its fore-aft bounce: scripts/cv_gait.py "
                         "--triples' choice)")
    ap.add_argument("--region-quantile", type=float, default=0.0005,
                    help="the region holds 1 - q of the class's training windows "
                         "(default 0.0005: cv_gait.py --triples' choice)")
    ap.add_argument("--region-fit", choices=("all", "pure"), default="pure",
                    help="fit each class's region on all of its windows or on those "
                         "wholly inside one activity (default pure: cv_gait.py --triples' "
                         "choice)")
    ap.add_argument("--region-margin", type=float, default=2.0,
                    help="each class's region threshold times this (default 2: "
                         "cv_gait.py --triples' choice)")
    ap.add_argument("--out", help="save the trained recognizer here (joblib)")
    ap.add_argument("--table", help="write P(O|A) (Table 5.1 layout) here (YAML)")
    args = ap.parse_args(argv)
    try:
        train_seeds, test = _parse_seeds(args.train_seeds), _parse_seeds(args.test_seeds)
        windows = [float(w) for w in args.windows.split(",")]
    except ValueError:
        ap.error("seeds: a list like 0-11 or 1,2,5; windows: like 3,4,5")
    if set(train_seeds) & set(test):
        ap.error("a person is in both --train-seeds and --test-seeds")
    features = [args.features] if args.features else ["thesis", "extended"]
    power = args.power == "on"
    feat, window, kind, lines = select(train_seeds, windows, features, power=power,
                                       variance=args.variance)
    print("\n".join(lines))
    kind = args.kind or kind
    ranges = tuple(n for n in args.range_features.split(",") if n and n != "none")
    regions = tuple(n for n in args.region_features.split(",") if n and n != "none")
    config = RecognizerConfig(window_s=window, kind=kind, features=feat,
                              variance=args.variance, range_features=ranges,
                              range_quantile=args.range_quantile, region_features=regions,
                              region_quantile=args.region_quantile,
                              region_fit=args.region_fit, region_margin=args.region_margin)
    rec = train(train_seeds, config, power)
    held = [record(seed, config, unknown=True, power=power) for seed in test]
    print("activity recognition (thesis 5.4.2): %s features (%s variances), window %g s "
          "every %g s, %s, power scheme %s, range features %s (q %g), region features %s "
          "(q %g, fit on %s windows, margin %g); trained on persons %s, tested on held-out "
          "persons %s (windows wholly inside one activity)"
          % (feat, args.variance, config.window_s, config.hop_s, kind, args.power,
             ",".join(ranges) or "none", config.range_quantile,
             ",".join(regions) or "none", config.region_quantile, config.region_fit,
             config.region_margin, args.train_seeds, args.test_seeds))
    results = {}
    for k in KINDS:
        results[k] = evaluate(rec, held, k)
        print("%-7s %s" % (k, ", ".join("%s %.3f" % a for a in accuracies(
            *results[k], config.classes))))
    true, pred = results[kind]
    counts, cols = confusion(true, pred, config.classes)
    print("confusion (%s; rows predicted, columns true; windows):" % kind)
    print("\n".join(_table(counts, list(config.classes) + [UNKNOWN], cols)))
    unknown_cols = [c for c in cols if c in UNKNOWN_ACTIVITIES]
    for c in unknown_cols:
        j = cols.index(c)
        print("unknown activity %-10s reported unknown in %.3f of its windows"
              % (c, counts[-1, j] / max(counts[:, j].sum(), 1)))
    known = [cols.index(a) for a in config.classes if a in cols]
    print("known activities reported unknown: %.3f of their windows"
          % (counts[-1, known].sum() / max(counts[:, known].sum(), 1)))
    print("windows straddling two activities (centre a known one) reported unknown: %.3f "
          "of %d" % straddling_unknown(rec, held, kind))
    om = observation_model(counts, len(FIVE))
    print("P(O|A) on the held-out persons (Table 5.1 layout; rows O, 'other' = another "
          "class or unknown; columns A):")
    for name, row in zip(list(FIVE) + ["other"], om["table"]):
        print("%-14s" % name + "".join("%8.3f" % v for v in row))
    if args.out:
        import joblib
        folder = os.path.dirname(os.path.abspath(args.out))
        os.makedirs(folder, exist_ok=True)
        joblib.dump(rec, args.out + ".part")
        os.replace(args.out + ".part", args.out)  # a waiting node never reads half a file
        print("recognizer saved to %s" % args.out)
    if args.table:
        import yaml
        with open(args.table, "w", encoding="utf-8") as f:
            yaml.safe_dump({"activities": list(FIVE), "rows": list(FIVE) + ["other"],
                            "observation_model": [[round(float(v), 4) for v in row]
                                                  for row in om["table"]],
                            "windows_per_activity": [int(v) for v in om["windows"]]}, f,
                           sort_keys=False, default_flow_style=None)
        print("P(O|A) written to %s" % args.table)
    five = np.diag(counts[:len(FIVE), :len(FIVE)]) / np.maximum(
        counts[:, :len(FIVE)].sum(axis=0), 1)
    print("accuracy: " + " ".join("%s=%.3f" % (a, v) for a, v in zip(FIVE, five)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
