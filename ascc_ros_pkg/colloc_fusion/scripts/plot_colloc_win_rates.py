#!/usr/bin/env python3
"""In how many trials each fusion beat a single robot, three readings side by side, with
what an ideal fusion of robots with the run's error statistics would do
(summary.json's ``theory``, colloc_fusion.win_rates), for bench_colloc.py runs.

    python ascc_ros_pkg/colloc_fusion/scripts/plot_colloc_win_rates.py OUT.png \
        LABEL=DIR [LABEL=DIR ...]

Readings: the best robot of each trial chosen afterwards with the truth, the robot chosen
in advance (best on average on another set: the run's ``--advance-from``), the median
robot. Bars: the share of trials; whiskers: the 90 % binomial (Wilson) interval; black
tick: the ideal fusion's expected share; dashed: half the trials ("most" is above it).
"""
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHODS = [("thesis", "thesis", "tab:red"), ("thesis+gate", "thesis + gate", "tab:blue"),
           ("information+gate", "information + gate", "tab:purple"),
           ("ci+gate", "CI + gate", "tab:olive")]
READINGS = [("per_trial_best", "per_trial_best", "best robot of each trial\n(chosen "
             "with the truth)"),
            ("advance_robot", "best_on_average", "robot chosen in advance\n(best on "
             "average, other set)"),
            ("median_robot", "median_robot", "median robot")]
Z90 = 1.6449


def wilson(k, n, z=Z90):
    """The Wilson score interval of k successes in n trials."""
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return c - h, c + h


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    out, runs = sys.argv[1], [a.split("=", 1) for a in sys.argv[2:]]
    ncol = min(2, len(runs))
    nrow = (len(runs) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.6 * ncol, 3.9 * nrow + 0.5),
                             sharey=True, squeeze=False)
    for ax in axes.flat[len(runs):]:
        ax.set_visible(False)
    width = 0.8 / len(METHODS)
    for ax, (label, d) in zip(axes.flat, runs):
        with open(os.path.join(d, "summary.json")) as f:
            summ = json.load(f)["summary"]
        th = summ.get("theory", {})
        for j, (reading, th_key, _) in enumerate(READINGS):
            for i, (m, name, color) in enumerate(METHODS):
                b = summ["beats"].get(m, {})
                n = b.get("advance_trials" if reading == "advance_robot" else "trials")
                if not n or reading not in b:
                    continue
                x = j + (i - (len(METHODS) - 1) / 2) * width
                p = b[reading] / n
                lo, hi = wilson(b[reading], n)
                ax.bar(x, p, width * 0.9, color=color, label=name if j == 0 else None)
                ax.errorbar(x, p, yerr=[[p - lo], [hi - p]], color="k", lw=0.8,
                            capsize=2)
            if th_key in th:
                ax.plot([j - 0.42, j + 0.42], [th[th_key]] * 2, color="k", lw=2,
                        label="ideal fusion (theory)" if j == 0 else None)
        ax.axhline(0.5, color="0.4", ls="--", lw=1)
        ax.set_xticks(range(len(READINGS)))
        ax.set_xticklabels([r[2] for r in READINGS], fontsize=7.5)
        ax.set_ylim(0, 1.05)
        n_trials = summ["beats"].get("thesis", {}).get("trials", 0)
        adv = summ.get("advance_robot") or "-"
        ax.set_title("%s (%d trials; in advance: %s)" % (label, n_trials, adv), fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
    for row in axes:
        row[0].set_ylabel("share of trials the fusion's\nerror is below")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(out, dpi=90)
    print(out)


if __name__ == "__main__":
    main()
