"""The camera's latency, estimated from the followed target's track (no rospy).

A camera frame is stamped when its first byte reaches ``q24_camera`` (issue 21; an IP
camera sends no capture time), but it was exposed earlier: exposure, read-out, JPEG
encoding and the network take 0.1-0.3 s on an IP camera (the simulated Q24: rendering and
encoding, 0.16 s at a load average of 7 on two cores and 0.3-1.0 s under heavier load,
measured against the ground truth: docs/results/target_follower.md). The follower places
each detection in odom at the robot's pose when the frame was taken; at the stamp instead,
a robot turning at w rad/s puts a target at range r off by about ``w * latency * r``
sideways (0.5 rad/s, 0.3 s, 1.5 m: 0.23 m). Those false sideways jumps come back as the
robot turns the other way, the trail and the steering follow them, the robot weaves and
falls back (held-out apartment, seed 1: 33 % of the straight samples out of the +-0.3 m
band).

The latency is not a constant of the camera (it grows with the load of the machine that
encodes and decodes), so it is estimated, continuously, from what the follower already
has. The followed target moves smoothly in odom (a person walks at a steady velocity
between turns) whatever the robot does, while a wrong latency moves its measured position
with the robot's changes of turn rate. For each candidate latency L (0 to
``max_latency_s`` by ``latency_step_s``) the target's positions over the last
``latency_window_s`` are placed at the odometry pose at stamp - L, and the candidate whose
positions are smoothest wins: the smallest mean squared distance of each position from
the straight line between its neighbours at its time (second differences; residuals
clipped at ``LATENCY_CLIP_M`` so that a corner or a bad range does not decide).

A window decides little on its own, and often nothing: while the robot drives straight,
or turns steadily, every candidate moves the positions alike and the costs differ only by
noise (office, seed 0, real-time factor 0.5: a run of such windows moved the earlier
per-window estimate from 0.1 to 0.63 s at a corner, truth 0.12 s). So the windows are
combined as evidence, in the way of least squares:

- **excitation**: every ``latency_update_s`` the window's *excitation* is computed from
  the odometry alone (no measurement): how far a latency error of ``EXCITATION_DELAY_S``
  moves the window's positions off their smooth path (root mean square of the change of
  the second-difference residuals, [m]). A window below ``min_excitation_m`` is skipped
  (its curve would be noise), and so is every window while the robot drives straight;
- **evidence**: an accepted window's cost curve, less its minimum, is divided by the
  window's noise (its minimum cost: the residual variance at the best candidate) and
  multiplied by its number of positions: a chi-square-like curve, in which a flat
  window weighs nothing and a sharp one much. The curves add up in ``evidence``,
  forgotten with the time constant ``latency_memory_s`` (the latency follows the load)
  and scaled by ``latency_update_s / latency_window_s`` (overlapping windows reuse each
  position that many times);
- **estimate and confidence**: the evidence's minimum (refined between candidates by a
  parabola) is the best latency, and its curvature there gives the standard error
  ``latency_std_s`` (least squares: evidence rises by 1 at one standard error). The
  estimate moves toward the best latency only once ``min_latency_windows`` windows were
  accepted and while that standard error is below ``max_latency_std_s``, by at most
  ``max_latency_change_s`` per update; otherwise it keeps its value. Until then,
  ``latency_s`` is used. The standard error assumes the residuals are noise; they are
  also the person's own changes of pace (starting to walk: the first windows of a
  recorded office run put the best latency at 0.8 s for 0.14 s), which is why a few
  windows are not trusted however sharp their curves.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

from ascc_common.params import param

LATENCY_CLIP_M = 0.3  # [m] residuals are clipped at this (corners, bad ranges)
ODOM_SLACK_S = 0.1  # [s] the newest odometry may be this much older than the newest stamp
EXCITATION_DELAY_S = 0.1  # [s] the latency error whose effect measures a window's excitation
MIN_POSITIONS = 8  # positions a window needs to be judged
NOISE_FLOOR_M2 = 1e-4  # [m^2] the smallest residual variance a window is credited with (1 cm)


@dataclass
class LatencyParams:
    """The camera latency the follower subtracts from the frames' stamps (module doc)."""

    latency_s: float = param(0.0, "[s] camera latency (exposure to the stamp): the "
                                  "estimate's start, or the value with "
                                  "estimate_latency false", ge=0.0)
    estimate_latency: bool = param(True, "estimate the latency from the followed "
                                         "target's track (module doc)")
    max_latency_s: float = param(1.0, "[s] largest latency considered", ge=0.0)
    latency_step_s: float = param(0.02, "[s] step of the candidate latencies", gt=0.0)
    latency_window_s: float = param(4.0, "[s] the target's positions over this long "
                                         "judge the candidates", gt=0.0)
    latency_update_s: float = param(0.5, "[s] a window is judged this often", gt=0.0)
    min_excitation_m: float = param(0.0002, "[m] a window counts only if a 0.1 s latency "
                                           "error would move its positions off their "
                                           "smooth path by this much (RMS)", ge=0.0)
    latency_memory_s: float = param(30.0, "[s] time constant with which old windows' "
                                          "evidence is forgotten", gt=0.0)
    max_latency_std_s: float = param(0.3, "[s] the estimate moves only while the "
                                          "evidence's standard error is below this",
                                     gt=0.0)
    max_latency_change_s: float = param(0.05, "[s] largest change of the estimate per "
                                              "update", gt=0.0)
    min_latency_windows: int = param(16, "windows the evidence needs before the estimate "
                                         "moves", ge=1)

    def validate(self) -> None:
        if self.latency_s > self.max_latency_s:
            raise ValueError("latency_s %.3f is above max_latency_s %.3f"
                             % (self.latency_s, self.max_latency_s))


def poses_at(stamps: np.ndarray, poses: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(x, y, yaw) interpolated at times ``t`` from odometry ``stamps`` (increasing) and
    ``poses`` (N x 3); clamped to the ends."""
    yaw = np.unwrap(poses[:, 2])
    return np.stack([np.interp(t, stamps, poses[:, 0]), np.interp(t, stamps, poses[:, 1]),
                     np.interp(t, stamps, yaw)], axis=-1)


def place(pose: np.ndarray, xy_base: np.ndarray) -> np.ndarray:
    """base_link points (N x 2) into odom through the poses (N x 3)."""
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([pose[..., 0] + c * xy_base[..., 0] - s * xy_base[..., 1],
                     pose[..., 1] + s * xy_base[..., 0] + c * xy_base[..., 1]], axis=-1)


def residuals(t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(..., N-2, 2) offsets of each inner position (``xy``: (..., N, 2)) from the
    straight line between its neighbours at its time (unclipped)."""
    f = ((t[1:-1] - t[:-2]) / np.maximum(t[2:] - t[:-2], 1e-9))[:, None]
    return xy[..., 1:-1, :] - (xy[..., :-2, :] + f * (xy[..., 2:, :] - xy[..., :-2, :]))


def roughness(t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Mean squared distance [m^2] of each inner position from the straight line between
    its neighbours at its time (residuals clipped at ``LATENCY_CLIP_M``); ``xy`` (N, 2)
    or stacked candidates (K, N, 2)."""
    r = np.minimum(np.linalg.norm(residuals(t, xy), axis=-1), LATENCY_CLIP_M)
    return np.mean(r ** 2, axis=-1)


class LatencyEstimator:
    """The camera latency [s] (module doc). ``add`` each measured position of the followed
    target (base_link, at the frame's stamp) with the odometry around it."""

    def __init__(self, p: LatencyParams):
        self.p = p
        self.latency_s = p.latency_s
        self.latency_std_s = math.inf  # standard error of the evidence's best latency
        self.best_s: Optional[float] = None  # the evidence's best latency
        self.estimates = 0  # windows accepted as evidence
        self.windows = 0  # windows judged (accepted or not)
        self.last_excitation_m = 0.0  # of the last window judged
        self.last_costs: Optional[np.ndarray] = None  # per candidate, of the last window
        self.candidates = np.arange(0.0, p.max_latency_s + 0.5 * p.latency_step_s,
                                    p.latency_step_s)
        self.evidence = np.zeros(len(self.candidates))
        self._evidence_t: Optional[float] = None  # [s] stamp of the evidence's last update
        self._next_update = -math.inf  # [s] stamp at which the next window is judged
        self._obs: List[Tuple[float, float, float]] = []

    @property
    def confidence(self) -> float:
        """The standard error as a share: 1 - latency_std_s / max_latency_std_s, clipped
        to [0, 1] (0: no usable evidence)."""
        return float(np.clip(1.0 - self.latency_std_s / self.p.max_latency_std_s, 0.0, 1.0))

    def reset_track(self) -> None:
        """Another target is followed: its positions do not continue the old ones (the
        evidence on the latency, a property of the camera, is kept)."""
        self._obs = []

    def add(self, stamp_s: float, xy_base: Tuple[float, float], odom_stamps: np.ndarray,
            odom_poses: np.ndarray) -> float:
        """One measured position of the followed target (frame stamp, base_link [m]);
        ``odom_stamps``/``odom_poses``: the odometry history (increasing stamps, N x 3;
        only the span the window needs is read). Returns the latency estimate."""
        if not self.p.estimate_latency:
            return self.latency_s
        if not (np.all(np.isfinite(xy_base)) and np.isfinite(stamp_s)):
            return self.latency_s
        if self._obs and stamp_s <= self._obs[-1][0]:
            return self.latency_s
        self._obs.append((float(stamp_s), float(xy_base[0]), float(xy_base[1])))
        while self._obs and self._obs[0][0] < stamp_s - self.p.latency_window_s:
            del self._obs[0]
        if stamp_s < self._next_update or len(self._obs) < MIN_POSITIONS or \
                len(odom_stamps) < 3:
            return self.latency_s
        obs = np.asarray(self._obs)
        # the odometry must cover the window at every candidate latency (its newest pose
        # may be a little older than the newest stamp)
        lo = obs[0, 0] - self.candidates[-1]
        if odom_stamps[0] > lo or odom_stamps[-1] < obs[-1, 0] - ODOM_SLACK_S:
            return self.latency_s
        i0 = max(0, int(np.searchsorted(odom_stamps, lo, side="right")) - 1)
        stamps = np.asarray(odom_stamps[i0:], float)
        poses = np.asarray(odom_poses[i0:], float)
        self._next_update = stamp_s + self.p.latency_update_s
        self.windows += 1
        self._judge(obs, stamps, poses)
        return self.latency_s

    def _judge(self, obs: np.ndarray, stamps: np.ndarray, poses: np.ndarray) -> None:
        t, xy = obs[:, 0], obs[:, 1:]
        p = self.p
        # excitation, from the odometry alone: how a latency error reshapes the path
        lat = self.latency_s
        pair = place(poses_at(stamps, poses, np.stack([t - lat, t - lat - EXCITATION_DELAY_S])),
                     np.broadcast_to(xy, (2,) + xy.shape))
        res = residuals(t, pair)
        self.last_excitation_m = float(np.sqrt(np.mean(
            np.sum((res[1] - res[0]) ** 2, axis=-1))))
        self._forget(float(t[-1]))
        if self.last_excitation_m < p.min_excitation_m:
            return
        placed = place(poses_at(stamps, poses, t[None, :] - self.candidates[:, None]),
                       np.broadcast_to(xy, (len(self.candidates),) + xy.shape))
        costs = roughness(t, placed)
        self.last_costs = costs
        n = len(t) - 2  # residuals
        weight = n * p.latency_update_s / p.latency_window_s
        self.evidence += weight * (costs - costs.min()) / max(float(costs.min()),
                                                               NOISE_FLOOR_M2)
        self.estimates += 1
        self._decide()

    def _forget(self, now_s: float) -> None:
        if self._evidence_t is not None and now_s > self._evidence_t:
            self.evidence *= math.exp(-(now_s - self._evidence_t) / self.p.latency_memory_s)
        self._evidence_t = now_s

    def _decide(self) -> None:
        """The evidence's best latency and standard error; the estimate moves toward it
        when the error is small enough (module doc)."""
        e, c, h = self.evidence, self.candidates, self.p.latency_step_s
        i = int(np.argmin(e))
        best, curv = float(c[i]), 0.0
        if 0 < i < len(e) - 1:
            curv = (e[i - 1] - 2.0 * e[i] + e[i + 1]) / h ** 2  # d2e/dL2
            if curv > 0.0:
                best += float(np.clip(-(e[i + 1] - e[i - 1]) / (2.0 * h * curv), -h, h))
        else:  # at an end: the one-sided slope bounds the error
            j = 1 if i == 0 else len(e) - 2
            curv = 2.0 * max(float(e[j] - e[i]), 0.0) / h ** 2
        # evidence = curv/2 * (L - best)^2: it rises by 1 at sqrt(2 / curv)
        self.best_s = best
        self.latency_std_s = math.sqrt(2.0 / curv) if curv > 0.0 else math.inf
        if self.latency_std_s < self.p.max_latency_std_s and \
                self.estimates >= self.p.min_latency_windows:
            step = self.p.max_latency_change_s
            self.latency_s += float(np.clip(best - self.latency_s, -step, step))
