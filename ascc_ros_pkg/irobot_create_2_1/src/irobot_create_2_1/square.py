"""The drive_square node's parameters (no ROS; the node is ros/drive_square_node.py)."""
from dataclasses import dataclass

from ascc_common.params import param


@dataclass
class DriveSquareParams:
    """Everything the drive_square node reads (private parameters)."""

    side_m: float = param(1.0, "[m] side of the square", gt=0.0)
    speed_m_s: float = param(0.2, "[m/s] forward speed on the sides", gt=0.0)
    turn_rate_rad_s: float = param(0.5, "[rad/s] turn rate at the corners", gt=0.0)
    compare_topic: str = param("", "nav_msgs/Odometry topic to log the odometry error "
                                   "against (\"\": none)")
