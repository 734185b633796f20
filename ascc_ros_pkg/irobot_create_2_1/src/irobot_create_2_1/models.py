"""The robot models the driver and the virtual Create speak: the first-generation iRobot
Create (2006 Create OI) and the iRobot Create 2 (Roomba 600 based, Create 2 OI, 2015).

Numbers (sources in the package README, "Robot models"):

=========================  ==============================  ================================
                           Create 1 (Create OI)            Create 2 (Create 2 OI)
=========================  ==============================  ================================
default baud               57600 (Baud, code 10)           115200 (Baud, code 11)
packets / groups           7..42 / 0..6                    7..58 / 0..6, 100, 101, 106, 107
streamed by the driver     group 6 (52 data bytes)         group 100 (80 data bytes)
odometry from              distance 19 [mm], angle 20      encoder counts 43/44 (signed
                           [deg]                           16 bit, rolling over)
wheel diameter             (not in the OI)                 72 mm
counts per wheel turn      (no encoders in the OI)         508.8
wheel base                 258 mm                          235 mm
=========================  ==============================  ================================

Pure Python, no ROS.
"""
import math
from dataclasses import dataclass
from typing import Dict, FrozenSet, Optional, Tuple

from . import protocol

ENCODER_MODULUS = 1 << 16   # packets 43/44 are 16 bit and roll over


@dataclass(frozen=True)
class RobotModel:
    """What differs between the Create models, for the driver and the emulator."""

    name: str
    baud: int                          # [baud] the OI's default rate
    packet_ids: FrozenSet[int]         # packet and group ids the robot answers
    stream_packets: Tuple[int, ...]    # what the driver asks to stream
    wheel_base_m: float                # [m] distance between the wheels
    wheel_diameter_m: Optional[float]  # [m] None: not given by the OI (no encoders)
    counts_per_rev: Optional[float]    # encoder counts per wheel revolution
    encoder_odometry: bool             # odometry from 43/44 (else from 19/20)

    @property
    def metres_per_count(self) -> float:
        if self.wheel_diameter_m is None or not self.counts_per_rev:
            raise ValueError("%s has no wheel encoders in its OI" % self.name)
        return math.pi * self.wheel_diameter_m / self.counts_per_rev

    @property
    def stream_body_bytes(self) -> int:
        """N-bytes of this model's stream frames for ``stream_packets``."""
        return sum(1 + protocol.packet_size(pid) for pid in self.stream_packets)


CREATE_1 = RobotModel(
    name="create_1", baud=57600, packet_ids=protocol.CREATE_1_IDS, stream_packets=(6,),
    wheel_base_m=0.258, wheel_diameter_m=None, counts_per_rev=None, encoder_odometry=False)
CREATE_2 = RobotModel(
    name="create_2", baud=115200, packet_ids=protocol.CREATE_2_IDS, stream_packets=(100,),
    wheel_base_m=0.235, wheel_diameter_m=0.072, counts_per_rev=508.8,
    encoder_odometry=True)

MODELS: Dict[str, RobotModel] = {m.name: m for m in (CREATE_1, CREATE_2)}


def model(name: str) -> RobotModel:
    """The model called ``name`` (ValueError naming the known ones otherwise)."""
    try:
        return MODELS[name]
    except KeyError:
        raise ValueError("unknown robot model %r (known: %s)"
                         % (name, ", ".join(sorted(MODELS)))) from None


def encoder_delta(previous: int, current: int) -> int:
    """Counts between two readings of a 16-bit encoder packet, across the rollover: the
    shorter way round (a wheel cannot turn 32768 counts, ~145 m, in one 15 ms frame)."""
    d = (int(current) - int(previous)) % ENCODER_MODULUS
    return d - ENCODER_MODULUS if d >= ENCODER_MODULUS // 2 else d


class EncoderOdometry:
    """Wheel travel from encoder counts: ``update(left, right)`` returns (distance [m],
    heading change [rad]) since the previous reading; the first reading only sets the
    reference (returns zeros)."""

    def __init__(self, robot: RobotModel, wheel_base_m: Optional[float] = None):
        self.metres_per_count = robot.metres_per_count
        self.wheel_base_m = wheel_base_m or robot.wheel_base_m
        self.previous: Optional[Tuple[int, int]] = None

    def reset(self) -> None:
        self.previous = None

    def update(self, left_counts: int, right_counts: int) -> Tuple[float, float]:
        previous, self.previous = self.previous, (int(left_counts), int(right_counts))
        if previous is None:
            return 0.0, 0.0
        dl = encoder_delta(previous[0], left_counts) * self.metres_per_count
        dr = encoder_delta(previous[1], right_counts) * self.metres_per_count
        return 0.5 * (dl + dr), (dr - dl) / self.wheel_base_m
