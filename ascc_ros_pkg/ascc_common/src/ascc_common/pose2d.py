"""Planar poses (x [m], y [m], theta [rad]), scalar or vectorised over leading axes, and
their quaternions: the one pose vocabulary of the stack.

A pose ``a`` maps points from its child frame into its parent frame:
``p_parent = R(a.theta) p_child + (a.x, a.y)``. ``compose(a, b)`` is "a then b" (a * b),
``inverse(a)`` is a^-1, ``relative(a, b)`` = a^-1 * b (b seen from a), as in tf.
Quaternions are (x, y, z, w) as in geometry_msgs; ``yaw_of`` reads any object with those
attributes (a geometry_msgs/Quaternion) without importing ROS messages.
"""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(theta):
    """Wrap angles [rad] to [-pi, pi); a float for a scalar, an array for an array."""
    if isinstance(theta, (float, int)):
        # a Python scalar without numpy's round trip (same formula and result): the
        # driver's odometry calls this once per 15 ms stream frame
        return (float(theta) + math.pi) % (2.0 * math.pi) - math.pi
    wrapped = (np.asarray(theta, dtype=float) + math.pi) % (2.0 * math.pi) - math.pi
    return float(wrapped) if wrapped.ndim == 0 else wrapped


def mean_yaw(yaws, weights=None) -> float:
    """Circular mean [rad] of angles (weighted if ``weights`` is given): the direction of
    the mean of their unit vectors, so that angles either side of +-pi average to pi."""
    yaws = np.asarray(yaws, dtype=float)
    if weights is None:
        return math.atan2(float(np.mean(np.sin(yaws))), float(np.mean(np.cos(yaws))))
    w = np.asarray(weights, dtype=float)
    return math.atan2(float(w @ np.sin(yaws)), float(w @ np.cos(yaws)))


def compose(a, b) -> np.ndarray:
    """a * b for poses (..., 3); broadcasts."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = np.cos(a[..., 2])
    s = np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a) -> np.ndarray:
    """a^-1 for poses (..., 3)."""
    a = np.asarray(a, dtype=float)
    c = np.cos(a[..., 2])
    s = np.sin(a[..., 2])
    x = -(c * a[..., 0] + s * a[..., 1])
    y = s * a[..., 0] - c * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def relative(a, b) -> np.ndarray:
    """a^-1 * b: pose b expressed in the frame of pose a."""
    return compose(inverse(a), b)


def transform_points(pose, pts) -> np.ndarray:
    """Points (M, 2) in the pose's child frame -> parent frame, for one pose (3,)."""
    pose = np.asarray(pose, dtype=float)
    pts = np.asarray(pts, dtype=float)
    c = math.cos(pose[2])
    s = math.sin(pose[2])
    out = np.empty_like(pts)
    out[:, 0] = pose[0] + c * pts[:, 0] - s * pts[:, 1]
    out[:, 1] = pose[1] + s * pts[:, 0] + c * pts[:, 1]
    return out


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw [rad] of a quaternion (rotation about z; roll/pitch ignored)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaw_of(q) -> float:
    """Yaw [rad] of a quaternion object with x, y, z, w attributes (geometry_msgs)."""
    return yaw_from_quaternion(q.x, q.y, q.z, q.w)


def quaternion_from_yaw(yaw: float):
    """(x, y, z, w) of a rotation by ``yaw`` [rad] about z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def z_axis_from_quaternion(x: float, y: float, z: float, w: float):
    """The child frame's z axis expressed in the parent frame (unit vector)."""
    return (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))
