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
clipped at ``LATENCY_CLIP_M`` so that a corner or a bad range does not decide). Only a
window in which the robot's turn rate changed by at least ``min_turn_rate_change_radps``
says anything (a robot that drives straight, or turns steadily, moves every candidate's
positions alike); then the estimate moves a share ``latency_gain`` of the way to the
winner. Until the first such window, ``latency_s`` is used.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

from ascc_common.params import param

LATENCY_CLIP_M = 0.3  # [m] residuals are clipped at this (corners, bad ranges)
ODOM_SLACK_S = 0.1  # [s] the newest odometry may be this much older than the newest stamp
RATE_STEP_S = 0.1  # [s] the turn rate's changes are judged on odometry this far apart


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
    min_turn_rate_change_radps: float = param(0.3, "[rad/s] the robot's turn rate must "
                                                   "have changed this much within the "
                                                   "window for an estimate", gt=0.0)
    latency_gain: float = param(0.3, "share of the way the estimate moves to a window's "
                                     "best candidate", gt=0.0, le=1.0)

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


def roughness(t: np.ndarray, xy: np.ndarray) -> float:
    """Mean squared distance [m^2] of each inner position from the straight line between
    its neighbours at its time (residuals clipped at ``LATENCY_CLIP_M``)."""
    f = ((t[1:-1] - t[:-2]) / np.maximum(t[2:] - t[:-2], 1e-9))[:, None]
    mid = xy[:-2] + f * (xy[2:] - xy[:-2])
    r = np.minimum(np.hypot(*(xy[1:-1] - mid).T), LATENCY_CLIP_M)
    return float(np.mean(r ** 2))


class LatencyEstimator:
    """The camera latency [s] (module doc). ``add`` each measured position of the followed
    target (base_link, at the frame's stamp) with the odometry around it."""

    def __init__(self, p: LatencyParams):
        self.p = p
        self.latency_s = p.latency_s
        self.estimates = 0  # windows that moved the estimate
        self.last_costs: Optional[np.ndarray] = None  # per candidate, of the last window
        self.candidates = np.arange(0.0, p.max_latency_s + 0.5 * p.latency_step_s,
                                    p.latency_step_s)
        self._obs: List[Tuple[float, float, float]] = []

    def reset_track(self) -> None:
        """Another target is followed: its positions do not continue the old ones."""
        self._obs = []

    def add(self, stamp_s: float, xy_base: Tuple[float, float], odom_stamps: np.ndarray,
            odom_poses: np.ndarray) -> float:
        """One measured position of the followed target (frame stamp, base_link [m]);
        ``odom_stamps``/``odom_poses``: the odometry history (increasing stamps, N x 3).
        Returns the latency estimate."""
        if not self.p.estimate_latency:
            return self.latency_s
        if not (np.all(np.isfinite(xy_base)) and np.isfinite(stamp_s)):
            return self.latency_s
        if self._obs and stamp_s <= self._obs[-1][0]:
            return self.latency_s
        self._obs.append((float(stamp_s), float(xy_base[0]), float(xy_base[1])))
        while self._obs and self._obs[0][0] < stamp_s - self.p.latency_window_s:
            del self._obs[0]
        if len(self._obs) < 5 or len(odom_stamps) < 3:
            return self.latency_s
        obs = np.asarray(self._obs)
        stamps = np.asarray(odom_stamps, float)
        poses = np.asarray(odom_poses, float)
        # the odometry must cover the window at every candidate latency (its newest pose
        # may be a little older than the newest stamp)
        if stamps[0] > obs[0, 0] - self.candidates[-1] or \
                stamps[-1] < obs[-1, 0] - ODOM_SLACK_S:
            return self.latency_s
        grid = np.arange(obs[0, 0] - self.candidates[-1], obs[-1, 0], RATE_STEP_S)
        rate = np.diff(poses_at(stamps, poses, grid)[:, 2]) / RATE_STEP_S
        if rate.size < 2 or float(rate.max() - rate.min()) < self.p.min_turn_rate_change_radps:
            return self.latency_s
        costs = np.array([roughness(obs[:, 0],
                                    place(poses_at(stamps, poses, obs[:, 0] - lat),
                                          obs[:, 1:]))
                          for lat in self.candidates])
        self.last_costs = costs
        best = float(self.candidates[int(np.argmin(costs))])
        self.latency_s += self.p.latency_gain * (best - self.latency_s)
        self.estimates += 1
        return self.latency_s
