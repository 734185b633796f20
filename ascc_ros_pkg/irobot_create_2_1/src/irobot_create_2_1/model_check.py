"""Start-up check that the robot on the port is the model the driver was told it is.

A Create 2 driven as a Create 1 (or the reverse) does not fail loudly: at the wrong baud
rate every byte is garbage, and a Create 1 asked for the Create 2's packet group 100 does
not send the frames asked for. The check watches the replies after start-up:

* ``ok`` after ``frames_needed`` frames of the requested length with a good checksum,
  known ids and an OI mode byte (packet 35) that is an OI mode (0..3);
* ``mismatch`` when, ``window_s`` after the first byte, bytes came (at least two frames'
  worth) but no such frame: frames of another length with a good checksum (another
  model's answer to our Stream request), only garbage (another baud rate), or mode bytes
  that are no OI mode. The message names what was seen, the likely model and the
  parameter to set.

No frame reaches odometry while the check is pending (the driver only takes the first one
as its reference), so a mismatch never becomes odometry. No bytes at all is not a
mismatch (robot off or asleep): the driver keeps re-sending its start-up sequence.
Pure Python, no ROS; times are passed in.
"""
from typing import Dict, List, Mapping, Optional

from . import protocol
from .models import MODELS, RobotModel

PENDING, OK, MISMATCH = "pending", "ok", "mismatch"


class ModelCheck:
    def __init__(self, robot: RobotModel, baud: int, window_s: float = 2.0,
                 frames_needed: int = 1):
        self.robot = robot
        self.baud = baud
        self.window_s = window_s
        self.frames_needed = frames_needed
        self.state = PENDING
        self.message = ""
        self.first_byte_time: Optional[float] = None
        self.bytes_seen = 0
        self.good_frames = 0
        self.bad_modes: Dict[int, int] = {}   # mode byte -> frames

    @property
    def pending(self) -> bool:
        return self.state == PENDING

    def accept(self, values: Mapping[int, int]) -> bool:
        """A decoded frame of the requested length: True when its mode byte is an OI mode
        (the frame may be used), False otherwise (it is counted against the model)."""
        mode = values.get(35)
        if mode is not None and mode not in protocol.OI_MODES:
            self.bad_modes[mode] = self.bad_modes.get(mode, 0) + 1
            return False
        if self.state == PENDING:
            self.good_frames += 1
            if self.good_frames >= self.frames_needed:
                self.state = OK
        return True

    def on_bytes(self, n_bytes: int, parser: protocol.StreamParser, now: float) -> str:
        """Account for ``n_bytes`` just read; returns the state (``mismatch`` once the
        window has passed without enough good frames, ``message`` then says why)."""
        if self.state != PENDING or n_bytes <= 0:
            return self.state
        if self.first_byte_time is None:
            self.first_byte_time = now
        self.bytes_seen += n_bytes
        frame_bytes = self.robot.stream_body_bytes + 3
        if (now - self.first_byte_time >= self.window_s
                and self.bytes_seen >= 2 * frame_bytes):
            self.state = MISMATCH
            self.message = self._explain(parser, now - self.first_byte_time)
        return self.state

    def _likely(self) -> List[RobotModel]:
        return [m for name, m in sorted(MODELS.items()) if name != self.robot.name]

    def _explain(self, parser: protocol.StreamParser, elapsed_s: float) -> str:
        other = self._likely()[0]
        what = ("%s (Stream %s: frames of %d data bytes at %d baud)"
                % (self.robot.name, list(self.robot.stream_packets),
                   self.robot.stream_body_bytes, self.baud))
        if self.bad_modes:
            seen = ("frames whose OI mode byte (packet 35) is %s, no OI mode (0..3)"
                    % ", ".join(str(m) for m in sorted(self.bad_modes)))
        elif parser.foreign_lengths:
            length = max(parser.foreign_lengths, key=parser.foreign_lengths.get)
            seen = ("%d well-formed stream frames of %d data bytes (the robot did not "
                    "stream the packets asked for: it does not know them)"
                    % (parser.foreign_lengths[length], length))
        else:
            seen = ("%d bytes and no valid stream frame (a wrong baud rate turns every "
                    "byte into garbage)" % self.bytes_seen)
        return ("robot model mismatch: the driver expects a %s but got %s in %.1f s. "
                "The robot is likely a %s (%d baud): set ~robot_model:=%s (and ~baud, "
                "0 = the model's rate). No odometry was published from these bytes."
                % (what, seen, elapsed_s, other.name, other.baud, other.name))
