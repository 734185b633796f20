"""The operator GUI's rules without Qt or rospy: the drive lease, the latched emergency
stop, the robot address, the map view (pixel <-> map frame, the grid as an image) and
the video statistics. The widgets (``telepresence.gui``) and the node only wire these to
events and topics, so they are tested here without a master or a display.
"""
from __future__ import annotations

import collections
import math
import socket
import xmlrpc.client
from dataclasses import dataclass
from typing import Deque, Dict, FrozenSet, Iterable, Optional, Tuple
from urllib.parse import urlsplit

import cv2
import numpy as np

from ascc_common.grid import GridInfo
from ascc_common.params import param

# Drive directions a button or key holds; each adds its unit command.
FORWARD, BACKWARD, LEFT, RIGHT = "forward", "backward", "left", "right"
DIRECTIONS = (FORWARD, BACKWARD, LEFT, RIGHT)
_UNIT = {FORWARD: (1.0, 0.0), BACKWARD: (-1.0, 0.0), LEFT: (0.0, 1.0), RIGHT: (0.0, -1.0)}


@dataclass
class OperatorGuiParams:
    """Parameters of node ``operator_gui`` (package README)."""

    max_linear_mps: float = param(0.3, "[m/s] teleop speed limit (full speed slider)", gt=0.0)
    max_angular_radps: float = param(1.0, "[rad/s] teleop turn rate limit", gt=0.0)
    cmd_rate_hz: float = param(10.0, "[Hz] teleop command rate while a drive is held", gt=0.0)
    link_timeout_s: float = param(
        1.0, "[s] no odometry for this long: the link is down, teleop stops", gt=0.0)
    master_check_s: float = param(1.0, "[s] period of the master check (xmlrpc)", gt=0.0)
    master_timeout_s: float = param(0.5, "[s] time-out of one master check", gt=0.0)
    video_stale_s: float = param(1.0, "[s] a frame older than this is shown as stale", gt=0.0)
    map_frame: str = param("map", "map frame (goals, map widget)")
    base_frame: str = param("base_link", "robot frame (pose on the map)")
    path_points: int = param(2000, "robot path points kept on the map", ge=2)
    path_step_m: float = param(0.05, "[m] a path point is added after this much motion",
                               gt=0.0)


# -- the drive lease --------------------------------------------------------------------
class DriveLease:
    """Teleop commands as a lease: a command is due only while a drive direction is held,
    the window has the focus, the link is up and the emergency stop is released. When any
    of these ends, ``tick`` returns one zero command, then None (nothing to publish: the
    mux's input goes stale and hands the base over, or stops it).

    ``speed`` (0..1) scales the limits; diagonal combinations (forward + left) keep both
    components; opposite directions cancel."""

    def __init__(self, max_linear_mps: float, max_angular_radps: float):
        if not (max_linear_mps > 0.0 and max_angular_radps > 0.0):
            raise ValueError("speed limits must be positive, got %r, %r"
                             % (max_linear_mps, max_angular_radps))
        self.max_linear_mps = float(max_linear_mps)
        self.max_angular_radps = float(max_angular_radps)
        self.speed = 0.5
        self.held: Dict[str, int] = {}  # direction -> how many sources (key, button) hold it
        self.focus = True
        self.link = True
        self.stopped = False  # the emergency stop
        self._sent_moving = False

    def set_speed(self, fraction: float) -> None:
        if not math.isfinite(fraction):
            raise ValueError("speed fraction must be finite, got %r" % (fraction,))
        self.speed = min(1.0, max(0.0, float(fraction)))

    def press(self, direction: str) -> None:
        if direction not in _UNIT:
            raise ValueError("unknown drive direction %r (one of %s)"
                             % (direction, ", ".join(DIRECTIONS)))
        self.held[direction] = self.held.get(direction, 0) + 1

    def release(self, direction: str) -> None:
        n = self.held.get(direction, 0) - 1
        if n > 0:
            self.held[direction] = n
        else:
            self.held.pop(direction, None)

    def release_all(self) -> None:
        self.held.clear()

    def set_focus(self, focus: bool) -> None:
        """Focus lost: every held direction is released (key releases never arrive)."""
        self.focus = bool(focus)
        if not self.focus:
            self.release_all()

    def set_link(self, up: bool) -> None:
        self.link = bool(up)
        if not self.link:
            self.release_all()

    @property
    def directions(self) -> FrozenSet[str]:
        return frozenset(self.held)

    @property
    def engaged(self) -> bool:
        return bool(self.held) and self.focus and self.link and not self.stopped

    def target(self) -> Tuple[float, float]:
        """(linear m/s, angular rad/s) of the held directions at the current speed."""
        if not self.engaged:
            return 0.0, 0.0
        v = sum(_UNIT[d][0] for d in self.held)
        w = sum(_UNIT[d][1] for d in self.held)
        v = max(-1.0, min(1.0, v)) * self.speed * self.max_linear_mps
        w = max(-1.0, min(1.0, w)) * self.speed * self.max_angular_radps
        return v, w

    def tick(self) -> Optional[Tuple[float, float]]:
        """The command to publish now (at the command rate, and at once after a change),
        or None: nothing to publish."""
        if self.engaged:
            self._sent_moving = True
            return self.target()
        if self._sent_moving:
            self._sent_moving = False
            return 0.0, 0.0
        return None


class EmergencyStop:
    """Latched: ``engage`` holds until ``rearm``; the GUI publishes ``e_stop`` (a mux lock
    above every input) true on engage, false on re-arm only."""

    def __init__(self, lease: DriveLease):
        self.lease = lease
        self.engaged = False

    def engage(self) -> bool:
        self.engaged = True
        self.lease.stopped = True
        self.lease.release_all()
        return True

    def rearm(self) -> bool:
        self.engaged = False
        self.lease.stopped = False
        return False


# -- the robot's address ------------------------------------------------------------------
def master_uri(text: str, default_port: int = 11311) -> str:
    """What the operator typed (an IP or host name, host:port, or a URI) -> the master's
    URI ``http://host:port/``. ValueError naming the text if it is not one."""
    s = (text or "").strip()
    if not s:
        raise ValueError("empty robot address: give an IP, host[:port] or http://host:port")
    if "://" not in s:
        s = "http://" + s
    parts = urlsplit(s)
    if parts.scheme != "http" or not parts.hostname:
        raise ValueError("robot address %r: expected an IP, host[:port] or http://host:port"
                         % text)
    try:
        port = parts.port or default_port
    except ValueError:
        raise ValueError("robot address %r: bad port" % text) from None
    if parts.path not in ("", "/"):
        raise ValueError("robot address %r: a master URI has no path" % text)
    host = parts.hostname
    if ":" in host:
        host = "[%s]" % host
    return "http://%s:%d/" % (host, port)


def namespace(text: str) -> str:
    """A robot namespace as typed ('robotA', '/robotA/', '' or '/') -> '/robotA' or '/'."""
    s = (text or "").strip().strip("/")
    if not s:
        return "/"
    for part in s.split("/"):
        if not part or not (part[0].isalpha()) or not all(c.isalnum() or c == "_"
                                                          for c in part):
            raise ValueError("namespace %r: parts must be a letter then letters, digits, _"
                             % text)
    return "/" + s


class _TimeoutTransport(xmlrpc.client.Transport):
    def __init__(self, timeout_s: float):
        super().__init__()
        self.timeout_s = timeout_s

    def make_connection(self, host):
        conn = super().make_connection(host)
        conn.timeout = self.timeout_s
        return conn


def check_master(uri: str, timeout_s: float = 0.5) -> Tuple[bool, str, Optional[int]]:
    """Ask the master at ``uri`` for its pid (getPid) within ``timeout_s``: (reachable,
    what to show, pid). Never raises and never waits longer (run it off the UI thread)."""
    proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout_s))
    try:
        code, msg, pid = proxy.getPid("/operator_gui_check")
    except (OSError, socket.timeout) as exc:
        return False, "master %s unreachable: %s" % (uri, exc), None
    except (xmlrpc.client.Error, ValueError) as exc:
        return False, "%s is not a ROS master: %s" % (uri, exc), None
    if code != 1:
        return False, "master %s answered %r: %s" % (uri, code, msg), None
    return True, "master %s (pid %d)" % (uri, pid), int(pid)


# -- the map -----------------------------------------------------------------------------
def _grid_lut() -> np.ndarray:
    """uint8 grey per int8 cell value (indexed by its uint8 view): rviz's map colours,
    unknown 205, free 254, occupied 0, in between darker with the probability."""
    values = np.arange(256, dtype=np.uint8).view(np.int8).astype(np.int16)
    lut = np.full(256, 205, dtype=np.uint8)
    known = (values >= 0) & (values <= 100)
    lut[known] = (254 - values[known] * 254 // 100).astype(np.uint8)
    return lut


GRID_LUT = _grid_lut()


def grid_image(grid: np.ndarray, max_side_px: int) -> Tuple[np.ndarray, float]:
    """int8 grid (height, width; row 0 at the map's bottom) -> (uint8 grey image, north
    up, its longer side at most ``max_side_px``; cells per pixel). One table look-up and
    one area resize (cv2): a 4000 x 4000 map in tens of ms."""
    if grid.ndim != 2 or grid.size == 0:
        raise ValueError("map grid must be a non-empty 2D array, got shape %r"
                         % (grid.shape,))
    img = cv2.LUT(np.ascontiguousarray(grid).view(np.uint8), GRID_LUT)
    h, w = img.shape
    scale = max(1.0, max(h, w) / float(max(1, max_side_px)))
    if scale > 1.0:
        img = cv2.resize(img, (max(1, int(round(w / scale))), max(1, int(round(h / scale)))),
                         interpolation=cv2.INTER_AREA)
    return cv2.flip(img, 0), scale  # flipped after the resize: fewer pixels


class MapView:
    """The map drawn fitted and centred in a widget of ``(width_px, height_px)``, north
    up: map-frame metres <-> widget pixels (x right, y down)."""

    def __init__(self, info: GridInfo, width_px: int, height_px: int):
        info.check_axis_aligned()
        self.info = info
        w_m, h_m = info.size_m
        self.px_per_m = min(width_px / w_m, height_px / h_m)
        self.left = (width_px - w_m * self.px_per_m) / 2.0
        self.top = (height_px - h_m * self.px_per_m) / 2.0

    def to_pixel(self, x, y):
        px = self.left + (np.asarray(x, dtype=float) - self.info.origin_x) * self.px_per_m
        py = self.top + (self.info.ymax - np.asarray(y, dtype=float)) * self.px_per_m
        return px, py

    def to_map(self, px: float, py: float) -> Tuple[float, float]:
        x = self.info.origin_x + (px - self.left) / self.px_per_m
        y = self.info.ymax - (py - self.top) / self.px_per_m
        return float(x), float(y)

    def inside(self, px: float, py: float) -> bool:
        x, y = self.to_map(px, py)
        ix, iy = self.info.world_to_cell(x, y)
        return bool(self.info.contains(ix, iy))

    def rect(self) -> Tuple[float, float, float, float]:
        """(left, top, width, height) [px] of the whole map in the widget."""
        w_m, h_m = self.info.size_m
        return self.left, self.top, w_m * self.px_per_m, h_m * self.px_per_m


def goal_pose(x: float, y: float, robot: Optional[Tuple[float, float, float]] = None
              ) -> Tuple[float, float, float]:
    """The goal for a click at (x, y) [m, map frame]: facing away from the robot (the
    direction it arrives from), or the robot's heading when it is on the spot."""
    if robot is None:
        return x, y, 0.0
    dx, dy = x - robot[0], y - robot[1]
    if math.hypot(dx, dy) < 1e-3:
        return x, y, robot[2]
    return x, y, math.atan2(dy, dx)


class PathTrail:
    """The robot's path on the map: a point per ``step_m`` of motion, the newest
    ``max_points``."""

    def __init__(self, step_m: float, max_points: int):
        self.step_m = step_m
        self.points: Deque[Tuple[float, float]] = collections.deque(maxlen=max_points)

    def add(self, x: float, y: float) -> bool:
        if self.points and math.hypot(x - self.points[-1][0],
                                      y - self.points[-1][1]) < self.step_m:
            return False
        self.points.append((x, y))
        return True

    def clear(self) -> None:
        self.points.clear()


# -- the video ---------------------------------------------------------------------------
class FrameStats:
    """Frame rate over the last ``window_s`` of shown frames and each frame's age at
    display (display time - the frame's stamp: glass-to-glass in one clock)."""

    def __init__(self, window_s: float = 2.0):
        self.window_s = window_s
        self.shown: Deque[float] = collections.deque()
        self.ages: Deque[float] = collections.deque(maxlen=1000)
        self.last_stamp: Optional[float] = None

    def add(self, stamp_s: float, now_s: float) -> float:
        """A frame stamped ``stamp_s`` shown at ``now_s``; returns its age [s]."""
        if self.shown and now_s < self.shown[-1]:  # time went back (a restarted sim)
            self.shown.clear()
        self.shown.append(now_s)
        while self.shown and self.shown[0] < now_s - self.window_s:
            self.shown.popleft()
        self.last_stamp = stamp_s
        age = now_s - stamp_s
        self.ages.append(age)
        return age

    def fps(self, now_s: float) -> float:
        recent = [t for t in self.shown if t >= now_s - self.window_s]
        if len(recent) < 2:
            return 0.0
        span = now_s - recent[0]
        return (len(recent) - 1) / span if span > 0 else 0.0

    def age(self, now_s: float) -> Optional[float]:
        """Age of the newest frame now (grows while none arrives)."""
        return None if self.last_stamp is None else now_s - self.last_stamp


def percentiles(values: Iterable[float], qs=(50, 95, 100)) -> Tuple[float, ...]:
    arr = np.asarray(list(values), dtype=float)
    if arr.size == 0:
        return tuple(float("nan") for _ in qs)
    return tuple(float(np.percentile(arr, q)) for q in qs)


def decode_jpeg(data: bytes) -> Optional[np.ndarray]:
    """JPEG bytes -> BGR image, or None if they do not decode."""
    buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size == 0:
        return None
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)
