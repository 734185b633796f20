"""Planar odometry from the Create's distance (packet 19, mm) and angle (packet 20, deg)
increments, integrated along circular arcs, with a covariance that grows with travel.

Conventions (REP 103): x forward, y left, yaw counter-clockwise positive; driving
backwards gives a negative distance and moves x backwards (Brown's driver got this wrong).
"""
import math
from typing import List, Tuple

from ascc_common.pose2d import wrap_angle


def integrate_arc(x: float, y: float, theta: float, distance_m: float,
                  dtheta_rad: float) -> Tuple[float, float, float]:
    """Pose after moving ``distance_m`` along an arc that turns by ``dtheta_rad``."""
    if abs(dtheta_rad) < 1e-9:
        return (x + distance_m * math.cos(theta), y + distance_m * math.sin(theta), theta)
    radius = distance_m / dtheta_rad
    theta2 = theta + dtheta_rad
    return (x + radius * (math.sin(theta2) - math.sin(theta)),
            y - radius * (math.cos(theta2) - math.cos(theta)),
            theta2)


class Odometry:
    """Integrates increments; keeps a diagonal covariance (x, y, yaw) that grows with the
    distance travelled and the angle turned (variances per metre / per radian)."""

    def __init__(self, var_xy_per_m: float = 1e-4, var_yaw_per_rad: float = 3e-4,
                 var_yaw_per_m: float = 1e-4):
        self.var_xy_per_m = var_xy_per_m
        self.var_yaw_per_rad = var_yaw_per_rad
        self.var_yaw_per_m = var_yaw_per_m
        self.reset()

    def reset(self) -> None:
        self.x = self.y = self.theta = 0.0
        self.travel_m = 0.0
        self.turn_rad = 0.0
        self.var_x = self.var_y = self.var_yaw = 0.0

    def update(self, distance_m: float, dtheta_rad: float) -> None:
        if not (math.isfinite(distance_m) and math.isfinite(dtheta_rad)):
            raise ValueError("non-finite odometry increment")
        x, y, theta = integrate_arc(self.x, self.y, self.theta, distance_m, dtheta_rad)
        self.x, self.y, self.theta = x, y, wrap_angle(theta)
        d, a = abs(distance_m), abs(dtheta_rad)
        self.travel_m += d
        self.turn_rad += a
        # Heading uncertainty turns into lateral uncertainty as the robot moves.
        lateral = self.var_yaw * d * d
        self.var_x += self.var_xy_per_m * d + lateral
        self.var_y += self.var_xy_per_m * d + lateral
        self.var_yaw += self.var_yaw_per_rad * a + self.var_yaw_per_m * d

    @property
    def pose(self) -> Tuple[float, float, float]:
        return self.x, self.y, self.theta

    def pose_covariance(self) -> List[float]:
        """Row-major 6x6 covariance (x, y, z, roll, pitch, yaw) as in nav_msgs/Odometry;
        z/roll/pitch are not observed by a planar robot and get a large variance."""
        cov = [0.0] * 36
        cov[0], cov[7], cov[35] = self.var_x, self.var_y, self.var_yaw
        cov[14] = cov[21] = cov[28] = 1e6
        return cov


def twist_covariance(var_v: float = 1e-3, var_w: float = 3e-3) -> List[float]:
    cov = [0.0] * 36
    cov[0], cov[35] = var_v, var_w
    cov[7] = 1e-6  # a differential drive cannot move sideways
    cov[14] = cov[21] = cov[28] = 1e6
    return cov
