"""Emulated wearable motion sensors (thesis 5.4): what a VN-100 on the waist and one on
the thigh measure while a person performs an activity. Pure numpy, vectorised over time.

Model. Each sensor sits on a body segment; its frame has x along the segment (towards the
head on the waist, knee -> hip on the thigh), y to the person's right, z out of the body's
front. The segment's orientation in the world (ENU) is a forward lean ``beta`` [rad] about
the person's left axis (0 upright, +pi/2 the segment pointing forward, -pi/2 backward),
a roll ``gamma`` about the person's forward axis and the heading ``psi``; a mounting tilt
per person and sensor is added. The accelerometer measures the specific force
f = R^T (a_world + [0, 0, g]) (a_world: the motion's acceleration, fore-aft and
sideways turned with the person's heading), the gyro the body rate (from R(t - h)^T R(t)), the
orientation is R as a quaternion. Postures (waist, thigh lean in degrees before the
person's offsets): standing (0, 0), sitting (-8, -90: the thigh horizontal, hip behind
the knee), typing (+15, -90, a fine tremor), eating (+20, -90, hand-to-mouth bends every
~4 s), lying (-90, -90, on the back), walking (gait: thigh swing +-25 deg at the stride
frequency, vertical bounce at twice it), opening a door (standing, a pull with a turn of
the trunk and a step back every ~5 s); the transitions of fig. 5.15: sit-to-stand and
stand-to-sit (the trunk leans forward while the thigh swings, ~1.5 s). Activities the
recognizer must not know (scratching, bending, carrying) exist for its tests. While
sitting or lying a person fidgets now and then (a shift of 1-2 s; what wakes a sleeping
sensor node, 5.4.1).

A `Person` (from a seed) varies all of it: posture offsets, gait frequency and amplitude,
tremor, noise, mounting tilts, fidget rate. Every random draw of a signal comes from the
person's seed and the sample's time, so a signal is the same whether rendered at once
(`render`) or sample by sample (the emulator node).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Sequence, Tuple

import numpy as np

G = 9.80665  # [m/s^2]
RATE_HZ = 20.0  # the VN-100 nodes' sample rate (5.4.2)
POSITIONS = ("waist", "thigh")
SEATED = ("sitting", "typing", "eating")
UPRIGHT = ("standing", "walking", "opening_door", "scratching", "carrying", "bending")
ACTIVITIES = ("lying", "typing", "eating", "sitting", "opening_door",   # 5.5
              "sit_to_stand", "stand_to_sit", "standing", "walking")   # fig. 5.15
UNKNOWN_ACTIVITIES = ("scratching", "bending", "carrying")
TRANSITION_S = 1.5  # [s] sit-to-stand / stand-to-sit (scaled per person)
FIDGET_BLOCK_S = 30.0  # [s] one fidget at a random time in each block, with a person's odds

# static lean [deg] of (waist, thigh) per posture
LEAN_DEG = {"standing": (0.0, 0.0), "walking": (0.0, 0.0), "opening_door": (0.0, 0.0),
         "scratching": (0.0, 0.0), "carrying": (-8.0, 0.0), "bending": (70.0, 5.0),
         "sitting": (-8.0, -90.0), "typing": (15.0, -90.0), "eating": (20.0, -90.0),
         "lying": (-90.0, -90.0)}


@dataclass(frozen=True)
class Person:
    """One person's way of moving (all drawn from ``seed``)."""

    seed: int
    lean_offset_deg: Tuple[float, float]     # waist, thigh
    stride_hz: float                         # gait: one stride = two steps
    bounce_mps2: float                       # vertical acceleration amplitude walking
    swing_deg: float                         # thigh swing amplitude walking
    tremor_mps2: float                       # typing: fine vibration amplitude
    noise_mps2: float                        # accelerometer white noise (sigma)
    gyro_noise_rps: float
    mount_deg: Tuple[Tuple[float, float, float], Tuple[float, float, float]]  # per position
    fidget_odds: float                       # chance of a fidget per FIDGET_BLOCK_S
    transition_s: float

    @classmethod
    def from_seed(cls, seed: int) -> Person:
        r = np.random.default_rng([seed, 7919])
        return cls(seed, (float(r.normal(0, 4)), float(r.normal(0, 4))),
                   float(r.uniform(0.8, 1.0)), float(r.uniform(1.6, 2.6)),
                   float(r.uniform(20, 30)), float(r.uniform(0.15, 0.3)),
                   float(r.uniform(0.03, 0.08)), float(r.uniform(0.01, 0.02)),
                   tuple(tuple(float(v) for v in r.normal(0, 4, 3)) for _ in POSITIONS),
                   float(r.uniform(0.4, 0.8)), float(TRANSITION_S * r.uniform(0.8, 1.25)))


def _unit_noise(seed: int, key: int, t: np.ndarray, n: int) -> np.ndarray:
    """Standard normal noise per (seed, key, sample time at RATE_HZ): (len(t), n), the
    same for a sample however it is rendered (a hash of the sample index, Box-Muller)."""
    k = np.round(np.asarray(t, dtype=float) * RATE_HZ).astype(np.int64)
    idx = (k[:, None] * n + np.arange(n)[None, :]).astype(np.uint64)
    with np.errstate(over="ignore"):
        h = idx * np.uint64(0x9E3779B97F4A7C15) + np.uint64((seed * 1000003 + key)
                                                             & 0xFFFFFFFF)
        h ^= h >> np.uint64(31)
        h *= np.uint64(0xBF58476D1CE4E5B9)
        h ^= h >> np.uint64(29)
        h2 = h * np.uint64(0x94D049BB133111EB)
        h2 ^= h2 >> np.uint64(32)
    u1 = ((h >> np.uint64(11)).astype(np.float64) + 0.5) / float(1 << 53)
    u2 = ((h2 >> np.uint64(11)).astype(np.float64) + 0.5) / float(1 << 53)
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)


def _fidget(person: Person, t: np.ndarray) -> np.ndarray:
    """0..1 envelope of the person's fidgets (one at a random time in some blocks)."""
    block = np.floor(t / FIDGET_BLOCK_S).astype(np.int64)
    out = np.zeros_like(t)
    for b in np.unique(block):  # a handful of blocks per call: not a per-sample loop
        r = np.random.default_rng([person.seed, 104729, int(b) & 0x7FFFFFFF])
        happens, start, length = r.random() < person.fidget_odds, r.uniform(0, 27), \
            r.uniform(1.0, 2.0)
        if happens:
            s = (t - b * FIDGET_BLOCK_S - start) / length
            m = (block == b) & (s > 0) & (s < 1)
            out[m] = np.sin(np.pi * s[m]) ** 2
    return out


def _angles(activity: str, pos: int, person: Person, t: np.ndarray):
    """(beta, gamma, psi) [rad] and the world acceleration (n, 3) of one activity."""
    n = t.size
    lean = LEAN_DEG[activity][pos] + person.lean_offset_deg[pos]
    beta = np.full(n, math.radians(lean))
    gamma = np.zeros(n)
    psi = np.zeros(n)
    acc = np.zeros((n, 3))
    w = 2.0 * np.pi * person.stride_hz
    if activity in ("walking", "carrying"):
        scale = 0.6 if activity == "carrying" else 1.0
        if pos == 1:
            beta += math.radians(person.swing_deg * scale) * np.sin(w * t)
        else:
            beta += math.radians(3.0) * np.sin(2 * w * t)
            gamma += math.radians(2.5) * np.sin(w * t)
        acc[:, 2] = person.bounce_mps2 * scale * np.sin(2 * w * t + 0.3 * pos)
        acc[:, 0] = 0.5 * person.bounce_mps2 * scale * np.sin(2 * w * t + 1.2)
    elif activity == "opening_door":
        ph = 2.0 * np.pi * t / 5.0
        pull = np.clip(np.sin(ph), 0.0, None) ** 2
        psi += math.radians(20.0) * pull * (pos == 0)
        beta += math.radians(-6.0 if pos == 0 else 8.0) * pull
        acc[:, 0] = -1.2 * np.cos(ph) * np.clip(np.sin(ph), 0.0, None)
    elif activity == "typing" and pos == 0:
        acc[:, 0] = person.tremor_mps2 * np.sin(2 * np.pi * 4.5 * t)
        acc[:, 1] = 0.5 * person.tremor_mps2 * np.sin(2 * np.pi * 6.1 * t + 1.0)
    elif activity == "eating":
        bend = np.clip(np.sin(2 * np.pi * t / 4.0), 0.0, None) ** 2
        beta += math.radians(12.0 if pos == 0 else 0.0) * bend
    elif activity == "scratching" and pos == 0:
        acc[:, 1] = 0.8 * np.sin(2 * np.pi * 3.0 * t)
    if activity in ("sitting", "lying", "typing", "eating"):
        f = _fidget(person, t)
        beta += math.radians(10.0 if pos == 0 else 4.0) * f * np.sin(2 * np.pi * 0.8 * t)
        acc[:, 1] += 0.8 * f * np.sin(2 * np.pi * 1.3 * t)
    return beta, gamma, psi, acc


def _rotation(beta, gamma, psi, mount_deg) -> np.ndarray:
    """(n, 3, 3) rotation sensor -> world: Rz(psi) Ry(beta) Rx(gamma) R0 Rmount."""
    def rx(a):
        c, s = np.cos(a), np.sin(a)
        o, z = np.ones_like(a), np.zeros_like(a)
        return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1),
                         np.stack([z, s, c], -1)], -2)

    def ry(a):
        c, s = np.cos(a), np.sin(a)
        o, z = np.ones_like(a), np.zeros_like(a)
        return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1),
                         np.stack([-s, z, c], -1)], -2)

    def rz(a):
        c, s = np.cos(a), np.sin(a)
        o, z = np.ones_like(a), np.zeros_like(a)
        return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                         np.stack([z, z, o], -1)], -2)

    # R0: sensor x -> up, y -> right (-y world), z -> forward (+x world), heading psi = 0
    r0 = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
    m = np.radians(mount_deg)
    mount = rx(np.array(m[0])) @ ry(np.array(m[1])) @ rz(np.array(m[2]))
    return rz(psi) @ ry(beta) @ rx(gamma) @ r0 @ mount


def _quaternions(r: np.ndarray) -> np.ndarray:
    """(n, 4) x, y, z, w of rotation matrices (n, 3, 3), w >= 0."""
    tr = np.trace(r, axis1=1, axis2=2)
    q = np.empty((r.shape[0], 4))
    w = np.sqrt(np.clip(1.0 + tr, 0.0, None)) / 2.0
    x = np.sqrt(np.clip(1.0 + r[:, 0, 0] - r[:, 1, 1] - r[:, 2, 2], 0.0, None)) / 2.0
    y = np.sqrt(np.clip(1.0 - r[:, 0, 0] + r[:, 1, 1] - r[:, 2, 2], 0.0, None)) / 2.0
    z = np.sqrt(np.clip(1.0 - r[:, 0, 0] - r[:, 1, 1] + r[:, 2, 2], 0.0, None)) / 2.0
    q[:, 0] = np.copysign(x, r[:, 2, 1] - r[:, 1, 2])
    q[:, 1] = np.copysign(y, r[:, 0, 2] - r[:, 2, 0])
    q[:, 2] = np.copysign(z, r[:, 1, 0] - r[:, 0, 1])
    q[:, 3] = w
    return q / np.linalg.norm(q, axis=1, keepdims=True)


@dataclass(frozen=True)
class Segment:
    """An activity over [start, end) [s]."""

    activity: str
    start: float
    end: float


def _state(activity: str, pos: int, person: Person, t: np.ndarray, segment_start: float):
    """Angles and acceleration; a transition blends its two postures."""
    transition = activity in ("sit_to_stand", "stand_to_sit")
    beta, gamma, psi, acc = _angles("standing" if transition else activity, pos, person, t)
    if transition:
        a, b = ("sitting", "standing") if activity == "sit_to_stand" else ("standing",
                                                                            "sitting")
        s = np.clip((t - segment_start) / person.transition_s, 0.0, 1.0)
        s = s * s * (3 - 2 * s)
        b0, _, _, _ = _angles(a, pos, person, t)
        b1, _, _, _ = _angles(b, pos, person, t)
        beta = (1 - s) * b0 + s * b1 + (math.radians(35.0) if pos == 0 else 0.0) * np.sin(
            np.pi * s)
        acc = acc.copy()
        acc[:, 2] = (1.5 if activity == "sit_to_stand" else -1.5) * np.sin(2 * np.pi * s) \
            * (s > 0) * (s < 1)
    return beta, gamma, psi, acc


def sensor_signals(activity: str, position: str, person: Person, t: Sequence[float],
                   segment_start: float = 0.0, heading_rad: float = 0.0
                   ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(accel (n, 3) [m/s^2], gyro (n, 3) [rad/s], quat (n, 4) x y z w) of the sensor at
    ``position`` at the times ``t`` [s] (noise included)."""
    if activity not in LEAN_DEG and activity not in ("sit_to_stand", "stand_to_sit"):
        raise ValueError("unknown activity %r" % (activity,))
    pos = POSITIONS.index(position)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    h = 1e-3
    mount = person.mount_deg[pos]
    beta, gamma, psi, acc = _state(activity, pos, person, t, segment_start)
    b2, g2, p2, _ = _state(activity, pos, person, t - h, segment_start)
    r = _rotation(beta, gamma, psi + heading_rad, mount)
    r_prev = _rotation(b2, g2, p2 + heading_rad, mount)
    d = np.einsum("nji,njk->nik", r_prev, r)  # R(t-h)^T R(t)
    gyro = np.stack([d[:, 2, 1] - d[:, 1, 2], d[:, 0, 2] - d[:, 2, 0],
                     d[:, 1, 0] - d[:, 0, 1]], axis=1) / (2.0 * h)
    # the motion's acceleration is the body's (x forward, y left): the gait's fore-aft
    # bounce points where the person walks, not along the world's x
    ch, sh = math.cos(heading_rad), math.sin(heading_rad)
    acc = np.stack([ch * acc[:, 0] - sh * acc[:, 1], sh * acc[:, 0] + ch * acc[:, 1],
                    acc[:, 2]], axis=1)
    f_world = acc + np.array([0.0, 0.0, G])
    accel = np.einsum("nji,nj->ni", r, f_world)  # R^T f
    accel += person.noise_mps2 * _unit_noise(person.seed, 10 + pos, t, 3)
    gyro += person.gyro_noise_rps * _unit_noise(person.seed, 20 + pos, t, 3)
    return accel, gyro, _quaternions(r)


def segments_with_transitions(script: Sequence[Tuple[str, float]],
                              person: Person) -> List[Segment]:
    """A script of (activity, duration [s]) as segments, with sit-to-stand or stand-to-sit
    inserted where the posture changes between seated and upright."""
    out: List[Segment] = []
    t, prev = 0.0, None
    for activity, duration in script:
        if prev is not None:
            kind = ("sit_to_stand" if prev in SEATED and activity in UPRIGHT else
                    "stand_to_sit" if prev in UPRIGHT and activity in SEATED else None)
            if kind:
                out.append(Segment(kind, t, t + person.transition_s))
                t += person.transition_s
        out.append(Segment(activity, t, t + duration))
        t += duration
        prev = activity
    return out


def render_at(segments: Sequence[Segment], person: Person, t: np.ndarray
              ) -> Dict[str, np.ndarray]:
    """The segments (``segments_with_transitions``) rendered at the times ``t`` [s] (any
    times, e.g. late timer ticks): ``t``, ``label`` (n,) activity names (None outside the
    segments), and per position ``<position>_accel``, ``_gyro``, ``_quat``."""
    t = np.asarray(t, dtype=float)
    out: Dict[str, np.ndarray] = {"t": t, "label": np.empty(t.size, dtype=object)}
    for position in POSITIONS:
        for k in ("accel", "gyro"):
            out["%s_%s" % (position, k)] = np.zeros((t.size, 3))
        out["%s_quat" % position] = np.zeros((t.size, 4))
    for seg in segments:
        m = (t >= seg.start) & (t < seg.end)
        out["label"][m] = seg.activity
        for position in POSITIONS:
            a, g, q = sensor_signals(seg.activity, position, person, t[m], seg.start)
            out["%s_accel" % position][m] = a
            out["%s_gyro" % position][m] = g
            out["%s_quat" % position][m] = q
    return out


def render(script: Sequence[Tuple[str, float]], person: Person,
           rate_hz: float = RATE_HZ) -> Dict[str, np.ndarray]:
    """A whole script rendered at ``rate_hz``: ``t`` (n,), ``label`` (n,) activity names,
    and per position ``<position>_accel``, ``_gyro``, ``_quat``."""
    segments = segments_with_transitions(script, person)
    end = segments[-1].end if segments else 0.0
    return render_at(segments, person, np.arange(0.0, end, 1.0 / rate_hz))
