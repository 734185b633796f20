"""Angle samples from skeleton frames, and templates cut from them (no ROS).

The simulated tracker's frames (telepresence.skeleton_sim) and the frames assembled from
a bag's ``/tf`` (telepresence.gestures.SkeletonFrames) go through the same path:
``elbow_angles`` per frame, frames without usable angles skipped. ``record_sim_template``
is what ``record_gesture_template --sim`` writes: one gesture performed with the mean
parameters, its cycles cut out (the raising and lowering of the arm left out).
"""
from __future__ import annotations

from typing import Iterable, List, Optional, Tuple

import numpy as np

from telepresence.gestures import BadSkeleton, Template, elbow_angles, resample
from telepresence.skeleton_sim import SensorParams, SkeletonSource, script_of

Sample = Tuple[float, int, float, float]  # t [s], user, yaw [rad], pitch [rad]
TEMPLATE_RATE_HZ = 15.0  # the templates' time base [Hz]


def frame_times(t0: float, t1: float, rate_hz: float) -> np.ndarray:
    return np.arange(t0, t1, 1.0 / rate_hz)


def sim_samples(source: SkeletonSource, times: Iterable[float]) -> List[Sample]:
    """The angle samples of the simulated tracker's frames at ``times`` (dropped frames
    and bad skeletons give none)."""
    out = []
    for t in times:
        f = source.frame(float(t))
        if f is None:
            continue
        try:
            yaw, pitch = elbow_angles(f.joints)
        except BadSkeleton:
            continue
        out.append((f.t, f.user, yaw, pitch))
    return out


def template_from_samples(command: str, samples: List[Sample], t_start: float,
                          t_end: float, rate_hz: float = TEMPLATE_RATE_HZ,
                          source: str = "") -> Template:
    """The samples of one user between ``t_start`` and ``t_end`` [s] as a template;
    ValueError if there are too few."""
    sel = [s for s in samples if t_start <= s[0] <= t_end]
    users = {s[1] for s in sel}
    if len(users) > 1:
        raise ValueError("the recording changes user (%s) between %.2f and %.2f s"
                         % (sorted(users), t_start, t_end))
    if len(sel) < 10:
        raise ValueError("only %d usable skeleton frames between %.2f and %.2f s"
                         % (len(sel), t_start, t_end))
    t = [s[0] for s in sel]
    yaw, pitch = resample(t, [s[2] for s in sel], [s[3] for s in sel], rate_hz)
    return Template(command, rate_hz, yaw, pitch, source)


def record_sim_template(command: str, seed: int, rate_hz: float = 30.0,
                        sensor: Optional[SensorParams] = None) -> Template:
    """``command`` performed once by the simulated person with the mean parameters
    (tempo, amplitude, two cycles) and ``seed``'s sensor noise, recorded at ``rate_hz``
    and cut to its cycles."""
    script = script_of(["rest", command, "rest"], seed, nominal=True)
    src = SkeletonSource(script, sensor or SensorParams(lost_per_min=0.0), seed)
    g = script[1]
    start = g.t0 + (g.t1 - g.motion_end)  # BLEND_S: the raise done
    samples = sim_samples(src, frame_times(0.0, src.end_s, rate_hz))
    return template_from_samples(command, samples, start, g.motion_end,
                                 source="simulated person, seed %d" % seed)
