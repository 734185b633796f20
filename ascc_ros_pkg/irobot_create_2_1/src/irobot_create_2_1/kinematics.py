"""Differential-drive command conversion for the Create: twist [m/s, rad/s] -> wheel
speeds [mm/s], with saturation that keeps the turn ratio (the path's curvature)."""
import math
from typing import NamedTuple

from . import protocol


class WheelCommand(NamedTuple):
    left_mm_s: int
    right_mm_s: int
    saturated: bool  # a wheel exceeded the limit and both were scaled down


def twist_to_wheels(linear_m_s: float, angular_rad_s: float, wheel_base_m: float,
                    max_wheel_speed_m_s: float = protocol.MAX_WHEEL_SPEED_MM_S / 1000.0
                    ) -> WheelCommand:
    """Wheel speeds for a body twist. Raises ValueError for NaN/inf input.

    When a wheel would exceed ``max_wheel_speed_m_s`` both wheels are scaled by the same
    factor, so the robot follows the commanded arc, only slower.
    """
    if not (math.isfinite(linear_m_s) and math.isfinite(angular_rad_s)):
        raise ValueError("non-finite twist (linear.x=%r, angular.z=%r)"
                         % (linear_m_s, angular_rad_s))
    if wheel_base_m <= 0:
        raise ValueError("wheel_base_m must be > 0, got %r" % wheel_base_m)
    half = 0.5 * wheel_base_m * angular_rad_s
    left, right = linear_m_s - half, linear_m_s + half
    peak = max(abs(left), abs(right))
    limit = min(max_wheel_speed_m_s, protocol.MAX_WHEEL_SPEED_MM_S / 1000.0)
    saturated = peak > limit
    if saturated:
        scale = limit / peak
        left, right = left * scale, right * scale
    return WheelCommand(int(round(left * 1000.0)), int(round(right * 1000.0)), saturated)


def wheels_to_twist(left_m_s: float, right_m_s: float, wheel_base_m: float):
    """Inverse of :func:`twist_to_wheels`: (linear m/s, angular rad/s)."""
    return 0.5 * (left_m_s + right_m_s), (right_m_s - left_m_s) / wheel_base_m
