"""Node ``web_console``: the robot serves its own operator page (issue 17).

Tornado (Debian's python3-tornado) runs in its own thread with its own IOLoop; rospy
callbacks only store the newest data or hand it over with ``IOLoop.add_callback`` (the
one thread-safe entry), so every client, the lease and the sockets are touched by the
tornado thread alone. Parameters: ``web_console.params.WebConsoleParams`` (README).

Subscribes (relative names): ``camera/image_raw/compressed`` (JPEG bytes sent on
untouched), ``map``, ``battery``, ``hazards``, ``velocity_mux/active``,
``gesture_control/state``, ``e_stop``, ``move_base/NavfnROS/plan``; TF map -> base_link.
Publishes ``teleop/cmd_vel`` (the mux's operator input) and ``e_stop`` (latched); sends
goals to the ``move_base`` action. ``~bound_port``: the port really bound.
"""
import asyncio
import math
import os
import threading
import time

import actionlib
import rospkg
import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid, Path
from sensor_msgs.msg import BatteryState, CompressedImage
from std_msgs.msg import Bool, String
from tornado import httpserver, ioloop, netutil, web, websocket

from ascc_common.grid import map_from_msg
from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import quaternion_from_yaw, yaw_of
from ascc_common.throttle import Throttle
from irobot_create_2_1.msg import Hazards
from web_console.lease import BUSY, DriveLease
from web_console.map_image import crop_known, grid_to_png, map_header
from web_console.params import WebConsoleParams
from web_console.protocol import (
    MAP,
    VIDEO,
    ProtocolError,
    binary_frame,
    clamp,
    goal_in_map,
    parse_message,
    token_ok,
)

WARN_PERIOD_S = 5.0  # throttle of repeated warnings [s]
TORNADO_MAX_MESSAGE_BYTES = 65536  # beyond this tornado closes the socket (1009)
MAX_PATH_POINTS = 200  # the plan sent to pages is thinned to this many points
MAP_MARGIN_M = 1.0  # pages get the map's known part and this much around it
GOAL_STATES = {GoalStatus.PENDING: "pending", GoalStatus.ACTIVE: "active",
               GoalStatus.PREEMPTED: "cancelled", GoalStatus.SUCCEEDED: "reached",
               GoalStatus.ABORTED: "failed", GoalStatus.REJECTED: "rejected",
               GoalStatus.RECALLED: "cancelled", GoalStatus.LOST: "lost"}


class ConsoleSocket(websocket.WebSocketHandler):
    """One page. Video and status keep only the newest message while a write is pending
    (a page that does not read gets frames dropped, never queued)."""

    def initialize(self, hub):
        self.hub = hub
        self.authorized = False
        self.pending = {}  # kind -> newest unsent message
        self.busy = {}  # kind -> write in flight
        self.dropped = 0

    def open(self):
        self.hub.on_open(self)

    def on_message(self, message):
        self.hub.on_message(self, message)

    def on_close(self):
        self.hub.on_close(self)

    def offer(self, kind, data, binary):
        """Send ``data`` now, or keep it as the newest of its ``kind`` while the previous
        one is still being written (the older pending one is dropped)."""
        if self.busy.get(kind):
            if kind in self.pending:
                self.dropped += 1
            self.pending[kind] = (data, binary)
            return
        self._write(kind, data, binary)

    def _write(self, kind, data, binary):
        try:
            future = self.write_message(data, binary=binary)
        except websocket.WebSocketClosedError:
            return
        self.busy[kind] = True
        future.add_done_callback(lambda f, k=kind: self._written(f, k))

    def _written(self, future, kind):
        self.busy[kind] = False
        if future.exception() is not None:  # closed meanwhile: on_close follows
            self.pending.pop(kind, None)
            return
        if kind in self.pending:
            self._write(kind, *self.pending.pop(kind))

    def send_json(self, obj):
        try:
            self.write_message(obj)
        except websocket.WebSocketClosedError:
            pass


class Hub:
    """The tornado thread's state: pages, lease, newest map; talks to ROS through
    ``node`` (publishers and the action client are thread-safe)."""

    def __init__(self, node, p):
        self.node, self.p = node, p
        self.clients = set()
        self.lease = DriveLease(p.lease_s)
        self.map_frame_msg = None
        self.throttle = Throttle(WARN_PERIOD_S)

    # -- pages ------------------------------------------------------------------------
    def on_open(self, client):
        if len(self.clients) >= self.p.max_clients:
            self._warn("full", "web_console: refused a page: %d connected (max_clients)",
                       len(self.clients))
            client.close(1013, "too many pages connected")
            return
        client.authorized = token_ok(self.p.token, "")
        self.clients.add(client)
        client.send_json({"type": "hello", "token_required": bool(self.p.token),
                          "max_linear_mps": self.p.max_linear_mps,
                          "max_angular_rps": self.p.max_angular_rps,
                          "lease_s": self.p.lease_s,
                          "max_frame_age_s": self.p.max_frame_age_s})
        if self.map_frame_msg is not None:
            client.offer("map", self.map_frame_msg, True)

    def on_close(self, client):
        self.clients.discard(client)
        if self.lease.release(client):
            self.node.publish_zero("the driving page closed")

    def on_message(self, client, text):
        try:
            msg = parse_message(text, self.p.max_message_bytes)
            handler = getattr(self, "_on_" + msg.type)
            handler(client, msg)
        except ProtocolError as err:
            self._refuse(client, str(err))

    def _refuse(self, client, why):
        self._warn("refused:" + why.split(" ")[0], "web_console: refused a page's message: %s",
                   why)
        client.send_json({"type": "error", "message": why})

    def _need_token(self, client, what):
        if not client.authorized:
            raise ProtocolError("%s needs the token (send 'auth' first)" % what)

    def _on_auth(self, client, msg):
        client.authorized = token_ok(self.p.token, msg.token)
        client.send_json({"type": "auth", "ok": client.authorized})
        if not client.authorized:
            self._warn("badtoken", "web_console: a page sent a wrong token")

    def _on_ping(self, client, msg):
        client.send_json({"type": "pong", "id": msg.id})

    def _on_drive(self, client, msg):
        self._need_token(client, "driving")
        if self.node.e_stopped:
            raise ProtocolError("e-stop is engaged: re-arm first")
        if self.lease.command(client, time.monotonic()) == BUSY:
            raise ProtocolError("another page is driving")
        self.node.publish_drive(clamp(msg.linear, self.p.max_linear_mps),
                                clamp(msg.angular, self.p.max_angular_rps))

    def _on_release(self, client, _msg):
        if self.lease.release(client):
            self.node.publish_zero("joystick released")

    def _on_estop(self, client, msg):
        if not msg.on:
            self._need_token(client, "re-arming")
        if msg.on:
            self.lease.reset()
            self.node.publish_zero("e-stop pressed")
        self.node.publish_estop(msg.on)

    def _on_goal(self, client, msg):
        self._need_token(client, "a goal")
        bounds = self.node.map_bounds
        if bounds is None:
            raise ProtocolError("no map yet: goal refused")
        if not goal_in_map(msg.x, msg.y, bounds):
            raise ProtocolError("goal (%.2f, %.2f) m is outside the map x[%.2f, %.2f] "
                                "y[%.2f, %.2f]" % (msg.x, msg.y, bounds[0], bounds[2],
                                                   bounds[1], bounds[3]))
        self.node.send_goal(msg.x, msg.y, msg.yaw)

    def _on_cancel(self, client, _msg):
        self._need_token(client, "cancelling")
        if not self.node.cancel_goal():
            raise ProtocolError("no goal of this console to cancel")

    # -- ROS data (called through IOLoop.add_callback) ---------------------------------
    def on_video(self, stamp, jpeg):
        if not self.clients:
            return
        header = {"stamp": stamp, "age_s": rospy.get_time() - stamp}
        data = binary_frame(VIDEO, header, jpeg)
        for client in list(self.clients):
            client.offer("video", data, True)

    def on_map(self, data):
        self.map_frame_msg = data
        for client in list(self.clients):
            client.offer("map", data, True)

    def on_check(self):
        if self.lease.tick(time.monotonic()):
            self.node.publish_zero("lease ran out")

    def on_status(self):
        if not self.clients:
            return
        status = self.node.status()
        for client in list(self.clients):
            mine = dict(status)
            holder = self.lease.holder
            mine["driver"] = None if holder is None else ("you" if holder is client
                                                          else "another page")
            mine["can_drive"] = client.authorized
            mine["pages"] = len(self.clients)
            mine["video_dropped"] = client.dropped
            client.offer("status", mine, False)

    def _warn(self, key, fmt, *args):
        if self.throttle.ready(key, time.monotonic()):
            rospy.logwarn(fmt, *args)


class WebConsoleNode:
    def __init__(self):
        self.p = from_params(WebConsoleParams, rospy.get_param, "~")
        self.lock = threading.Lock()
        self.e_stopped = False
        self.map_bounds = None
        self.map_key = None
        self.battery = None
        self.hazards = None
        self.mode = "unknown"
        self.gesture = "unknown"
        self.path = []
        self.pose = None
        self.goal = None
        self.throttle = Throttle(WARN_PERIOD_S)
        self.cmd_pub = rospy.Publisher("teleop/cmd_vel", Twist, queue_size=1)
        self.estop_pub = rospy.Publisher("e_stop", Bool, queue_size=1, latch=True)
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.move_base = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        self.hub = Hub(self, self.p)
        self.loop = None
        self._start_server()
        self.subs = [
            rospy.Subscriber("camera/image_raw/compressed", CompressedImage, self.on_image,
                             queue_size=1, buff_size=2 ** 22),
            rospy.Subscriber("map", OccupancyGrid, self.on_map, queue_size=1,
                             buff_size=2 ** 24),
            rospy.Subscriber("battery", BatteryState, self.on_battery, queue_size=1),
            rospy.Subscriber("hazards", Hazards, self.on_hazards, queue_size=1),
            rospy.Subscriber("velocity_mux/active", String, self.on_mode, queue_size=1),
            rospy.Subscriber("gesture_control/state", String, self.on_gesture, queue_size=1),
            rospy.Subscriber("e_stop", Bool, self.on_estop, queue_size=1),
            rospy.Subscriber("move_base/NavfnROS/plan", Path, self.on_path, queue_size=1),
        ]
        # PacedTimer: wakes once per period, not on every /clock message of a simulator,
        # and stops when the shutdown starts (ascc_common.paced_timer)
        self.pose_timer = PacedTimer(0.1, self.on_pose_timer, rospy.get_time,
                                     rospy.core.is_shutdown_requested, name="pose")
        rospy.on_shutdown(self.on_shutdown)

    # -- the server thread --------------------------------------------------------------
    def _start_server(self):
        ready = threading.Event()
        errors = []
        www = os.path.join(rospkg.RosPack().get_path("web_console"), "www")

        def run():
            asyncio.set_event_loop(asyncio.new_event_loop())
            try:
                app = web.Application([
                    (r"/ws", ConsoleSocket, {"hub": self.hub}),
                    (r"/(.*)", web.StaticFileHandler, {"path": www,
                                                       "default_filename": "index.html"}),
                ], websocket_max_message_size=TORNADO_MAX_MESSAGE_BYTES)
                sockets = netutil.bind_sockets(self.p.port, self.p.address)
                server = httpserver.HTTPServer(app)
                server.add_sockets(sockets)
                self.bound_port = sockets[0].getsockname()[1]
                self.loop = ioloop.IOLoop.current()
                ioloop.PeriodicCallback(self.hub.on_check,
                                        1000.0 / self.p.check_rate_hz).start()
                ioloop.PeriodicCallback(self.hub.on_status,
                                        1000.0 / self.p.status_rate_hz).start()
            except OSError as err:
                errors.append(err)
                ready.set()
                return
            ready.set()
            self.loop.start()

        self.thread = threading.Thread(target=run, name="web_console_server", daemon=True)
        self.thread.start()
        ready.wait()
        if errors:
            raise RuntimeError("cannot bind %s:%d: %s" % (self.p.address, self.p.port,
                                                          errors[0]))
        rospy.set_param("~bound_port", self.bound_port)
        rospy.loginfo("web_console: serving http://%s:%d/ (driving %s)", self.p.address,
                      self.bound_port, "needs the token" if self.p.token else "open to all")

    def _call(self, fn, *args):
        if self.loop is not None:
            self.loop.add_callback(fn, *args)

    # -- ROS callbacks: store or hand over -------------------------------------------
    def on_image(self, msg):
        if "jpeg" not in msg.format.lower() or not msg.data:
            self._warn("format", "web_console: camera frame in format '%s' (%d bytes) "
                       "skipped: the page shows JPEG only", msg.format, len(msg.data))
            return
        self._call(self.hub.on_video, msg.header.stamp.to_sec(), bytes(msg.data))

    def on_map(self, msg):
        try:
            grid, info = map_from_msg(msg)
            info.check_axis_aligned()
        except ValueError as err:
            self._warn("map", "web_console: map skipped: %s", err)
            return
        key = (info, hash(grid.tobytes()))
        if key == self.map_key:
            return
        self.map_key = key
        part, shown = crop_known(grid, info, int(round(MAP_MARGIN_M / info.resolution)))
        header = map_header(shown)
        header["frame"] = msg.header.frame_id
        data = binary_frame(MAP, header, grid_to_png(part))
        with self.lock:
            self.map_bounds = info.bounds
        self._call(self.hub.on_map, data)

    def on_battery(self, msg):
        with self.lock:
            self.battery = {"percent": _finite(msg.percentage * 100.0),
                            "voltage_v": _finite(msg.voltage),
                            "charging": msg.power_supply_status ==
                            BatteryState.POWER_SUPPLY_STATUS_CHARGING}

    def on_hazards(self, msg):
        with self.lock:
            self.hazards = {"bump_left": msg.bump_left, "bump_right": msg.bump_right,
                            "wheeldrop": msg.wheeldrop_left or msg.wheeldrop_right or
                            msg.wheeldrop_caster,
                            "cliff": msg.cliff_left or msg.cliff_front_left or
                            msg.cliff_front_right or msg.cliff_right}

    def on_mode(self, msg):
        self.mode = msg.data

    def on_gesture(self, msg):
        self.gesture = msg.data

    def on_estop(self, msg):
        self.e_stopped = bool(msg.data)

    def on_path(self, msg):
        pts = [(p.pose.position.x, p.pose.position.y) for p in msg.poses]
        step = max(1, int(math.ceil(len(pts) / float(MAX_PATH_POINTS))))
        thinned = pts[::step] + (pts[-1:] if pts and (len(pts) - 1) % step else [])
        with self.lock:
            self.path = [[round(x, 3), round(y, 3)] for x, y in thinned]

    def on_pose_timer(self):
        try:
            tf = self.tf_buffer.lookup_transform(self.p.map_frame, self.p.base_frame,
                                                 rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException):
            return
        t = tf.transform
        with self.lock:
            self.pose = [round(t.translation.x, 3), round(t.translation.y, 3),
                         round(yaw_of(t.rotation), 4)]

    # -- actions of the pages (thread-safe) ------------------------------------------
    def publish_drive(self, linear, angular):
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = linear, angular
        self.cmd_pub.publish(cmd)

    def publish_zero(self, why):
        rospy.logdebug("web_console: zero command (%s)", why)
        self.cmd_pub.publish(Twist())

    def publish_estop(self, on):
        self.e_stopped = on
        self.estop_pub.publish(Bool(data=on))
        rospy.loginfo("web_console: e-stop %s", "engaged" if on else "re-armed")

    def send_goal(self, x, y, yaw):
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = self.p.map_frame
        goal.target_pose.header.stamp = rospy.Time.now()
        goal.target_pose.pose.position.x = x
        goal.target_pose.pose.position.y = y
        q = goal.target_pose.pose.orientation
        q.x, q.y, q.z, q.w = quaternion_from_yaw(yaw)
        self.move_base.send_goal(goal)
        with self.lock:
            self.goal = [x, y, yaw]
        rospy.loginfo("web_console: goal (%.2f, %.2f, %.2f rad) in %s", x, y, yaw,
                      self.p.map_frame)

    def cancel_goal(self):
        """Cancel the goal this console sent; False when none is pending or active."""
        if self.move_base.gh is None or self.move_base.get_state() not in (
                GoalStatus.PENDING, GoalStatus.ACTIVE):
            return False
        self.move_base.cancel_goal()
        return True

    def status(self):
        with self.lock:
            goal = None
            if self.goal is not None:
                state = self.move_base.get_state() if self.move_base.gh else None
                goal = {"x": self.goal[0], "y": self.goal[1], "yaw": self.goal[2],
                        "state": GOAL_STATES.get(state, "sent")}
            return {"type": "status", "battery": self.battery, "hazards": self.hazards,
                    "mode": self.mode, "gesture": self.gesture, "estop": self.e_stopped,
                    "pose": self.pose, "path": self.path, "goal": goal,
                    "frame": self.p.map_frame}

    def _warn(self, key, fmt, *args):
        if self.throttle.ready(key, time.monotonic()):
            rospy.logwarn(fmt, *args)

    def on_shutdown(self):
        if self.hub.lease.holder is not None:
            self.cmd_pub.publish(Twist())
        if self.loop is not None:
            self.loop.add_callback(self.loop.stop)


def _finite(value):
    return round(value, 3) if math.isfinite(value) else None


def main():
    rospy.init_node("web_console")
    try:
        WebConsoleNode()
    except (ValueError, RuntimeError) as err:
        rospy.logfatal("web_console: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
