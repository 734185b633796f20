"""A simulated person in front of the Kinect, as openni_tracker reports it (no ROS).

The person performs a script of episodes: the two commands of thesis 4.4 (``come_close``:
beckoning, the forearm swung up and down toward the body; ``go_away``: shooing, the
forearm swept outward and back) and idle motion (``rest``: arms hanging, ``scratch``: the
right hand scratching the head, ``point``: the right arm pointing somewhere, ``wave``:
waving hello, ``walk_past``: someone else walks across the view). Every episode draws its
own variation (tempo, amplitude, centre, number of cycles) from the script's seed.

``SkeletonSource.frame(t)`` gives what openni_tracker would publish at ``t``: the user id
and the 15 joints (``JOINTS``) in ``openni_depth_frame`` [m] (x away from the sensor, y to
the sensor's left, z up; the person facing the sensor has their right hand on the
sensor's left, +y), with Gaussian joint noise, dropped frames (nothing published), a
joint missing now and then, optionally NaN positions, tracking lost at random and
whenever the person leaves the field of view; each time tracking starts again the user
id changes (openni_tracker's new user). Everything is a function of the seed and ``t``.

Body coordinates (``forward``, ``left``, ``up`` of the person) describe the arm: a
direction of yaw psi (about ``up``, 0 = forward, + = toward the person's left) and pitch
theta (+ = up) is ``(cos th cos psi, cos th sin psi, sin th)``; gesture recognition
measures the forearm's yaw and pitch the same way (telepresence.gestures).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import nested, param
from telepresence.gestures import JOINTS

GESTURES = ("come_close", "go_away")
IDLE_KINDS = ("rest", "scratch", "point", "wave", "walk_past")
KINDS = GESTURES + IDLE_KINDS

UPPER_ARM_M = 0.28  # shoulder -> elbow [m] (scaled by the person's height)
FOREARM_M = 0.27  # elbow -> hand [m]
FOV_HALF_RAD = math.radians(28.5)  # Kinect: 57 deg horizontal field of view
RANGE_M = (0.8, 4.0)  # the skeleton tracker's working range [m]
BLEND_S = 0.5  # arm raised from / lowered to rest [s]
# rest posture of a joint, body coordinates relative to the torso joint [m]
BODY = {"head": (0.0, 0.0, 0.55), "neck": (0.0, 0.0, 0.35), "torso": (0.0, 0.0, 0.0),
        "left_shoulder": (0.0, 0.18, 0.30), "right_shoulder": (0.0, -0.18, 0.30),
        "left_hip": (0.0, 0.10, -0.25), "right_hip": (0.0, -0.10, -0.25),
        "left_knee": (0.0, 0.10, -0.70), "right_knee": (0.0, -0.10, -0.70),
        "left_foot": (0.0, 0.10, -1.12), "right_foot": (0.0, -0.10, -1.12)}
TORSO_Z_M = 1.15  # height of the torso joint of a person of scale 1 [m]


def direction(psi: float, theta: float) -> np.ndarray:
    """Unit vector of yaw ``psi`` and pitch ``theta`` [rad] in body coordinates."""
    c = math.cos(theta)
    return np.array([c * math.cos(psi), c * math.sin(psi), math.sin(theta)])


def _smooth(s: float) -> float:
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


def _blend(a: np.ndarray, b: np.ndarray, s: float) -> np.ndarray:
    v = (1.0 - s) * a + s * b
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else b


class Episode(NamedTuple):
    kind: str
    t0: float  # start [s]
    t1: float  # end [s] (arm back at rest, or the passer-by gone)
    motion_end: float  # a gesture's end: its last cycle done [s] (= t1 for idle motion)
    p: Dict[str, float]  # the episode's drawn parameters


def _cycles_episode(kind, t0, rng, f_hz, cycles, extra):
    motion = cycles / f_hz
    p = dict(extra, f_hz=f_hz, cycles=float(cycles))
    return Episode(kind, t0, t0 + BLEND_S + motion + BLEND_S, t0 + BLEND_S + motion, p)


def make_episode(kind: str, t0: float, rng: np.random.Generator,
                 nominal: bool = False) -> Episode:
    """One episode of ``kind`` starting at ``t0`` with parameters drawn from ``rng``
    (``nominal``: the gestures' mean parameters, as a template is recorded)."""
    def u(lo, hi, mid=None):
        return (lo + hi) / 2.0 if nominal and mid is None else \
            (mid if nominal else float(rng.uniform(lo, hi)))
    d = math.radians
    if kind == "come_close":  # beckoning: forearm pitch swings up toward the body
        return _cycles_episode(kind, t0, rng, 1.1 * u(0.85, 1.18, 1.0),
                               2 if nominal else int(rng.integers(2, 4)),
                               {"centre": d(u(38, 52)), "amp": d(u(22, 34)),
                                "psi0": d(u(2, 18)), "upper_psi": d(u(-25, -5))})
    if kind == "go_away":  # shooing: forearm yaw swept outward and back, held low
        return _cycles_episode(kind, t0, rng, 1.3 * u(0.85, 1.18, 1.0),
                               2 if nominal else int(rng.integers(2, 4)),
                               {"centre": d(u(-43, -27)), "amp": d(u(22, 34)),
                                "theta0": d(u(5, 19)), "upper_psi": d(u(-25, -5))})
    if kind == "rest":
        dur = u(1.0, 3.0)
        return Episode(kind, t0, t0 + dur, t0 + dur, {})
    if kind == "scratch":
        hold = u(1.5, 3.0)
        p = {"f_hz": u(2.5, 4.0), "psi0": d(u(60, 85)), "theta0": d(u(62, 78))}
        return Episode(kind, t0, t0 + 2 * BLEND_S + hold, t0 + 2 * BLEND_S + hold, p)
    if kind == "point":
        hold = u(1.5, 3.0)
        p = {"psi0": d(u(-70, 30)), "theta0": d(u(-15, 25))}
        return Episode(kind, t0, t0 + 2 * BLEND_S + hold, t0 + 2 * BLEND_S + hold, p)
    if kind == "wave":
        f = u(1.5, 2.5)
        cycles = int(rng.integers(2, 5))
        p = {"f_hz": f, "lateral": u(0.3, 0.6), "forward": u(0.05, 0.35)}
        end = t0 + 2 * BLEND_S + cycles / f
        return Episode(kind, t0, end, end, p)
    if kind == "walk_past":
        dist = u(1.5, 3.0)
        speed = u(0.8, 1.4)
        half = dist * math.tan(FOV_HALF_RAD) + 0.6  # from out of view to out of view
        direction_sign = 1.0 if rng.random() < 0.5 else -1.0
        p = {"dist": dist, "speed": speed, "half": half, "sign": direction_sign}
        end = t0 + 2.0 * half / speed
        return Episode(kind, t0, end, end, p)
    raise ValueError("unknown episode kind %r (known: %s)" % (kind, ", ".join(KINDS)))


def make_script(seed: int, duration_s: float, kinds: Sequence[str] = KINDS,
                weights: Optional[Sequence[float]] = None,
                rest_between: bool = True) -> List[Episode]:
    """Episodes of random ``kinds`` (chosen with ``weights``) until ``duration_s``, each
    followed by a rest (``rest_between``)."""
    rng = np.random.default_rng(seed)
    w = np.ones(len(kinds)) if weights is None else np.asarray(weights, float)
    w = w / w.sum()
    out: List[Episode] = []
    t = 0.0
    while t < duration_s:
        e = make_episode(kinds[int(rng.choice(len(kinds), p=w))], t, rng)
        out.append(e)
        t = e.t1
        if rest_between and e.kind != "rest":
            e = make_episode("rest", t, rng)
            out.append(e)
            t = e.t1
    return out


def script_of(kinds: Sequence[str], seed: int, nominal: bool = False) -> List[Episode]:
    """Episodes of the given ``kinds`` in order (a fixed scenario: tests, recording)."""
    rng = np.random.default_rng(seed)
    out: List[Episode] = []
    t = 0.0
    for k in kinds:
        e = make_episode(k, t, rng, nominal)
        out.append(e)
        t = e.t1
    return out


class Posture(NamedTuple):
    torso: np.ndarray  # torso joint in openni_depth_frame [m]
    facing: float  # the direction the person faces, in openni_depth_frame [rad]
    upper: np.ndarray  # right upper arm direction (body coordinates)
    fore: np.ndarray  # right forearm direction (body coordinates)
    left_swing: float  # left arm's forward swing [rad]
    passer: bool  # the passer-by of walk_past (another user)


@dataclass
class PersonParams:
    """The standing person (drawn per script from its seed unless given)."""

    dist_m: float = 2.0  # torso distance from the sensor [m]
    lateral_m: float = 0.0  # [m], + to the sensor's left
    facing_offset: float = 0.0  # turned away from facing the sensor straight [rad]
    scale: float = 1.0  # body size

    @staticmethod
    def draw(rng: np.random.Generator) -> PersonParams:
        return PersonParams(float(rng.uniform(1.5, 2.6)), float(rng.uniform(-0.3, 0.3)),
                            math.radians(float(rng.uniform(-20, 20))),
                            float(rng.uniform(0.9, 1.1)))


REST_UPPER = direction(0.0, math.radians(-88))


class Person:
    """The posture of the scripted person as a function of time."""

    def __init__(self, script: Sequence[Episode], person: PersonParams,
                 rest_psi: float = 0.2):
        self.script = list(script)
        self.person = person
        self.starts = [e.t0 for e in self.script]
        self.rest_fore = direction(rest_psi, math.radians(-80))

    def episode_at(self, t: float) -> Optional[Episode]:
        i = int(np.searchsorted(self.starts, t, side="right")) - 1
        if i < 0 or t >= self.script[i].t1:
            return None
        return self.script[i]

    def posture(self, t: float) -> Posture:
        pp = self.person
        torso = np.array([pp.dist_m, pp.lateral_m, TORSO_Z_M * pp.scale])
        facing = math.pi + pp.facing_offset + 0.03 * math.sin(0.7 * t)  # slight sway
        e = self.episode_at(t)
        rest = Posture(torso, facing, REST_UPPER, self.rest_fore, 0.0, False)
        if e is None or e.kind == "rest":
            return rest
        tau = t - e.t0
        if e.kind == "walk_past":
            p = e.p
            y = p["sign"] * (-p["half"] + p["speed"] * tau)
            swing = 0.35 * math.sin(2.0 * math.pi * 0.9 * tau)
            fore = direction(0.0, math.radians(-75) + swing)
            upper = direction(0.0, math.radians(-90) + 0.5 * swing)
            return Posture(np.array([p["dist"], y, TORSO_Z_M]), p["sign"] * math.pi / 2,
                           upper, fore, -swing, True)
        upper, fore = self._arm(e, tau)
        motion_s = e.motion_end - e.t0 - BLEND_S
        if tau < BLEND_S:  # raise the arm
            s = _smooth(tau / BLEND_S)
            upper0, fore0 = self._arm(e, BLEND_S)
            return rest._replace(upper=_blend(REST_UPPER, upper0, s),
                                 fore=_blend(self.rest_fore, fore0, s))
        if tau > BLEND_S + motion_s:  # lower it
            s = _smooth((tau - BLEND_S - motion_s) / BLEND_S)
            upper1, fore1 = self._arm(e, BLEND_S + motion_s)
            return rest._replace(upper=_blend(upper1, REST_UPPER, s),
                                 fore=_blend(fore1, self.rest_fore, s))
        return rest._replace(upper=upper, fore=fore)

    @staticmethod
    def _arm(e: Episode, tau: float) -> Tuple[np.ndarray, np.ndarray]:
        """Right upper arm and forearm directions ``tau`` s into episode ``e``'s motion
        (the motion starts at BLEND_S)."""
        p, s = e.p, tau - BLEND_S
        if e.kind == "come_close":
            ph = 2.0 * math.pi * p["f_hz"] * s
            theta = p["centre"] - p["amp"] * math.cos(ph)
            psi = p["psi0"] + math.radians(5) * math.sin(ph)
            return direction(p["upper_psi"], math.radians(-60)), direction(psi, theta)
        if e.kind == "go_away":
            ph = 2.0 * math.pi * p["f_hz"] * s
            psi = p["centre"] + p["amp"] * math.cos(ph)
            theta = p["theta0"] + math.radians(4) * math.sin(ph)
            return direction(p["upper_psi"], math.radians(-50)), direction(psi, theta)
        if e.kind == "scratch":
            theta = p["theta0"] + math.radians(5) * math.sin(2 * math.pi * p["f_hz"] * s)
            return direction(math.radians(-80), math.radians(10)), direction(p["psi0"],
                                                                             theta)
        if e.kind == "point":
            return direction(p["psi0"], p["theta0"] - 0.1), direction(p["psi0"], p["theta0"])
        if e.kind == "wave":
            lat = p["lateral"] * math.sin(2 * math.pi * p["f_hz"] * s)
            v = np.array([p["forward"], lat, 1.0])
            return direction(math.radians(-70), math.radians(-5)), v / np.linalg.norm(v)
        raise ValueError(e.kind)


def joints_of(posture: Posture, scale: float = 1.0) -> Dict[str, np.ndarray]:
    """The 15 joints in openni_depth_frame [m] of ``posture``."""
    f = np.array([math.cos(posture.facing), math.sin(posture.facing), 0.0])
    left = np.array([-math.sin(posture.facing), math.cos(posture.facing), 0.0])
    rot = np.column_stack([f, left, [0.0, 0.0, 1.0]])  # body -> depth frame
    out = {}
    for name, v in BODY.items():
        out[name] = posture.torso + rot @ (scale * np.asarray(v))
    rs = out["right_shoulder"]
    out["right_elbow"] = rs + rot @ (scale * UPPER_ARM_M * posture.upper)
    out["right_hand"] = out["right_elbow"] + rot @ (scale * FOREARM_M * posture.fore)
    ls = out["left_shoulder"]
    hang = direction(0.0, -math.pi / 2 + posture.left_swing)
    out["left_elbow"] = ls + rot @ (scale * UPPER_ARM_M * hang)
    out["left_hand"] = out["left_elbow"] + rot @ (scale * FOREARM_M * hang)
    return out


@dataclass
class SensorParams:
    """What makes the simulated tracker imperfect."""

    noise_m: float = param(0.01, "joint position noise, standard deviation at 2 m [m] "
                           "(grows with the square of the distance)", ge=0.0)
    drop_prob: float = param(0.05, "probability that a frame is not published", ge=0.0,
                             le=1.0)
    missing_joint_prob: float = param(0.005, "probability that a frame lacks one joint",
                                      ge=0.0, le=1.0)
    nan_prob: float = param(0.0, "probability that a frame has a NaN joint position",
                            ge=0.0, le=1.0)
    lost_per_min: float = param(1.0, "tracking lost at random, mean events per minute "
                                "[1/min]", ge=0.0)


class Frame(NamedTuple):
    t: float  # [s]
    user: int  # openni_tracker's user id
    joints: Dict[str, np.ndarray]  # joint -> (x, y, z) in openni_depth_frame [m]


@dataclass
class SkeletonSource:
    """The simulated tracker: ``frame(t)`` is the Frame published at ``t``, or None
    (dropped, or nobody tracked). Call with increasing ``t``; a frame's randomness comes
    from ``seed`` and its time step, so the same seed gives the same frames."""

    script: List[Episode]
    sensor: SensorParams = field(default_factory=SensorParams)
    seed: int = 0
    person: Optional[PersonParams] = None
    user: int = 0  # the last user id given; the next one tracked gets user + 1
    _was_tracked: bool = False
    _passer: bool = False
    _lost: List[Tuple[float, float]] = field(default_factory=list)

    def __post_init__(self):
        rng = np.random.default_rng([self.seed, 1])
        if self.person is None:
            self.person = PersonParams.draw(rng)
        self.body = Person(self.script, self.person, float(rng.uniform(-0.4, 0.4)))
        end = self.script[-1].t1 if self.script else 0.0
        t = 0.0
        rate = self.sensor.lost_per_min / 60.0
        while rate > 0.0:  # random tracking losses: (start, end) [s]
            t += float(rng.exponential(1.0 / rate))
            if t > end:
                break
            self._lost.append((t, t + float(rng.uniform(0.3, 1.5))))

    @property
    def end_s(self) -> float:
        return self.script[-1].t1 if self.script else 0.0

    def gestures(self) -> List[Episode]:
        """The script's command gestures (the ground truth of a benchmark)."""
        return [e for e in self.script if e.kind in GESTURES]

    def tracked(self, t: float, posture: Posture) -> bool:
        x, y = float(posture.torso[0]), float(posture.torso[1])
        in_view = RANGE_M[0] < x < RANGE_M[1] and abs(math.atan2(y, x)) < FOV_HALF_RAD
        return in_view and not any(a <= t < b for a, b in self._lost)

    def frame(self, t: float) -> Optional[Frame]:
        posture = self.body.posture(t)
        tracked = self.tracked(t, posture)
        if tracked and (not self._was_tracked or posture.passer != self._passer):
            self.user += 1  # a new user: after a loss, or another person
        self._was_tracked = tracked
        self._passer = posture.passer
        if not tracked:
            return None
        rng = np.random.default_rng([self.seed, 2, int(round(t * 1000.0))])
        s = self.sensor
        if rng.random() < s.drop_prob:
            return None
        scale = 1.0 if posture.passer else self.person.scale
        joints = joints_of(posture, scale)
        sigma = s.noise_m * (float(posture.torso[0]) / 2.0) ** 2
        for name in JOINTS:
            joints[name] = joints[name] + rng.normal(0.0, sigma, 3)
        if rng.random() < s.missing_joint_prob:
            del joints[JOINTS[int(rng.integers(len(JOINTS)))]]
        if rng.random() < s.nan_prob:
            joints[JOINTS[int(rng.integers(len(JOINTS)))]] = np.full(3, np.nan)
        return Frame(t, self.user, joints)


@dataclass
class SkeletonSimParams:
    """The ``skeleton_sim`` node's parameters."""

    rate_hz: float = param(30.0, "frame rate of the simulated tracker [Hz] (openni_tracker: "
                           "30)", gt=0.0, le=200.0)
    seed: int = param(0, "seed of the script, the person and the sensor's imperfections")
    episodes: str = param("", "comma-separated episode kinds performed in order, e.g. "
                          "'rest,come_close,rest'; empty: a random mix of every kind")
    duration_s: float = param(600.0, "length of a random script before it repeats (with "
                              "the next seed) [s]", gt=0.0)
    loop: bool = param(True, "repeat the script (next seed) when it ends; false: the "
                       "person leaves (nothing published)")
    depth_frame: str = param("openni_depth_frame", "frame of the joint positions")
    parent_frame: str = param("base_link", "static mount parent of depth_frame; empty: "
                              "no mount published")
    mount_x_m: float = param(0.0, "depth_frame origin in parent_frame, x [m]")
    mount_z_m: float = param(0.75, "depth_frame origin in parent_frame, z (Kinect on its "
                             "stand) [m]")
    sensor: SensorParams = nested(SensorParams)

    def script(self, seed: int) -> List[Episode]:
        kinds = [k.strip() for k in self.episodes.split(",") if k.strip()]
        if kinds:
            return script_of(kinds, seed)
        return make_script(seed, self.duration_s)

    def validate(self) -> None:
        bad = [k.strip() for k in self.episodes.split(",") if k.strip() and
               k.strip() not in KINDS]
        if bad:
            raise ValueError("episodes: unknown kind(s) %s (known: %s)"
                             % (", ".join(bad), ", ".join(KINDS)))
