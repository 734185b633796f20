"""Parameters of the ``web_console`` node (no rospy)."""
from __future__ import annotations

from dataclasses import dataclass

from ascc_common.params import param


@dataclass
class WebConsoleParams:
    address: str = param("127.0.0.1", "address to bind (0.0.0.0: every interface)")
    port: int = param(8088, "HTTP/WebSocket port (0: any free port, see ~bound_port)",
                      ge=0, le=65535)
    token: str = param("", "shared token that allows driving and goals; empty: anyone "
                       "who reaches the page may drive")
    max_linear_mps: float = param(0.3, "[m/s] speed limit of the operator's commands",
                                  gt=0.0, le=0.5)
    max_angular_rps: float = param(1.0, "[rad/s] turn-rate limit", gt=0.0, le=4.0)
    lease_s: float = param(0.2, "[s] a drive command holds for this long", gt=0.0, le=1.0)
    check_rate_hz: float = param(50.0, "[Hz] lease check (zero command when it runs out)",
                                 gt=0.0)
    status_rate_hz: float = param(5.0, "[Hz] status (battery, mode, pose, path) to pages",
                                  gt=0.0)
    max_message_bytes: int = param(4096, "[bytes] longer page messages are refused", ge=64)
    max_clients: int = param(32, "connections over this are refused", ge=1)
    map_frame: str = param("map", "frame of the map, the pose and goals")
    base_frame: str = param("base_link", "the robot's frame")
    max_frame_age_s: float = param(0.5, "[s] the page marks video older than this stale",
                                   gt=0.0)

    def validate(self):
        if not self.address:
            raise ValueError("address must not be empty")
