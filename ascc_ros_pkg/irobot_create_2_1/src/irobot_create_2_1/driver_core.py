"""The driver's logic without ROS: start-up sequence, stream decoding, odometry, motion
commands with a watchdog, saturation and bump safety. The node feeds it bytes and times
(ROS time, so simulated time works) and writes the bytes it returns to the port."""
import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

from ascc_common.params import param

from . import kinematics, protocol
from .model_check import MISMATCH, ModelCheck
from .models import CREATE_1, EncoderOdometry, RobotModel
from .odometry import Odometry
from .sensor_state import EVENT_PACKETS, hazards, increments_si

#: Packets the Create 1 driver streams: group 6 = every packet 7..42 (52 data bytes per
#: frame); the Create 2's are ``models.CREATE_2.stream_packets`` (group 100, 7..58).
STREAM_PACKETS = CREATE_1.stream_packets


class StreamClock:
    """When each stream frame was measured, from the Create's 15 ms cadence.

    The host reads the serial line when it gets around to it: on a loaded robot PC (or a
    simulator running faster than real time) many frames can wait in the buffer and arrive
    in one read. Stamped all with the read time, the odometry pose would stand still and
    then jump, and TF would interpolate a straight line across the gap. The newest frame of
    a read is taken as measured at the read time, the older ones one ``period_s`` apart
    before it:

        stamp_i = max(received - (n-1-i) * period_s, previous stamp, 0)

    so a single frame per read keeps its read time (no bias when the host keeps up) and
    stamps never decrease. They are never negative either: a backlog read just after a
    simulated clock started (or before it, at time 0) would otherwise date frames before
    time 0, which ROS time cannot hold. Time going back by more than ``reset_s`` (a
    restarted simulator or bag) starts afresh. (A min-latency filter along the cadence was
    tried: in the simulator the host's /clock jitters and it stamped the odometry 0.1 s
    early.)
    """

    def __init__(self, period_s: float = protocol.STREAM_PERIOD_S, reset_s: float = 0.25):
        if not (period_s > 0 and reset_s > 0):
            raise ValueError("period_s and reset_s must be > 0")
        self.period_s = period_s
        self.reset_s = reset_s
        self.last: Optional[float] = None  # stamp of the newest frame
        self.resets = 0

    def reset(self) -> None:
        self.last = None

    def stamps(self, n: int, received: float) -> List[float]:
        """Stamps of n frames that arrived together at ``received`` (oldest first)."""
        if n <= 0:
            return []
        out = [max(received - (n - 1 - i) * self.period_s, 0.0) for i in range(n)]
        last = self.last
        if last is not None and received < last - self.reset_s:
            self.resets += 1
        elif last is not None:
            out = [max(t, last) for t in out]
        self.last = out[-1]
        return out


@dataclass
class DriverParams:
    """Everything the driver node reads (private parameters)."""

    port: str = param("/dev/ttyUSB0", "serial device (or a virtual Create's pty)")
    robot_model: str = param("create_1", "create_1 or create_2: protocol, baud, packets, "
                             "geometry", choices=("create_1", "create_2"))
    baud: int = param(0, "[baud] OI baud rate; 0: the model's (57600 / 115200)", ge=0)
    mode: str = param("safe", "safe or full (full disables the cliff/wheel-drop stop)",
                      choices=("safe", "full"))
    cmd_timeout_s: float = param(0.5, "[s] no command for this long -> wheels stopped",
                                 gt=0.0)
    cmd_rate_hz: float = param(20.0, "[Hz] wheel commands are (re)sent at this rate")
    publish_rate_hz: float = param(30.0, "[Hz] cap on odom/TF")
    sensor_rate_hz: float = param(10.0, "[Hz] cap on sensorPacket/hazards/light_bumper; a "
                                  "change of a bumper, wheel-drop, cliff, virtual-wall, "
                                  "button, charger or light-bumper bit goes out at once",
                                  gt=0.0)
    sensor_timeout_s: float = param(1.0, "[s] no stream frame for this long -> restart it")
    frames_per_read: int = param(3, "stream frames (15 ms each) the reader waits for before "
                                 "it parses, runs the watchdog and publishes; 1: every frame",
                                 ge=1, le=16)
    wheel_base_m: float = param(0.0, "[m] wheel separation; 0: the model's (0.258 / 0.235)",
                                ge=0.0)
    odom_linear_scale_correction: float = param(
        1.0, "[-] factor on the distance the robot reports (its wheels' calibration: true "
        "distance / odometry's over a measured straight run; the TurtleBot driver's name)",
        gt=0.5, le=1.5)
    max_wheel_speed_m_s: float = param(0.5, "[m/s] per-wheel limit")
    stop_on_bump: bool = param(True, "a pressed bumper removes forward motion")
    light_bump_speed_m_s: float = param(0.0, "[m/s] create_2: forward speed cap while a "
                                        "light bumper sees something; 0: off", ge=0.0)
    stuck_after_s: float = param(1.0, "[s] create_2: wheels driving forward this long with "
                                 "the stasis sensor still -> stuck warning", gt=0.0)
    publish_tf: bool = param(True, "broadcast odom_frame -> base_frame")
    odom_frame: str = param("odom", "odometry frame")
    base_frame: str = param("base_link", "robot frame")


class CreateDriverCore:
    """``robot``: the model (:mod:`.models`); ``wheel_base_m`` None or 0 takes its wheel
    base, ``baud`` None its baud rate (the start-up model check names it).
    ``light_bump_speed_m_s`` > 0 caps forward speed while a light bumper (Create 2) sees
    something; ``stuck_after_s``: see :meth:`update_stuck`."""

    def __init__(self, wheel_base_m: Optional[float] = None, mode: str = "safe",
                 cmd_timeout_s: float = 0.5, stop_on_bump: bool = True,
                 max_wheel_speed_m_s: float = 0.5, resend_period_s: float = 0.5,
                 odometry: Optional[Odometry] = None, robot: RobotModel = CREATE_1,
                 baud: Optional[int] = None, light_bump_speed_m_s: float = 0.0,
                 stuck_after_s: float = 1.0, linear_scale: float = 1.0):
        if mode not in ("safe", "full"):
            raise ValueError("mode must be 'safe' or 'full', got %r" % (mode,))
        if cmd_timeout_s <= 0:
            raise ValueError("cmd_timeout_s must be > 0, got %r" % (cmd_timeout_s,))
        if not 0.5 < linear_scale <= 1.5:
            raise ValueError("linear_scale must be in (0.5, 1.5], got %r" % (linear_scale,))
        self.robot = robot
        self.wheel_base_m = wheel_base_m or robot.wheel_base_m
        self.baud = baud or robot.baud
        self.mode = mode
        self.cmd_timeout_s = cmd_timeout_s
        self.stop_on_bump = stop_on_bump
        self.max_wheel_speed_m_s = max_wheel_speed_m_s
        self.resend_period_s = resend_period_s
        self.light_bump_speed_m_s = light_bump_speed_m_s
        self.stuck_after_s = stuck_after_s
        self.linear_scale = linear_scale  # odometry distance factor (wheel calibration)
        self.parser = protocol.StreamParser(robot.stream_packets, robot.packet_ids)
        self.model_check = ModelCheck(robot, self.baud)
        self._held: List[Tuple[Dict[int, int], float]] = []  # frames while the check runs
        self.encoders = (EncoderOdometry(robot, self.wheel_base_m)
                         if robot.encoder_odometry else None)
        self.odom = odometry or Odometry()
        self._forward_since: Optional[float] = None  # wheels driving forward, no stasis
        self.light_bump_slowdowns = 0
        self.bytes_received = 0
        self.stuck_seconds = 0
        self.stuck_now = False
        self.values: Dict[int, int] = {}
        self.last_frame_time: Optional[float] = None  # when the newest frame arrived
        self.stream_clock = StreamClock()
        # (stamp, odometry pose x y theta) after each frame of the last on_bytes call
        self.frame_poses: List[Tuple[float, Tuple[float, float, float]]] = []
        # commanded body twist and when it came (None: never)
        self._twist: Tuple[float, float] = (0.0, 0.0)
        self._cmd_time: Optional[float] = None
        self._sent: Optional[Tuple[int, int]] = None
        self._sent_time = -math.inf
        self.watchdog_stops = 0
        self.bump_stops = 0
        self.rejected_cmds = 0
        self.saturated_cmds = 0
        self.warning_kind: Optional[str] = None  # "rejected"/"saturated": last set_twist

    # --- start-up -------------------------------------------------------------------
    def init_sequence(self) -> bytes:
        """Bytes that wake the robot, pick the mode and start the sensor stream. Sent on
        every (re)connection; the wheels start stopped."""
        self._sent = None
        self.stream_clock.reset()
        if self.encoders is not None:
            self.encoders.reset()  # the robot may have been power-cycled: new reference
        mode = protocol.safe() if self.mode == "safe" else protocol.full()
        return (protocol.start() + mode + protocol.drive_direct(0, 0)
                + protocol.stream(self.robot.stream_packets, self.robot.packet_ids))

    def demo_bytes(self, number: int) -> bytes:
        """Demo (Create 1 only; ValueError on the Create 2, where opcode 136 is Max)."""
        if self.robot.encoder_odometry:
            raise ValueError("the Create 2 has no demos (its opcode 136 is Max, a cleaning "
                             "cycle)")
        return protocol.demo(number)

    def clear_bytes(self) -> bytes:
        """Stop a running demo, cleaning cycle or docking and take the robot back into
        the driver's mode. Create 1: Demo 255 (which, like every Demo, leaves the OI in
        passive mode) then the mode; Create 2: the mode command alone ends them."""
        mode = protocol.safe() if self.mode == "safe" else protocol.full()
        return mode if self.robot.encoder_odometry else protocol.demo(255) + mode

    # --- sensors --------------------------------------------------------------------
    @property
    def frame_bytes(self) -> int:
        """Bytes of one stream frame of this model: header, length, body, checksum."""
        return 3 + self.robot.stream_body_bytes

    def event_key(self) -> Tuple[int, ...]:
        """The values of the event packets (``sensor_state.EVENT_PACKETS``: bumpers,
        wheel drops, cliffs, virtual wall, buttons, charger, light bumper): the node
        publishes the sensor messages at once when this changes, at its rate otherwise."""
        get = self.values.get
        return tuple(get(pid, -1) for pid in EVENT_PACKETS)

    @property
    def mismatch(self) -> bool:
        """The start-up check found another model (``model_check.message`` says why)."""
        return self.model_check.state == MISMATCH

    def on_bytes(self, data: bytes, now: float) -> List[Dict[int, int]]:
        """Feed bytes from the robot; complete frames update odometry and the state.

        Until the model check passes, frames are held back (none reaches odometry or
        ``values``); they are used once it passes and dropped on a mismatch, after which
        nothing more is decoded."""
        self.frame_poses = []
        self.bytes_received += len(data)
        if self.mismatch:
            return []
        frames = [f for f in self.parser.feed(data) if self.model_check.accept(f)]
        stamps = self.stream_clock.stamps(len(frames), now)
        if self.model_check.pending:
            if self.model_check.on_bytes(len(data), self.parser, now) == MISMATCH:
                self._held = []
                return []
            self._held += list(zip(frames, stamps))
            if self.model_check.pending:
                return []
        batch, self._held = self._held + list(zip(frames, stamps)), []
        for values, stamp in batch:
            self._integrate(values)
            self.values.update(values)
            self.frame_poses.append((stamp, self.odom.pose))
        if batch:
            self.last_frame_time = now
        return [values for values, _ in batch]

    def _integrate(self, values: Dict[int, int]) -> None:
        if self.encoders is None:
            distance_m, dtheta_rad = increments_si(values)
        elif 43 in values and 44 in values:
            distance_m, dtheta_rad = self.encoders.update(values[43], values[44])
        else:
            return
        self.odom.update(distance_m * self.linear_scale, dtheta_rad)

    @property
    def last_frame_stamp(self) -> Optional[float]:
        """When the newest frame was measured (StreamClock); None before the first."""
        return self.stream_clock.last

    def sensors_stale(self, now: float, timeout_s: float) -> bool:
        return self.last_frame_time is None or now - self.last_frame_time > timeout_s

    # --- commands -------------------------------------------------------------------
    def set_twist(self, linear_m_s: float, angular_rad_s: float, now: float) -> Optional[str]:
        """Store a body twist. Returns a warning text for rejected or clamped input.

        A non-finite twist is refused and the robot is stopped (the caller clearly lost
        control of its numbers); a too-fast one is scaled down keeping the turn ratio.
        ``warning_kind`` says which ("rejected", "saturated", None for no warning).
        """
        self.warning_kind = None
        try:
            cmd = kinematics.twist_to_wheels(linear_m_s, angular_rad_s, self.wheel_base_m,
                                             self.max_wheel_speed_m_s)
        except ValueError as exc:
            self.rejected_cmds += 1
            self.warning_kind = "rejected"
            self._twist, self._cmd_time = (0.0, 0.0), now
            return "cmd_vel rejected, robot stopped: %s" % exc
        self._twist, self._cmd_time = (linear_m_s, angular_rad_s), now
        if cmd.saturated:
            self.saturated_cmds += 1
            self.warning_kind = "saturated"
            return ("cmd_vel (%.3f m/s, %.3f rad/s) exceeds the wheel limit %.3f m/s; "
                    "scaled down keeping the turn ratio"
                    % (linear_m_s, angular_rad_s, self.max_wheel_speed_m_s))
        return None

    def set_wheels(self, left_m_s: float, right_m_s: float, now: float) -> Optional[str]:
        """Per-wheel command (the tank/turn services); same watchdog as cmd_vel."""
        v, w = kinematics.wheels_to_twist(left_m_s, right_m_s, self.wheel_base_m)
        return self.set_twist(v, w, now)

    def stop(self, now: float) -> None:
        self._twist, self._cmd_time = (0.0, 0.0), now

    def command_stale(self, now: float) -> bool:
        return self._cmd_time is None or now - self._cmd_time > self.cmd_timeout_s

    def bumped(self) -> bool:
        h = hazards(self.values)
        return h["bump_left"] or h["bump_right"]

    def target_wheels(self, now: float) -> Tuple[int, int]:
        """Wheel speeds [mm/s] the robot should run now, after the watchdog and bump rule."""
        if self.command_stale(now):
            return 0, 0
        v, w = self._twist
        if self.stop_on_bump and v > 0.0 and self.bumped():
            v = 0.0  # keep turning so the robot can get away from what it hit
        elif 0.0 < self.light_bump_speed_m_s < v and self.values.get(45, 0):
            v = self.light_bump_speed_m_s  # something ahead: slow down before the bump
        cmd = kinematics.twist_to_wheels(v, w, self.wheel_base_m, self.max_wheel_speed_m_s)
        return cmd.left_mm_s, cmd.right_mm_s

    def command_bytes(self, now: float) -> Optional[bytes]:
        """Drive Direct bytes to send now, or None when the robot already has them (they
        are repeated every ``resend_period_s`` in case a byte was lost on the line)."""
        target = self.target_wheels(now)
        if target == self._sent and now - self._sent_time < self.resend_period_s:
            return None
        if (self.light_bump_speed_m_s > 0.0 and self.values.get(45, 0)
                and target != self._sent and not self.command_stale(now)
                and 0.0 < self.light_bump_speed_m_s < self._twist[0]):
            self.light_bump_slowdowns += 1
        if target == (0, 0) and self._sent not in (None, (0, 0)):
            if self.command_stale(now):
                self.watchdog_stops += 1
            elif self.bumped():
                self.bump_stops += 1
        self._sent, self._sent_time = target, now
        return protocol.drive_direct(target[0], target[1])

    @property
    def sent_wheels(self) -> Optional[Tuple[int, int]]:
        return self._sent

    def watchdog_bytes(self, now: float) -> Optional[bytes]:
        """The watchdog at the stream's cadence (call after each read of frames): the
        stop command when the command went stale while the wheels were sent moving, else
        None. The command timer alone would stop them up to one of its periods late."""
        if self.command_stale(now) and self._sent not in (None, (0, 0)):
            return self.command_bytes(now)
        return None

    # --- Create 2: stasis -------------------------------------------------------------
    def update_stuck(self, now: float) -> bool:
        """Create 2: True (also kept in ``stuck_now``) when both wheels have been driven
        forward (sent speeds) for ``stuck_after_s`` while the stasis sensor (packet 58)
        reports no forward progress and is not disabled. False on a Create 1 (no 58).
        Call it periodically (the node: once a second)."""
        stasis = self.values.get(58)
        sent = self._sent or (0, 0)
        moving = min(sent) > 0
        if (stasis is None or not moving or stasis & protocol.STASIS_TOGGLING
                or stasis & protocol.STASIS_DISABLED):
            self._forward_since = None
            self.stuck_now = False
            return False
        if self._forward_since is None:
            self._forward_since = now
        self.stuck_now = now - self._forward_since >= self.stuck_after_s
        return self.stuck_now
