#!/usr/bin/env python3
"""The README's figure: the right elbow's yaw and pitch (telepresence.gestures), and the
template matching on a simulated performance.

    plot_elbow_angles.py [--seed N] [-o docs/images/telepresence_elbow_angles.png]

Top left: the person seen from above (yaw psi: the forearm's direction about the body's
up axis, 0 = forward, + = to the person's left). Bottom left: seen from their right
(pitch theta: above the horizontal plane of the body). Right: yaw and pitch of a
simulated script (seed N: rest, come_close, rest, scratch, rest, go_away, rest) with the
two templates drawn where they matched, and each template's least match error with the
threshold (log scale).
"""
import argparse
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from telepresence.gestures import GestureParams, GestureRecognizer, load_template  # noqa: E402
from telepresence.skeleton_sim import SkeletonSource, script_of  # noqa: E402

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOT = os.path.dirname(os.path.dirname(PKG))


def arrow(ax, a, b, **kw):
    ax.annotate("", xy=b, xytext=a, arrowprops=dict(arrowstyle="->", lw=2, **kw))


PSI, THETA = math.radians(35), math.radians(40)  # the drawn forearm's yaw and pitch


def geometry(ax_top, ax_side, psi=PSI, theta=THETA):
    # top view: forward = up the page, left = left of the page
    ax = ax_top
    ax.add_patch(plt.Circle((0, 0), 0.12, fill=False))
    ax.plot([-0.18, 0.18], [0, 0], "k-", lw=3)  # shoulders (left at -x on the page)
    ax.text(-0.2, -0.07, "left\nshoulder", ha="center", fontsize=8)
    ax.text(0.2, -0.07, "right\nshoulder", ha="center", fontsize=8)
    elbow = np.array([0.2, 0.1])
    ax.plot([0.18, elbow[0]], [0, elbow[1]], "k-", lw=2)
    c = math.cos(theta)
    d = np.array([-math.sin(psi), math.cos(psi)]) * 0.3 * c  # page x = -left
    arrow(ax, elbow, elbow + d, color="C0")
    arrow(ax, (0, 0), (0, 0.35), color="gray")
    arrow(ax, (0, 0), (-0.3, 0), color="gray")
    ax.text(0.01, 0.37, "forward", fontsize=8)
    ax.text(-0.33, 0.02, "left", fontsize=8)
    ax.plot([elbow[0], elbow[0]], [elbow[1], elbow[1] + 0.3 * c], "k:", lw=1)
    ang = np.linspace(0, psi, 20)
    ax.plot(elbow[0] - 0.15 * np.sin(ang), elbow[1] + 0.15 * np.cos(ang), "C0-")
    ax.text(elbow[0] - 0.08, elbow[1] + 0.18, "yaw ψ > 0", color="C0", fontsize=9)
    ax.set_title("from above: yaw ψ", fontsize=10)
    ax.set_aspect("equal")
    ax.set_xlim(-0.4, 0.45)
    ax.set_ylim(-0.15, 0.5)
    ax.axis("off")
    # side view from the person's right: forward = right of the page, up = up
    ax = ax_side
    ax.plot([0, 0], [-0.4, 0.35], "k-", lw=3)  # torso -> neck
    ax.add_patch(plt.Circle((0, 0.47), 0.1, fill=False))
    ax.text(0.02, -0.42, "torso", fontsize=8)
    ax.text(0.02, 0.33, "neck", fontsize=8)
    elbow = np.array([0.1, 0.0])
    ax.plot([0, elbow[0]], [0.3, elbow[1]], "k-", lw=2)
    d = np.array([math.cos(theta), math.sin(theta)]) * 0.3
    arrow(ax, elbow, elbow + d, color="C1")
    ax.plot([elbow[0], elbow[0] + 0.3], [0, 0], "k:", lw=1)
    ang = np.linspace(0, theta, 20)
    ax.plot(elbow[0] + 0.15 * np.cos(ang), 0.15 * np.sin(ang), "C1-")
    ax.text(elbow[0] + 0.17, 0.05, "pitch θ > 0", color="C1", fontsize=9)
    ax.text(elbow[0] + 0.1, elbow[1] + 0.24, "forearm\nelbow → hand", fontsize=8)
    ax.set_title("from the right: pitch θ", fontsize=10)
    ax.set_aspect("equal")
    ax.set_xlim(-0.2, 0.5)
    ax.set_ylim(-0.45, 0.6)
    ax.axis("off")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=1001)
    ap.add_argument("-o", "--output",
                    default=os.path.join(ROOT, "docs", "images",
                                         "telepresence_elbow_angles.png"))
    a = ap.parse_args()
    templates = {c: load_template(os.path.join(PKG, "templates", c + ".yaml"))
                 for c in ("come_close", "go_away")}
    params = GestureParams()
    script = script_of(["rest", "come_close", "rest", "scratch", "rest", "go_away", "rest"],
                       a.seed)
    src = SkeletonSource(script, seed=a.seed)
    rec = GestureRecognizer(list(templates.values()), params)
    ts, yaw, pitch, errs, matches = [], [], [], {c: [] for c in templates}, []
    for t in np.arange(0.0, src.end_s, 1.0 / 30.0):
        f = src.frame(float(t))
        if f is None:
            continue
        step = rec.on_frame(f.t, f.user, f.joints)
        if step.angles is None:
            continue
        ts.append(f.t)
        yaw.append(step.angles[0])
        pitch.append(step.angles[1])
        got = {m.command: m.error_rad2 for m in rec.matcher.errors(f.t)}
        for c in templates:
            errs[c].append(got.get(c, np.nan))
        if step.match:
            matches.append(step.match)

    fig = plt.figure(figsize=(12, 6))
    geometry(fig.add_subplot(2, 3, 1), fig.add_subplot(2, 3, 4))
    ax1 = fig.add_subplot(2, 3, (2, 3))
    ax2 = fig.add_subplot(2, 3, (5, 6), sharex=ax1)
    ax1.plot(ts, np.degrees(yaw), "C0-", lw=1, label="yaw ψ")
    ax1.plot(ts, np.degrees(pitch), "C1-", lw=1, label="pitch θ")
    for m in matches:
        tp = templates[m.command]
        k = m.t - m.time_scale * tp.duration_s + m.time_scale * np.arange(len(tp.yaw)) \
            / tp.rate_hz
        ax1.plot(k, np.degrees(tp.yaw), "C0--", lw=2)
        ax1.plot(k, np.degrees(tp.pitch), "C1--", lw=2)
        ax1.axvline(m.t, color="k", lw=0.8)
        ax1.text(m.t, -112, "%s " % m.command, ha="right", fontsize=8)
    for e in script:
        if e.kind != "rest":
            ax1.axvspan(e.t0, e.t1, color="0.92")
            ax1.text((e.t0 + e.t1) / 2, 100, e.kind, ha="center", fontsize=8)
    ax1.set_ylabel("angle [deg]")
    ax1.set_ylim(-150, 112)
    ax1.plot([], [], "k--", lw=2, label="template, where it matched (command: black line)")
    ax1.legend(loc="lower left", fontsize=8, ncol=3)
    ax1.set_title("simulated performance (seed %d) and the templates (seed 1)" % a.seed,
                  fontsize=10)
    for c, col in (("come_close", "C2"), ("go_away", "C3")):
        ax2.semilogy(ts, errs[c], col + "-", lw=1, label=c)
    ax2.axhline(params.threshold_rad2, color="k", ls=":", label="threshold")
    ax2.set_ylabel("least match error [rad²]")
    ax2.set_xlabel("time [s]")
    ax2.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(a.output, dpi=90)
    print("wrote %s (%d commands: %s)" % (a.output, len(matches),
                                          ", ".join(m.command for m in matches)))


if __name__ == "__main__":
    main()
