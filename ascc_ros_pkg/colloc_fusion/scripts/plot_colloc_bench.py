#!/usr/bin/env python3
"""Per-trial errors of bench_colloc.py runs side by side (log scale): each robot alone,
the best robot, the thesis's fusion with and without the gate.

    python ascc_ros_pkg/colloc_fusion/scripts/plot_colloc_bench.py OUT.png \
        LABEL=DIR [LABEL=DIR ...]
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SERIES = [("robotA", "robot A", "o", "0.7"), ("robotB", "robot B", "s", "0.7"),
          ("robotC", "robot C", "^", "0.7"), ("best_robot", "best robot", "_", "k"),
          ("thesis", "thesis fusion", "x", "tab:red"),
          ("thesis+gate", "thesis + gate", "+", "tab:blue")]


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    out, runs = sys.argv[1], [a.split("=", 1) for a in sys.argv[2:]]
    fig, axes = plt.subplots(1, len(runs), figsize=(5.5 * len(runs), 4.2), sharey=True,
                             squeeze=False)
    for ax, (label, d) in zip(axes[0], runs):
        with open(os.path.join(d, "summary.json")) as f:
            trials = [t for t in json.load(f)["trials"] if not t.get("failed")]
        for key, name, marker, color in SERIES:
            xs = [t["trial"] for t in trials if t.get(key) is not None]
            ys = [t[key] for t in trials if t.get(key) is not None]
            ax.scatter(xs, ys, marker=marker, color=color, label=name, s=30)
        ax.axhline(0.04, color="tab:green", lw=1, ls="--", label="goal 4 cm")
        ax.set_yscale("log")
        ax.set_title(label)
        ax.set_xlabel("trial (0: the world's placement)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("mean error over the recorded 20 s [m]")
    axes[0][-1].legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(out)


if __name__ == "__main__":
    main()
