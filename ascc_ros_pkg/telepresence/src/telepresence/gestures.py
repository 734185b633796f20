"""Gesture recognition of thesis 4.4, without ROS: the right elbow's yaw and pitch, and
sliding-window least-mean-square template matching against recorded templates.

**Angles** (``elbow_angles``; README figure ``docs/images/telepresence_elbow_angles.png``):
the person's body frame is built from the skeleton: ``left`` = unit(left_shoulder -
right_shoulder), ``up`` = unit(neck - torso with its ``left`` component removed),
``forward`` = left x up (the way the chest faces). The forearm d = right_hand -
right_elbow in that frame gives the elbow's **yaw** psi = atan2(d.left, d.forward) (0: the
forearm points forward, +: toward the person's left) and **pitch** theta = atan2(d.up,
|d horizontal|) (+: up), in radians. They do not depend on where the person stands or
how they face the sensor.

**Matching** (``GestureMatcher``): each new sample (psi, theta) is first the mean of the
samples of the last ``smooth_s`` (3 frames at 30 Hz: less joint noise, 0.03 s of lag); the
newest samples are compared with each template over a window of the template's length, the
window ending at the newest sample, resampled to the template's time base (linear
interpolation; psi unwrapped). The error is the mean over the window of ``(cos theta_T *
wrap(psi - psi_T))^2 + (theta - theta_T)^2`` [rad^2] (the squared angle between the two
forearm directions for small differences: yaw counts less when the forearm points up or
down, where it is ill-defined). The window slides with every new sample (the thesis's
shift to the least error), and is also stretched by the ``time_scales`` (people beckon
faster or slower than the template). A template matches when its least error is below
``threshold_rad2``; the best template under the threshold is the command. A window that
spans a gap in the samples longer than ``max_gap_s`` (lost frames, bad data) is not
compared; after a command none is emitted for ``refractory_s``.
"""
from __future__ import annotations

import math
import re
from collections import deque
from dataclasses import dataclass
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param

JOINTS = ("head", "neck", "torso", "left_shoulder", "left_elbow", "left_hand",
          "right_shoulder", "right_elbow", "right_hand", "left_hip", "left_knee",
          "left_foot", "right_hip", "right_knee", "right_foot")  # openni_tracker's 15
JOINT_SET = frozenset(JOINTS)
ANGLE_JOINTS = ("torso", "neck", "left_shoulder", "right_shoulder", "right_elbow",
                "right_hand")
COMMANDS = ("come_close", "go_away")
MIN_SEGMENT_M = 0.05  # shorter shoulder or forearm segments: the skeleton is degenerate [m]


class BadSkeleton(ValueError):
    """A skeleton frame from which the angles cannot be computed (the reason is the
    message)."""


class TemplateError(ValueError):
    """A template file that is missing or malformed (the reason is the message)."""


def elbow_angles(joints: Dict[str, Any]) -> Tuple[float, float]:
    """(yaw, pitch) [rad] of the right forearm in the person's body frame (module
    docstring); BadSkeleton naming missing, non-finite or degenerate joints."""
    missing = [j for j in ANGLE_JOINTS if j not in joints or joints[j] is None]
    if missing:
        raise BadSkeleton("missing joints: %s" % ", ".join(missing))
    p = {j: np.asarray(joints[j], dtype=float) for j in ANGLE_JOINTS}
    bad = [j for j in ANGLE_JOINTS if p[j].shape != (3,) or not np.all(np.isfinite(p[j]))]
    if bad:
        raise BadSkeleton("non-finite (NaN/inf) or malformed joint positions: %s"
                          % ", ".join(bad))
    left = p["left_shoulder"] - p["right_shoulder"]
    n = float(np.linalg.norm(left))
    if n < MIN_SEGMENT_M:
        raise BadSkeleton("shoulders %.3f m apart: degenerate skeleton" % n)
    left /= n
    up = p["neck"] - p["torso"]
    up -= float(up @ left) * left
    n = float(np.linalg.norm(up))
    if n < MIN_SEGMENT_M:
        raise BadSkeleton("neck - torso %.3f m across the shoulders: degenerate skeleton"
                          % n)
    up /= n
    forward = np.cross(left, up)
    d = p["right_hand"] - p["right_elbow"]
    if float(np.linalg.norm(d)) < MIN_SEGMENT_M:
        raise BadSkeleton("right forearm %.3f m long: degenerate skeleton"
                          % float(np.linalg.norm(d)))
    df, dl, du = float(d @ forward), float(d @ left), float(d @ up)
    return math.atan2(dl, df), math.atan2(du, math.hypot(df, dl))


def wrap(a):
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


# -- templates ---------------------------------------------------------------------------
@dataclass
class Template:
    """A recorded gesture: yaw and pitch [rad] sampled at ``rate_hz``."""

    command: str
    rate_hz: float
    yaw: np.ndarray
    pitch: np.ndarray
    source: str = ""

    @property
    def duration_s(self) -> float:
        return (len(self.yaw) - 1) / self.rate_hz

    def to_dict(self) -> Dict[str, Any]:
        return {"command": self.command, "rate_hz": float(self.rate_hz),
                "source": self.source,
                "yaw_rad": [round(float(v), 5) for v in self.yaw],
                "pitch_rad": [round(float(v), 5) for v in self.pitch]}


def template_from_dict(d: Any, where: str = "template") -> Template:
    """A Template from its YAML dict; TemplateError naming what is wrong."""
    if not isinstance(d, dict):
        raise TemplateError("%s: not a mapping of command, rate_hz, yaw_rad, pitch_rad"
                            % where)
    missing = [k for k in ("command", "rate_hz", "yaw_rad", "pitch_rad") if k not in d]
    if missing:
        raise TemplateError("%s: lacks %s" % (where, ", ".join(missing)))
    if d["command"] not in COMMANDS:
        raise TemplateError("%s: command %r is not one of %s"
                            % (where, d["command"], ", ".join(COMMANDS)))
    rate = d["rate_hz"]
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) \
            or not math.isfinite(rate) or not 1.0 <= rate <= 200.0:
        raise TemplateError("%s: rate_hz must be in [1, 200] Hz, got %r" % (where, rate))
    arrays = []
    for key in ("yaw_rad", "pitch_rad"):
        try:
            a = np.asarray(d[key], dtype=float)
        except (TypeError, ValueError) as err:
            raise TemplateError("%s: %s is not a list of numbers (%s)" % (where, key, err)) from err
        if a.ndim != 1 or len(a) < 5 or not np.all(np.isfinite(a)):
            raise TemplateError("%s: %s must be a list of at least 5 finite angles"
                                % (where, key))
        arrays.append(a)
    if len(arrays[0]) != len(arrays[1]):
        raise TemplateError("%s: yaw_rad has %d samples, pitch_rad %d"
                            % (where, len(arrays[0]), len(arrays[1])))
    if np.any(np.abs(arrays[1]) > math.pi / 2 + 1e-6):
        raise TemplateError("%s: pitch_rad outside [-pi/2, pi/2]: not radians?" % where)
    return Template(d["command"], float(rate), arrays[0], arrays[1],
                    str(d.get("source", "")))


def load_template(path: str) -> Template:
    """The template in YAML file ``path``; TemplateError if missing or malformed."""
    import yaml
    try:
        with open(path) as f:
            d = yaml.safe_load(f)
    except OSError as err:
        raise TemplateError("cannot read template %s: %s" % (path, err.strerror or err)) from err
    except yaml.YAMLError as err:
        raise TemplateError("template %s is not YAML: %s" % (path, err)) from err
    return template_from_dict(d, "template %s" % path)


def save_template(path: str, template: Template) -> None:
    import yaml
    with open(path, "w") as f:
        f.write("# Gesture template (telepresence record_gesture_template): the right "
                "elbow's yaw and\n# pitch [rad] at rate_hz, see telepresence.gestures.\n")
        yaml.safe_dump(template.to_dict(), f, default_flow_style=None, sort_keys=False,
                       width=100)


def resample(t: Sequence[float], yaw: Sequence[float], pitch: Sequence[float],
             rate_hz: float) -> Tuple[np.ndarray, np.ndarray]:
    """Samples at times ``t`` resampled to ``rate_hz`` from t[0] (psi unwrapped first)."""
    t = np.asarray(t, float)
    grid = np.arange(t[0], t[-1] + 1e-9, 1.0 / rate_hz)
    y = np.interp(grid, t, np.unwrap(np.asarray(yaw, float)))
    return wrap(y), np.interp(grid, t, np.asarray(pitch, float))


# -- matching ----------------------------------------------------------------------------
@dataclass
class GestureParams:
    threshold_rad2: float = param(0.08, "a template matches when its mean squared angle "
                                  "error is below this [rad^2]", gt=0.0)
    time_scales: List[float] = param([0.8, 0.9, 1.0, 1.1, 1.25], "window lengths tried, "
                                     "relative to the template's", gt=0.2, le=5.0)
    max_gap_s: float = param(0.25, "a window spanning a longer gap between samples is not "
                             "compared [s]", gt=0.0)
    refractory_s: float = param(1.5, "no command for this long after one [s]", ge=0.0)
    smooth_s: float = param(0.08, "each sample is the mean of the samples of this last "
                            "stretch of time (causal moving average; 0: none) [s]", ge=0.0)


class Match(NamedTuple):
    t: float  # end of the matched window [s]
    command: str
    error_rad2: float
    time_scale: float


class GestureMatcher:
    """Feed samples with ``add(t, yaw, pitch)``; it returns a Match when a template
    matches (module docstring). ``reset()`` forgets the samples (another user, time
    going back)."""

    def __init__(self, templates: Sequence[Template], params: GestureParams):
        self.templates = list(templates)
        self.p = params
        longest = max((tp.duration_s for tp in self.templates), default=0.0)
        self.horizon_s = longest * max(params.time_scales) + 0.5
        self.samples: deque = deque()  # (t, unwrapped yaw, pitch), smoothed
        self.raw: deque = deque()  # (t, unwrapped yaw, pitch) of the last smooth_s
        self.last_command_t = -math.inf

    def reset(self) -> None:
        self.samples.clear()
        self.raw.clear()

    def add(self, t: float, yaw: float, pitch: float) -> Optional[Match]:
        if self.samples and t <= self.samples[-1][0]:
            return None  # not newer: ignored
        if self.raw:  # unwrap yaw against the previous sample
            prev = self.raw[-1][1]
            yaw = prev + float(wrap(yaw - prev))
        self.raw.append((t, yaw, pitch))
        while self.raw[0][0] <= t - self.p.smooth_s and len(self.raw) > 1:
            self.raw.popleft()
        n = len(self.raw)
        self.samples.append((t, sum(r[1] for r in self.raw) / n,
                             sum(r[2] for r in self.raw) / n))
        while self.samples and self.samples[0][0] < t - self.horizon_s:
            self.samples.popleft()
        best = self.best(t)
        if best is None or best.error_rad2 >= self.p.threshold_rad2:
            return None
        if t - self.last_command_t < self.p.refractory_s:
            return None
        self.last_command_t = t
        return best

    def errors(self, t: float) -> List[Match]:
        """The least error of every template for the window ending at ``t`` (templates
        whose windows cannot be compared are left out)."""
        if len(self.samples) < 2:
            return []
        a = np.asarray(self.samples)
        ts, ys, ps = a[:, 0], a[:, 1], a[:, 2]
        out = []
        for tp in self.templates:
            k = np.arange(len(tp.yaw)) / tp.rate_hz
            best = None
            for s in self.p.time_scales:
                start = t - s * tp.duration_s
                if ts[0] > start + 1e-9:
                    continue  # not enough history
                i0 = max(int(np.searchsorted(ts, start, side="right")) - 1, 0)
                if i0 + 1 < len(ts) and np.max(np.diff(ts[i0:])) > self.p.max_gap_s:
                    continue
                grid = start + s * k
                yaw = np.interp(grid, ts, ys)
                pitch = np.interp(grid, ts, ps)
                dy = np.cos(tp.pitch) * wrap(yaw - tp.yaw)
                err = float(np.mean(dy * dy + (pitch - tp.pitch) ** 2))
                if best is None or err < best.error_rad2:
                    best = Match(t, tp.command, err, s)
            if best is not None:
                out.append(best)
        return out

    def best(self, t: float) -> Optional[Match]:
        errs = self.errors(t)
        return min(errs, key=lambda m: m.error_rad2) if errs else None


class Step(NamedTuple):
    """What one skeleton frame gave: a command (or None), the angles (None if the frame
    was unusable) and problems as (kind, text) for throttled warnings."""

    match: Optional[Match]
    angles: Optional[Tuple[float, float]]
    problems: List[Tuple[str, str]]


class GestureRecognizer:
    """Skeleton frames -> commands: the angles of each frame into a GestureMatcher, with
    the bad-data rules: a frame without usable angles (missing joints, NaN) is skipped
    (a gap: windows across it are not compared); another user id forgets the samples
    (no window mixes two people); a frame not newer than the last is ignored."""

    def __init__(self, templates: Sequence[Template], params: GestureParams):
        self.matcher = GestureMatcher(templates, params)
        self.user: Optional[int] = None

    def reset(self) -> None:
        self.matcher.reset()
        self.user = None

    def on_frame(self, t: float, user: int, joints: Dict[str, Any]) -> Step:
        problems = []
        if self.user is not None and user != self.user:
            s = self.matcher.samples
            if s and t - s[-1][0] < self.matcher.horizon_s:
                problems.append(("user", "user id changed from %d to %d: the %d samples "
                                 "of the gesture window dropped (no command from two "
                                 "people's motion)" % (self.user, user, len(s))))
            self.matcher.reset()
        self.user = user
        try:
            yaw, pitch = elbow_angles(joints)
        except BadSkeleton as err:
            kind = "missing" if str(err).startswith("missing") else "bad"
            problems.append((kind, "user %d: skeleton frame skipped: %s" % (user, err)))
            return Step(None, None, problems)
        return Step(self.matcher.add(t, yaw, pitch), (yaw, pitch), problems)


# -- skeleton frames from TF ------------------------------------------------------------
FRAME_RE = re.compile(r"^/?([a-z_]+?)_(\d+)$")


class SkeletonFrames:
    """openni_tracker's TF transforms assembled into frames. openni_tracker sends each
    joint of a frame in its own transform with its own stamp, so a frame is the run of
    joints of one user within ``max_skew_s`` of its first, each joint once: ``add`` every
    transform (child ``<joint>_<user>`` of ``depth_frame``), ``take(now)`` the frames
    completed (all 15 joints, or the next frame begun, or ``max_skew_s`` passed since
    the first joint: then it may lack joints, which ``elbow_angles`` names)."""

    def __init__(self, depth_frame: str = "openni_depth_frame", max_skew_s: float = 0.05):
        self.depth_frame = depth_frame.lstrip("/")
        self.max_skew_s = max_skew_s
        self.current: Dict[str, Any] = {}  # joint -> xyz of the frame being assembled
        self.user: Optional[int] = None
        self.first_t = self.last_t = -math.inf
        self.ready: List[Tuple[float, int, Dict[str, Any]]] = []

    def add(self, parent: str, child: str, t: float, xyz: Any) -> Optional[str]:
        """Store one transform; a problem (a skeleton frame of another parent) as a
        string, None if stored or not a skeleton frame."""
        m = FRAME_RE.match(child)
        if m is None or m.group(1) not in JOINT_SET:
            return None
        if parent.lstrip("/") != self.depth_frame:
            return "skeleton frame %s has parent %s, expected %s" % (child, parent,
                                                                    self.depth_frame)
        user, joint = int(m.group(2)), m.group(1)
        if self.current and (user != self.user or joint in self.current
                             or t - self.first_t > self.max_skew_s):
            self._close()
        if not self.current:
            self.user, self.first_t = user, t
        self.current[joint] = xyz
        self.last_t = max(self.last_t, t) if len(self.current) > 1 else t
        if len(self.current) == len(JOINT_SET):
            self._close()
        return None

    def _close(self) -> None:
        self.ready.append((self.last_t, self.user, self.current))
        self.current = {}

    def take(self, now: float) -> List[Tuple[float, int, Dict[str, Any]]]:
        """The frames (t of their newest joint, user, joints) completed by ``now``, oldest
        first."""
        if self.current and now - self.first_t >= self.max_skew_s:
            self._close()
        out, self.ready = self.ready, []
        return out

    def clear(self) -> None:
        self.current, self.ready = {}, []
        self.user, self.first_t, self.last_t = None, -math.inf, -math.inf
