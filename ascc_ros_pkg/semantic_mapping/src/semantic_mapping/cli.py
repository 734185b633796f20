"""The evaluation commands of thesis 5.5 (fixed interfaces, issue 16):

    rosrun semantic_mapping forward_fusion [--trials N] [--seed S] [--exact]
    rosrun semantic_mapping sequential_test

`forward_fusion` prints the confusion matrix in Table 5.4's layout (rows: decision 1..5,
columns: true furniture type 1..5, then the accuracy row), ours beside the printed one,
and as its last line ``accuracy: a1 a2 a3 a4 a5`` (ours, furniture types 1..5). With
``--exact`` the counts are the expected ones (trials x the probabilities from enumerating
every (O, CL) pair) and the accuracies exact.

`sequential_test` prints Table 5.5's rows for t1..t5 (true type, O, CL, the estimate,
entropy and mutual information [bits]), each computed row followed by the printed one,
then the room belief P_t(R) after each step.

Both read the model tables from ``--models`` (default ``config/models.yaml``) and the
printed results and the sequential scenario from ``--thesis`` (default
``config/thesis_results.yaml``). Exit status: 0 ok, 2 bad arguments or an unreadable or
malformed file (the message names it).
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import List, Optional, Sequence

import numpy as np

from .evaluation import forward_fusion_exact, forward_fusion_sampled, sequential, tied_pairs
from .models import DEFAULT_MODELS, ModelError, Models, load_models, read_yaml

DEFAULT_THESIS = os.path.join(os.path.dirname(DEFAULT_MODELS), "thesis_results.yaml")


def _common(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--models", default=DEFAULT_MODELS,
                    help="model tables YAML (default: the package's config/models.yaml)")
    ap.add_argument("--thesis", default=DEFAULT_THESIS,
                    help="the thesis's printed results YAML (config/thesis_results.yaml)")


def _load(args) -> tuple:
    models = load_models(args.models)
    thesis = read_yaml(args.thesis)
    if not isinstance(thesis, dict):
        raise ModelError("%s: expected a mapping" % args.thesis)
    return models, thesis


def _thesis_part(thesis: dict, key: str, fields: Sequence[str], path: str) -> dict:
    part = thesis.get(key)
    if not isinstance(part, dict) or any(k not in part for k in fields):
        raise ModelError("%s: %s: expected the fields %s" % (path, key, ", ".join(fields)))
    return part


def _row(label: str, values: Sequence, fmt: str, width: int = 8) -> str:
    return label + "".join(("{:>%d%s}" % (width, fmt)).format(v) for v in values)


def forward_fusion_lines(models: Models, printed: dict, trials: int, seed: int,
                         exact: bool) -> List[str]:
    n = len(models.furniture)
    if exact:
        probs = forward_fusion_exact(models)
        counts, accuracy, cfmt = probs * trials, np.diag(probs), ".1f"
        how = "exact: every (O, CL) pair enumerated; counts are expected counts"
    else:
        counts = forward_fusion_sampled(models, trials, np.random.default_rng(seed))
        accuracy, cfmt = np.diag(counts) / float(trials), "d"
        how = "sampled: seed %d; A ~ P(A|F), O ~ P(O|A), CL ~ P(CL|F)" % seed
    names = ", ".join("%d %s" % (i + 1, f) for i, f in enumerate(models.furniture))
    lines = ["forward fusion test (thesis 5.5.1): furniture types %s" % names,
             "%d trials per type, uniform prior, decision eq. 5.3; %s" % (trials, how)]
    ties = tied_pairs(models)
    if ties:
        lines.append("ties (decided for the lowest type): %s" % ", ".join(
            "O=%d CL=%d" % (o + 1, c + 1) for o, c in ties))
    ref_counts, ref_acc = printed["confusion"], printed["accuracy"]
    lines.append("%-10s%s   | thesis Table 5.4 (%d trials)" % (
        "", "ours: true furniture type F".center(8 * n), printed["trials"]))
    lines.append(_row("%-10s" % "decision", range(1, n + 1), "d")
                 + "   |" + _row("", range(1, n + 1), "d"))
    for d in range(n):
        lines.append(_row("%-10d" % (d + 1), counts[d], cfmt) + "   |"
                     + _row("", ref_counts[d], "d"))
    lines.append(_row("%-10s" % "accuracy", accuracy, ".4f") + "   |"
                 + _row("", ref_acc, ".4f"))
    lines.append("accuracy: " + " ".join("%.4f" % a for a in accuracy))
    return lines


def forward_fusion_main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="forward_fusion",
                                 description="The forward fusion test of thesis 5.5.1.")
    ap.add_argument("--trials", type=int, default=1000,
                    help="trials per furniture type (default 1000, as in the thesis)")
    ap.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    ap.add_argument("--exact", action="store_true",
                    help="expected accuracies by enumerating every (O, CL) pair")
    _common(ap)
    args = ap.parse_args(argv)
    if args.trials < 1:
        ap.error("--trials must be at least 1")
    try:
        models, thesis = _load(args)
        printed = _thesis_part(thesis, "table_5_4", ("trials", "confusion", "accuracy"),
                               args.thesis)
    except (OSError, ModelError) as e:
        print("forward_fusion: %s" % e, file=sys.stderr)
        return 2
    print("\n".join(forward_fusion_lines(models, printed, args.trials, args.seed,
                                         args.exact)))
    return 0


SEQUENTIAL_FIELDS = ("grid", "furniture", "observation", "location_type", "estimate",
                     "entropy", "mutual_information")


def _one_based(values: Sequence, n: int, field: str, path: str) -> List[int]:
    if not all(isinstance(v, int) and 1 <= v <= n for v in values):
        raise ModelError("%s: table_5_5: %s: values must be integers 1..%d" % (path, field, n))
    return [v - 1 for v in values]


def sequential_lines(models: Models, printed: dict, path: str) -> List[str]:
    n_t = len(printed["grid"])
    if any(len(printed[k]) != n_t for k in SEQUENTIAL_FIELDS):
        raise ModelError("%s: table_5_5: every row must have %d entries" % (path, n_t))
    obs = _one_based(printed["observation"], len(models.activities), "observation", path)
    cls = _one_based(printed["location_type"], len(models.location_types), "location_type",
                     path)
    steps = sequential(models, printed["grid"], obs, cls)
    head = "%-24s" % ""
    lines = ["sequential test (thesis 5.5.2): grids %s at t1..t%d; eq. 5.2 from uniform "
             "priors; entropy in bits" % (" ".join(str(g) for g in printed["grid"]), n_t),
             head + "".join("%9s" % ("t%d" % (i + 1)) for i in range(n_t)),
             _row("%-24s" % "Furniture type", printed["furniture"], "d", 9),
             _row("%-24s" % "Motion observation O", printed["observation"], "d", 9),
             _row("%-24s" % "Location category CL", printed["location_type"], "d", 9),
             _row("%-24s" % "Furniture estimation", [s.update.label + 1 for s in steps],
                  "d", 9),
             _row("%-24s" % "  printed (Table 5.5)", printed["estimate"], "d", 9),
             _row("%-24s" % "Entropy", [s.update.entropy_bits for s in steps], ".4f", 9),
             _row("%-24s" % "  printed (Table 5.5)", printed["entropy"], ".4f", 9),
             _row("%-24s" % "Mutual Information",
                  [s.update.information_bits for s in steps], ".4f", 9),
             _row("%-24s" % "  printed (Table 5.5)", printed["mutual_information"], ".4f",
                  9)]
    for r, room in enumerate(models.rooms):
        lines.append(_row("%-24s" % ("P_t(R=%s)" % room), [s.room[r] for s in steps],
                          ".4f", 9))
    return lines


def sequential_test_main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="sequential_test",
                                 description="The sequential simulation of thesis 5.5.2.")
    _common(ap)
    args = ap.parse_args(argv)
    try:
        models, thesis = _load(args)
        printed = _thesis_part(thesis, "table_5_5", SEQUENTIAL_FIELDS, args.thesis)
        lines = sequential_lines(models, printed, args.thesis)
    except (OSError, ModelError) as e:
        print("sequential_test: %s" % e, file=sys.stderr)
        return 2
    print("\n".join(lines))
    return 0
