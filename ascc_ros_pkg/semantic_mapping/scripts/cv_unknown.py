#!/usr/bin/env python3
"""The unknown detector's threshold by cross-validation over the training persons.

For each quantile q of a class's own training distances (RecognizerConfig's
``unknown_quantile``, 0.995 by default): 3-fold cross-validation over persons 0-11
(recognizer: extended features, 3 s windows, nn_hmm, as semantic.launch trains it), each
fold's persons recorded with the activities the recognizer does not know (scratching,
bending, carrying). Prints per q the fraction of windows reported unknown for each known
activity (a cost: a lost observation) and each unknown one (the aim). Only the training
persons; the held-out persons 100-104 are not read.

    python ascc_ros_pkg/semantic_mapping/scripts/cv_unknown.py [--quantiles 0.9 0.95 ...]
"""
import argparse
import sys

import numpy as np

from semantic_mapping.activity import UNKNOWN, RecognizerConfig
from semantic_mapping.body_signals import UNKNOWN_ACTIVITIES
from semantic_mapping.training import FIVE, record, train

KNOWN = FIVE + ("standing", "walking")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quantiles", type=float, nargs="+",
                    default=[0.9, 0.95, 0.975, 0.99, 0.995, 0.999])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(12)))
    ap.add_argument("--folds", type=int, default=3)
    args = ap.parse_args(argv)
    config = RecognizerConfig(window_s=3.0, features="extended")
    classes = list(config.classes)
    true, best, dist, thresholds = [], [], [], {q: [] for q in args.quantiles}
    for g in np.array_split(np.asarray(args.seeds), args.folds):
        fit_seeds = [s for s in args.seeds if s not in g]
        rec = train(fit_seeds, config)
        # each class's training distances, for its threshold at every quantile
        own = [[] for _ in classes]
        for s in fit_seeds:
            f, lab, _ = record(s, config)
            z = rec.scaler.transform(f)
            for i, a in enumerate(classes):
                m = np.asarray(lab) == a
                own[i].append(rec._mahalanobis(z[m], rec.means[i], rec.precisions[i]))
        own = [np.concatenate(d) for d in own]
        for s in g:
            f, lab, pure = record(int(s), config, unknown=True)
            z = rec.scaler.transform(f)
            d = np.stack([rec._mahalanobis(z, m, p)
                          for m, p in zip(rec.means, rec.precisions)], axis=1)
            post = rec.posteriors(f)  # the known mask only flattens unknown windows
            true.append(np.asarray(lab, dtype=object)[pure])
            best.append(np.asarray(classes, dtype=object)[np.argmax(post, axis=1)][pure])
            dist.append(d[pure])
            for q in args.quantiles:
                thresholds[q].append(np.array([np.quantile(x, q) for x in own]))
        print("fold %s done" % list(g), flush=True)
    sizes = [len(t) for t in true]
    t = np.concatenate(true)
    for q in args.quantiles:
        th = np.vstack([np.repeat(th[None], n, axis=0)
                        for th, n in zip(thresholds[q], sizes)])
        known = (np.vstack(dist) <= th).any(axis=1)
        unknown = np.where(known, np.concatenate(best), UNKNOWN) == UNKNOWN
        rate = {a: float(np.mean(unknown[t == a])) for a in KNOWN + UNKNOWN_ACTIVITIES}
        print("q %.3f  known reported unknown: %s | unknown reported unknown: %s" % (
            q, " ".join("%s %.3f" % (a, rate[a]) for a in KNOWN),
            " ".join("%s %.3f" % (a, rate[a]) for a in UNKNOWN_ACTIVITIES)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
