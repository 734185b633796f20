"""The Q24 camera driver's logic without ROS (thesis 2.2): its parameters, the newest-frame
slot between the reader and the publisher, reconnection back-off, frame-rate and
warning throttles, and the JPEG check. ``ros/q24_camera_node.py`` wires it to topics."""
import collections
import threading
import time
from dataclasses import dataclass
from typing import Callable, Deque, Optional, Tuple

import cv2
import numpy as np

from ascc_common.params import param
from target_follower.mjpeg import Frame

# image_transport's compressed plugin (Noetic) writes this format for a bgr8 JPEG
COMPRESSED_FORMAT = "bgr8; jpeg compressed bgr8"


@dataclass
class Q24CameraParams:
    """Everything the q24_camera node reads (private parameters)."""

    url: str = param("", "MJPEG stream URL (required), e.g. the Q24's "
                     "http://<camera-ip>/control/faststream.jpg?stream=full&needlength&fps=10;"
                     " user:password@ in the URL is sent as HTTP Basic authentication")
    frame_id: str = param("camera", "frame of the images (a launch file sets e.g. "
                          "robotA/camera)")
    publish_raw: bool = param(False, "also decode and publish camera/image_raw (bgr8)")
    timeout_s: float = param(2.0, "[s] connect and read timeout: no byte for this long "
                             "is a stalled stream", gt=0.0)
    reconnect_min_s: float = param(0.5, "[s] first wait before reconnecting", gt=0.0)
    reconnect_max_s: float = param(8.0, "[s] the wait doubles up to this", gt=0.0)
    max_frame_age_s: float = param(0.5, "[s] frames older than this are dropped (here "
                                   "and, by default, by consumers)", gt=0.0)
    age_rate_hz: float = param(10.0, "[Hz] camera/frame_age publication rate", gt=0.0)
    verify_decode: bool = param(True, "decode every JPEG (at 1/8 scale unless publish_raw)"
                                " so that a corrupt one is dropped, not published")

    def validate(self) -> None:
        if not self.url.strip():
            raise ValueError("~url is required (the camera's MJPEG stream URL)")
        if self.reconnect_max_s < self.reconnect_min_s:
            raise ValueError("reconnect_max_s %.3g < reconnect_min_s %.3g"
                             % (self.reconnect_max_s, self.reconnect_min_s))


class Backoff:
    """Exponential reconnection delay: ``min_s``, doubled after each failure up to
    ``max_s``; ``reset()`` after a connection that delivered a frame."""

    def __init__(self, min_s: float, max_s: float):
        self.min_s, self.max_s = min_s, max_s
        self._next_s = min_s

    def next_delay(self) -> float:
        delay = self._next_s
        self._next_s = min(self._next_s * 2.0, self.max_s)
        return delay

    def reset(self) -> None:
        self._next_s = self.min_s


class NewestFrame:
    """The one-frame slot between the stream reader and the publisher: ``put`` replaces
    an untaken frame (counted in ``dropped``), ``take`` waits for a frame. Nothing ever
    queues behind the newest frame."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._frame: Optional[Frame] = None
        self._closed = False
        self.received = 0
        self.dropped = 0

    def put(self, frame: Frame) -> None:
        with self._cond:
            if self._frame is not None:
                self.dropped += 1
            self._frame = frame
            self.received += 1
            self._cond.notify_all()

    def take(self, timeout_s: float) -> Optional[Frame]:
        """The newest frame (removed from the slot), or None after ``timeout_s`` or
        once closed."""
        with self._cond:
            self._cond.wait_for(lambda: self._frame is not None or self._closed,
                                timeout_s)
            frame, self._frame = self._frame, None
            return frame

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()


class RateMeter:
    """Events per second over the last ``window_s`` (monotonic clock)."""

    def __init__(self, window_s: float = 5.0, clock: Callable[[], float] = time.monotonic):
        self.window_s = window_s
        self._clock = clock
        self._times: Deque[float] = collections.deque()

    def tick(self) -> None:
        self._times.append(self._clock())
        self._trim()

    def rate_hz(self) -> float:
        self._trim()
        if len(self._times) < 2:
            return 0.0
        span = self._clock() - self._times[0]
        return (len(self._times) - 1) / span if span > 0 else 0.0

    def _trim(self) -> None:
        cutoff = self._clock() - self.window_s
        while self._times and self._times[0] < cutoff:
            self._times.popleft()


def jpeg_problem(data: bytes, decode: bool = True, full: bool = False
                 ) -> Tuple[Optional[str], Optional[np.ndarray]]:
    """(what is wrong with ``data`` as a JPEG or None, the decoded bgr8 image when
    ``full``). Checks the SOI and EOI markers (a truncated frame lacks EOI), then, with
    ``decode``, decodes it: in full (bgr8) when ``full``, else at 1/8 scale, which costs
    a fraction of a full decode and still fails on most corrupt entropy data."""
    if len(data) < 4 or data[:2] != b"\xff\xd8":
        return "no JPEG start marker (SOI) in %d bytes" % len(data), None
    if not data.rstrip(b"\r\n\x00").endswith(b"\xff\xd9"):
        return "no JPEG end marker (EOI): truncated frame of %d bytes" % len(data), None
    if not decode and not full:
        return None, None
    flags = cv2.IMREAD_COLOR if full else cv2.IMREAD_REDUCED_GRAYSCALE_8
    image = cv2.imdecode(np.frombuffer(data, np.uint8), flags)
    if image is None or image.size == 0:
        return "JPEG of %d bytes does not decode" % len(data), None
    return None, image if full else None
