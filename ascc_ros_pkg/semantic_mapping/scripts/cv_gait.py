#!/usr/bin/env python3
"""The range feature of the unknown detector by cross-validation over the training persons.

Carrying is, in the emulator's signals, a walk with a smaller gait (0.6 of the thigh's
swing and of the bounce) and the trunk leant back: the Mahalanobis distance of the
unknown detector does not tell it from walking (`cv_unknown.py`). Here each single window
feature (`activity.feature_names`) is tried as ``RecognizerConfig.range_features`` with
each ``range_quantile``: a window is known only within the training range of the feature
of the class the network takes it for (`activity.Recognizer.known`). 3-fold
cross-validation over persons 0-11 (extended, 3 s, nn_hmm, as semantic.launch trains
it; the distance threshold as configured), each fold's test persons recorded with
scratching, bending and carrying. The rule, fixed before the run: the candidate that
reports the most carrying windows unknown while no known activity loses more than 2 %
more of its windows to "unknown" than without a range feature.
Only the training persons; the held-out persons 100-104 are for `train_activity`.

    python ascc_ros_pkg/semantic_mapping/scripts/cv_gait.py [--quantiles 0.001 ...]
"""
import argparse
import sys

import numpy as np

from semantic_mapping.activity import RecognizerConfig, feature_names
from semantic_mapping.body_signals import UNKNOWN_ACTIVITIES
from semantic_mapping.training import FIVE, record, train

KNOWN = FIVE + ("standing", "walking")
MAX_EXTRA_LOSS = 0.02


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quantiles", type=float, nargs="+",
                    default=[0.0005, 0.001, 0.0025, 0.005, 0.01])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(12)))
    ap.add_argument("--folds", type=int, default=3)
    args = ap.parse_args(argv)
    config = RecognizerConfig(window_s=3.0, features="extended")
    names = feature_names(config)
    k = len(config.classes)
    true, near, taken, feats = [], [], [], []
    lo, hi = {q: [] for q in args.quantiles}, {q: [] for q in args.quantiles}
    for g in np.array_split(np.asarray(args.seeds), args.folds):
        fit_seeds = [s for s in args.seeds if s not in g]
        rec = train(fit_seeds, config)
        x, y = [], []
        for s in fit_seeds:
            f, lab, _ = record(s, config)
            x.append(f)
            y.append(np.array([config.classes.index(a) for a in lab]))
        x, y = np.vstack(x), np.concatenate(y)
        for s in g:
            f, lab, pure = record(int(s), config, unknown=True)
            true.append(np.asarray(lab, dtype=object)[pure])
            near.append(rec.near(f)[pure].any(axis=1))  # the distance test alone
            taken.append(rec.nn.predict_proba(rec.scaler.transform(f)).argmax(axis=1)[pure])
            feats.append(f[pure])
            for q in args.quantiles:  # (classes, features) bounds of this fold
                b = np.stack([np.quantile(x[y == a], [q, 1.0 - q], axis=0)
                              for a in range(k)])
                lo[q].append(np.repeat(b[None, :, 0], pure.sum(), axis=0))
                hi[q].append(np.repeat(b[None, :, 1], pure.sum(), axis=0))
        print("fold %s done" % list(g), flush=True)
    t, near, f = np.concatenate(true), np.concatenate(near), np.vstack(feats)
    taken = np.concatenate(taken)
    rows = np.arange(t.size)
    acts = KNOWN + UNKNOWN_ACTIVITIES

    def rates(known):
        return {a: float(np.mean(~known[t == a])) for a in acts}

    base = rates(near)
    print("no range feature: " + " ".join("%s %.3f" % (a, base[a]) for a in acts))
    best = None
    for q in args.quantiles:
        lq, hq = np.vstack(lo[q]), np.vstack(hi[q])  # (n, classes, features)
        # within the range of the class the network takes the window for
        inside = (f >= lq[rows, taken]) & (f <= hq[rows, taken])  # (n, features)
        for j, name in enumerate(names):
            r = rates(near & inside[:, j])
            worst = max(r[a] - base[a] for a in KNOWN)
            ok = worst <= MAX_EXTRA_LOSS
            print("q %.4f %-13s %s carrying %.3f  worst extra loss of a known activity "
                  "%.3f%s" % (q, name, " ".join("%s %.3f" % (a, r[a]) for a in KNOWN),
                              r["carrying"], worst, "" if ok else "  (over the rule)"),
                  flush=True)
            if ok and (best is None or r["carrying"] > best[0]):
                best = (r["carrying"], name, q)
    if best is None:
        print("no candidate within the rule")
    else:
        print("chosen: range_features (%s,), range_quantile %g: carrying unknown %.3f"
              % (best[1], best[2], best[0]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
