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

With ``--pairs``: pairs of the gait's features (`GAIT`) and a triple, each as a box
(``range_features``: within each feature's range) and as an ellipse
(``region_features``: the class's Mahalanobis distance on just those features), with
the same rule.

With ``--triples``: the pair of swing and lean (`PAIR`) alone and with one feature of
the waist's bounce (`BOUNCE`); ``--margins``: each region's threshold times each margin;
``--fit both``: regions fitted on all of a class's windows and on its whole-activity
windows. The rule as above; a tie: the smaller worst extra loss, then the first.

    python ascc_ros_pkg/semantic_mapping/scripts/cv_gait.py [--pairs | --triples]
        [--quantiles ...] [--margins ...] [--fit all|pure|both]
"""
import argparse
import itertools
import sys

import numpy as np

from semantic_mapping.activity import (
    RecognizerConfig,
    feature_names,
    fit_regions,
    in_region,
    pure_fit_mask,
)
from semantic_mapping.body_signals import UNKNOWN_ACTIVITIES
from semantic_mapping.training import FIVE, record, train

KNOWN = FIVE + ("standing", "walking")
MAX_EXTRA_LOSS = 0.02
# what carrying changes in the emulator (`body_signals._angles`): the thigh's swing (its
# forward axis z, and x), the bounce (the waist's vertical x and fore-aft z) and the
# waist leant back (gravity's share on the waist's forward axis: mean z)
GAIT = ("thigh_var_z", "thigh_dvar_z", "thigh_var_x", "waist_var_x", "waist_var_z",
        "waist_mean_z")
TRIPLES = (("thigh_var_z", "waist_var_x", "waist_mean_z"),)
# ``--triples``: the chosen pair (swing, lean) and one feature of the waist's bounce. The
# gait bounces the trunk vertically at twice the stride frequency (walking and carrying,
# the waist's x axis: its variance, and its difference variance, which grows with the
# bounce's frequency too); opening a door has no vertical bounce (its push-pull is
# fore-aft, the waist's z: listed as the control that should not help against a door)
PAIR = ("thigh_dvar_z", "waist_mean_z")
BOUNCE = ("waist_var_x", "waist_dvar_x", "waist_var_z")


def candidates(names, pairs, triples=False):
    """(shape, feature names): single features as ranges, or (``pairs``) every pair of
    `GAIT` and the `TRIPLES` as a box (ranges of each) and as an ellipse (a region), or
    (``triples``) `PAIR` alone and with each `BOUNCE` feature, as boxes and ellipses."""
    if triples:
        sets = [PAIR] + [PAIR + (b,) for b in BOUNCE]
    elif pairs:
        sets = list(itertools.combinations(GAIT, 2)) + list(TRIPLES)
    else:
        return [("range", (n,)) for n in names]
    return [(shape, fs) for fs in sets for shape in ("range", "region")]


def inside(folds, k, shape, index, q, fit, margin=1.0):
    """(test windows,) bool: within the range or region (its threshold times ``margin``)
    of the class the network takes each for, fitted on each fold's training windows."""
    out = []
    for x, y, p, f, taken, _, _ in folds:
        if fit == "pure":  # a class's pure windows where it has some
            keep = pure_fit_mask(y, p)
            x, y = x[keep], y[keep]
        if shape == "range":
            b = np.stack([np.quantile(x[y == a][:, index], [q, 1.0 - q], axis=0)
                          for a in range(k)])  # (classes, 2, features)
            lo, hi = b[taken, 0], b[taken, 1]
            out.append(np.all((f[:, index] >= lo) & (f[:, index] <= hi), axis=1))
        else:
            out.append(in_region(f[:, index], fit_regions(x[:, index], y, k, q, margin),
                                 taken))
    return np.concatenate(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quantiles", type=float, nargs="+",
                    default=[0.0005, 0.001, 0.0025, 0.005, 0.01])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(12)))
    ap.add_argument("--folds", type=int, default=3)
    ap.add_argument("--pairs", action="store_true",
                    help="pairs (and a triple) of the gait's features, as boxes and as "
                         "ellipses, instead of single features")
    ap.add_argument("--triples", action="store_true",
                    help="the pair of swing and lean alone and with one feature of the "
                         "waist's bounce each (`BOUNCE`), as boxes and as ellipses")
    ap.add_argument("--margins", type=float, nargs="+", default=[1.0],
                    help="the regions' distance thresholds times each of these (the "
                         "spread of persons beyond the training persons'; boxes: 1 only)")
    ap.add_argument("--fit", choices=("all", "pure", "both"), default="all",
                    help="the ranges and regions from all of a class's windows, from its "
                         "windows wholly inside one activity (a class without such "
                         "windows, the transitions: all), or both variants")
    args = ap.parse_args(argv)
    config = RecognizerConfig(window_s=3.0, features="extended")
    names = feature_names(config)
    k = len(config.classes)
    folds = []  # (training x, y; test features, network's class, near, true) per fold
    for g in np.array_split(np.asarray(args.seeds), args.folds):
        fit_seeds = [s for s in args.seeds if s not in g]
        rec = train(fit_seeds, config)
        x, y, p = [], [], []
        for s in fit_seeds:
            f, lab, pure = record(s, config)
            x.append(f)
            y.append(np.array([config.classes.index(a) for a in lab]))
            p.append(pure)
        x, y, p = np.vstack(x), np.concatenate(y), np.concatenate(p)
        true, near, taken, feats = [], [], [], []
        for s in g:
            f, lab, pure = record(int(s), config, unknown=True)
            true.append(np.asarray(lab, dtype=object)[pure])
            near.append(rec.near(f)[pure].any(axis=1))  # the distance test alone
            taken.append(rec.nn.predict_proba(rec.scaler.transform(f)).argmax(axis=1)[pure])
            feats.append(f[pure])
        folds.append((x, y, p, np.vstack(feats), np.concatenate(taken), np.concatenate(near),
                      np.concatenate(true)))
        print("fold %s done" % list(g), flush=True)
    t = np.concatenate([fd[6] for fd in folds])
    near = np.concatenate([fd[5] for fd in folds])
    acts = KNOWN + UNKNOWN_ACTIVITIES

    def rates(known):
        return {a: float(np.mean(~known[t == a])) for a in acts}

    base = rates(near)
    print("no range feature: " + " ".join("%s %.3f" % (a, base[a]) for a in acts))
    best = None
    fits = ("all", "pure") if args.fit == "both" else (args.fit,)
    for q, fit, margin in itertools.product(args.quantiles, fits, args.margins):
        for shape, fs in candidates(names, args.pairs, args.triples):
            if shape == "range" and margin != 1.0:
                continue
            r = rates(near & inside(folds, k, shape, [names.index(n) for n in fs], q, fit,
                                    margin))
            worst = max(r[a] - base[a] for a in KNOWN)
            ok = worst <= MAX_EXTRA_LOSS
            print("q %.4f %-4s m %.1f %-6s %-40s %s carrying %.3f  worst extra loss of a "
                  "known activity %.3f%s" % (q, fit, margin, shape, ",".join(fs),
                                             " ".join("%s %.3f" % (a, r[a]) for a in KNOWN),
                                             r["carrying"], worst,
                                             "" if ok else "  (over the rule)"), flush=True)
            # the most carrying unknown; a tie: the smaller worst extra loss, then the first
            if ok and (best is None or (r["carrying"], -worst) > (best[0], -best[6])):
                best = (r["carrying"], shape, fs, q, fit, margin, worst)
    if best is None:
        print("no candidate within the rule")
    else:
        print("chosen: %s_features (%s), %s_quantile %g, fit on %s windows, margin %g: "
              "carrying unknown %.3f (worst extra loss of a known activity %.3f)"
              % (best[1], ",".join(best[2]), best[1], best[3], best[4], best[5], best[0],
                 best[6]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
