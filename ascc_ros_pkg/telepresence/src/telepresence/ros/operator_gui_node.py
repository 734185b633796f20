"""Node ``operator_gui``: the remote operator's Qt GUI (thesis 4.3), the window of
``telepresence.gui.window`` fed by ``RosAdapter``.

The robot is picked before rospy starts: ``--master`` / ``--ns`` (or the start dialog
when ``--master`` is not given and ROS_MASTER_URI is unset, or ``--dialog``). The master
is asked for its pid over XML-RPC with a short time-out in a thread (``check_master``)
until it answers, the dialog showing "unreachable"; only then is ``rospy.init_node``
called (it reads ROS_MASTER_URI once per process: switching to another robot needs a
restart of the GUI). While running, the same check runs every ``~master_check_s``: an
unreachable master is shown and the drive lease drops; when the master comes back with a
new pid (restarted), every subscription, publisher and the action client are made anew,
so they register with it.

Topics (relative: the robot's namespace): publishes ``teleop/cmd_vel``
(geometry_msgs/Twist, the velocity mux's operator input, only while a drive is held),
``e_stop`` (std_msgs/Bool, latched: true on the emergency stop, false on re-arm);
subscribes ``camera/image_raw/compressed`` (JPEG, decoded off the UI thread), ``map``
(OccupancyGrid, deserialised with numpy), ``odom`` (the link's heartbeat), ``battery``,
``hazards``, ``velocity_mux/active``, ``gesture_control/state``; TF map -> base_link for
the pose; action client ``move_base``.
"""
from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import time

import numpy
from PyQt5.QtCore import QObject, QTimer, pyqtSignal
from PyQt5.QtWidgets import QApplication, QDialog, QMessageBox

from ascc_common.grid import GridInfo
from ascc_common.params import from_params
from ascc_common.pose2d import quaternion_from_yaw, yaw_of
from telepresence.gui.widgets import ConnectDialog
from telepresence.gui.window import AdapterSignals, OperatorWindow
from telepresence.teleop import (
    OperatorGuiParams,
    check_master,
    decode_jpeg,
    grid_image,
    master_uri,
    namespace,
)

GOAL_TEXT = {0: "pending", 1: "active", 2: "preempted (cancelled)", 3: "reached",
             4: "aborted by move_base", 5: "refused by move_base", 6: "cancelling",
             7: "recalled", 8: "recalled (cancelled)", 9: "lost"}


class MasterWatch(QObject):
    """The master's XML-RPC check in a thread: ``state(reachable, text, pid)``."""

    state = pyqtSignal(bool, str, object)

    def __init__(self, uri, period_s, timeout_s):
        super().__init__()
        self.uri, self.period_s, self.timeout_s = uri, period_s, timeout_s
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def start(self):
        self.thread.start()

    def run(self):
        while not self.stopping.is_set():
            self.state.emit(*check_master(self.uri, self.timeout_s))
            self.stopping.wait(self.period_s)

    def stop(self):
        self.stopping.set()


class RosAdapter(AdapterSignals):
    """The GUI's ROS I/O; callbacks run in rospy's threads and reach the widgets only
    through the signals (queued into the UI thread)."""

    def __init__(self, params: OperatorGuiParams):
        super().__init__()
        import rospy
        import tf2_ros
        self.rospy = rospy
        self.p = params
        self.tf2_ros = tf2_ros
        # debug=False: no ~tf2_frames service, and no master call while the window is
        # built (a master gone at that moment raised out of the constructor)
        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0), debug=False)
        self.tf_listener = None
        self.last_odom = None  # wall time of the newest odometry
        self.master_ok = True
        self.master_pid = None
        self.link_text = None
        self.goal_handle_lock = threading.Lock()  # guards goal_seq and goal_handle
        self.goal_seq = 0  # the newest goal sent; transitions of older ones are ignored
        self.goal_handle = None  # the newest goal's actionlib ClientGoalHandle
        self.io = []
        self.goal_client = None
        self.estop_state = None
        self.counts = {"map": 0, "image": 0}  # messages received (tests, diagnosis)
        self.map_side_px = 1024  # the map widget's size (the window sets it)
        self.tf_timer = QTimer(self)
        self.tf_timer.timeout.connect(self.poll)

    def start(self):
        """Subscribe and publish: after the window has connected its slots (a latched
        message, the map, arrives at once and is sent only once)."""
        self.make_io()
        self.tf_timer.start(100)

    # -- connections ------------------------------------------------------------------
    def make_io(self):
        import actionlib
        from geometry_msgs.msg import Twist
        from move_base_msgs.msg import MoveBaseAction
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import BatteryState, CompressedImage
        from std_msgs.msg import Bool, String

        from irobot_create_2_1.msg import Hazards
        rospy = self.rospy
        for thing in self.io:
            thing.unregister()
        if self.tf_listener is not None:
            self.tf_listener.unregister()
        self.tf_listener = self.tf2_ros.TransformListener(self.tf_buffer)
        self.cmd_pub = rospy.Publisher("teleop/cmd_vel", Twist, queue_size=1)
        self.estop_pub = rospy.Publisher("e_stop", Bool, queue_size=1, latch=True)
        if self.estop_state is not None:  # a restarted master: the latched state again
            self.estop_pub.publish(Bool(data=self.estop_state))
        self.io = [
            self.cmd_pub, self.estop_pub,
            rospy.Subscriber("camera/image_raw/compressed", CompressedImage, self.on_image,
                             queue_size=1, buff_size=2 ** 24),
            rospy.Subscriber("map", rospy.AnyMsg, self.on_map, queue_size=1,
                             buff_size=2 ** 26),
            rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=1),
            rospy.Subscriber("battery", BatteryState, self.on_battery, queue_size=1),
            rospy.Subscriber("hazards", Hazards, self.on_hazards, queue_size=1),
            rospy.Subscriber("velocity_mux/active", String,
                             lambda m: self.mux_active.emit(m.data), queue_size=1),
            rospy.Subscriber("gesture_control/state", String,
                             lambda m: self.gesture_state.emit(m.data), queue_size=1),
        ]
        if self.goal_client is not None:
            self.goal_client.stop()
        # actionlib.ActionClient, not SimpleActionClient: Noetic's SimpleActionClient
        # drops a transition that arrives before send_goal has returned ("not tracking",
        # ros/actionlib#206), and active_cb is then never called; here each goal's
        # callback knows its own sequence number before the goal leaves
        self.goal_client = actionlib.ActionClient("move_base", MoveBaseAction)

    def on_master(self, reachable, text, pid):
        restarted = reachable and self.master_pid is not None and pid != self.master_pid
        self.master_ok = reachable
        if reachable:
            self.master_pid = pid
        if restarted:
            self.rospy.logwarn("operator_gui: the master restarted (%s): reconnecting", text)
            self.make_io()
        if not reachable:
            self.rospy.logwarn_throttle(5.0, "operator_gui: %s" % text)
        self.update_link(text)

    def update_link(self, master_text=""):
        if not self.master_ok:
            up, text = False, master_text
        elif self.last_odom is None:
            up, text = False, "connected; no odometry from the robot yet"
        elif time.monotonic() - self.last_odom > self.p.link_timeout_s:
            up, text = False, "robot silent: no odometry for %.1f s" % (
                time.monotonic() - self.last_odom)
        else:
            up, text = True, "up"
        if (up, text) != self.link_text:
            self.link_text = (up, text)
            self.link.emit(up, text)

    def now(self):
        return self.rospy.Time.now().to_sec()

    # -- callbacks (rospy threads) ----------------------------------------------------
    def on_image(self, msg):
        self.counts["image"] += 1
        bgr = decode_jpeg(bytes(msg.data))
        if bgr is None:
            self.rospy.logwarn_throttle(5.0, "operator_gui: a camera frame (%d bytes, format "
                                        "'%s') does not decode as JPEG" % (len(msg.data),
                                                                           msg.format))
            return
        self.frame.emit(bgr, msg.header.stamp.to_sec())

    def on_map(self, raw):
        from nav_msgs.msg import OccupancyGrid
        self.counts["map"] += 1
        msg = OccupancyGrid()
        try:
            msg.deserialize_numpy(raw._buff, numpy)
            info = GridInfo.from_msg_info(msg.info).check_axis_aligned()
            grid = numpy.asarray(msg.data, dtype=numpy.int8).reshape(info.height, info.width)
            image, _ = grid_image(grid, self.map_side_px)  # here, not in the UI thread
        except Exception as exc:  # noqa: BLE001 - any bad map is named, the GUI keeps on
            self.rospy.logwarn_throttle(5.0, "operator_gui: unusable map: %s" % exc)
            return
        if self.counts["map"] == 1:
            rospy_ = self.rospy
            rospy_.loginfo("operator_gui: first map %d x %d cells of %.3f m", info.width,
                           info.height, info.resolution)
        self.grid.emit(grid, info, image)

    def on_odom(self, msg):
        self.last_odom = time.monotonic()

    def on_battery(self, msg):
        pct = msg.percentage * 100.0 if math.isfinite(msg.percentage) else float("nan")
        low = math.isfinite(pct) and pct < 20.0
        self.battery.emit("%.0f %%, %.2f V" % (pct, msg.voltage), low)

    def on_hazards(self, msg):
        bumps = [n for n, b in (("left", msg.bump_left), ("right", msg.bump_right)) if b]
        drops = [n for n, b in (("left", msg.wheeldrop_left), ("right", msg.wheeldrop_right),
                                ("caster", msg.wheeldrop_caster)) if b]
        self.hazards.emit(", ".join(bumps) or "none", ", ".join(drops) or "none",
                          bool(bumps or drops))

    # -- UI thread --------------------------------------------------------------------
    def poll(self):
        """The pose from TF and the link's state (10 Hz)."""
        self.update_link()
        try:
            t = self.tf_buffer.lookup_transform(self.p.map_frame, self.p.base_frame,
                                                self.rospy.Time(0))
        except Exception:  # noqa: BLE001 - no pose yet: nothing to draw
            return
        tr = t.transform
        self.pose.emit(tr.translation.x, tr.translation.y, yaw_of(tr.rotation))

    def publish_cmd(self, v, w):
        from geometry_msgs.msg import Twist
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        self.cmd_pub.publish(msg)

    def publish_estop(self, engaged):
        from std_msgs.msg import Bool
        self.estop_state = bool(engaged)
        self.estop_pub.publish(Bool(data=self.estop_state))

    def send_goal(self, x, y, yaw):
        from move_base_msgs.msg import MoveBaseGoal
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = self.p.map_frame
        goal.target_pose.header.stamp = self.rospy.Time.now()
        goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = x, y
        qx, qy, qz, qw = quaternion_from_yaw(yaw)
        o = goal.target_pose.pose.orientation
        o.x, o.y, o.z, o.w = qx, qy, qz, qw
        if not self.goal_client.wait_for_server(self.rospy.Duration(0.2)):
            self.goal_status.emit("no move_base action server: goal not sent", False, True)
            return
        self.goal_status.emit("sent (%.2f, %.2f)" % (x, y), True, False)  # before: the
        # transitions come from actionlib's thread, queued after it
        with self.goal_handle_lock:
            self.goal_seq += 1
            seq = self.goal_seq
        handle = self.goal_client.send_goal(
            goal, transition_cb=lambda gh: self.on_goal_transition(seq, gh, x, y))
        with self.goal_handle_lock:
            if seq == self.goal_seq:
                self.goal_handle = handle

    def cancel_goal(self):
        self.goal_client.cancel_all_goals()

    def on_goal_transition(self, seq, gh, x, y):
        """actionlib's thread: the goal's communication state changed."""
        from actionlib import CommState
        with self.goal_handle_lock:
            if seq != self.goal_seq:
                return  # a goal replaced by a newer one
        comm = gh.get_comm_state()
        if comm == CommState.ACTIVE:
            self.goal_status.emit("active (%.2f, %.2f)" % (x, y), True, False)
        elif comm == CommState.DONE:
            state = gh.get_goal_status()
            text = GOAL_TEXT.get(state, "state %d" % state)
            self.goal_status.emit(text, False, state not in (2, 3, 8))


def make_window(uri, title):
    """After ``rospy.init_node``: the adapter, the shown window and the running master
    watch (the node's main, and the rostest that drives the window)."""
    import rospy
    params = from_params(OperatorGuiParams, rospy.get_param, "~")
    adapter = RosAdapter(params)
    window = OperatorWindow(adapter, params, title)
    adapter.start()
    watch = MasterWatch(uri, params.master_check_s, params.master_timeout_s)
    watch.state.connect(adapter.on_master)
    watch.start()
    window.resize(1280, 600)
    window.show()
    window.activateWindow()
    return adapter, window, watch


def pick_robot(app, uri, ns, params, dialog):
    """The master and namespace: given, or from the dialog; then waited for (the check in
    a thread, shown in a message box that the operator may cancel: back to the dialog if
    there is one). None if cancelled."""
    while True:
        if dialog:
            d = ConnectDialog(uri, ns)
            if d.exec_() != QDialog.Accepted:
                return None
            uri, ns = d.result_uri, d.result_ns
        if wait_for_master(uri, params):
            return uri, ns
        if not dialog:
            return None


def wait_for_master(uri, params):
    """True when the master at uri answers, False if the operator cancels the wait."""
    watch = MasterWatch(uri, params.master_check_s, params.master_timeout_s)
    box = QMessageBox(QMessageBox.Information, "ASCCbot telepresence",
                      "checking %s ..." % uri, QMessageBox.Cancel)
    result = {}

    def on_state(ok, text, _pid):
        if ok:
            result["ok"] = True
            box.done(0)
        else:
            if box.text().split("\n")[0] != text:  # also on stderr, once per change
                print("operator_gui: %s; retrying every %.1f s" % (text, params.master_check_s),
                      file=sys.stderr, flush=True)
            box.setText("%s\nretrying every %.1f s" % (text, params.master_check_s))

    watch.state.connect(on_state)
    watch.start()
    box.exec_()
    watch.stop()
    return bool(result.get("ok"))


def main(argv=None):
    """The node; exits with run()'s code (0 closed, 1 cancelled, 2 bad arguments)."""
    sys.exit(run(sys.argv if argv is None else argv))


def run(argv):
    import rospy
    args = rospy.myargv(argv)[1:]
    parser = argparse.ArgumentParser(prog="operator_gui", description=__doc__.split("\n")[0])
    parser.add_argument("--master", default="", help="the robot: IP, host[:port] or URI")
    parser.add_argument("--ns", default="", help="the robot's namespace")
    parser.add_argument("--dialog", action="store_true", help="always show the start dialog")
    opts = parser.parse_args(args)
    app = QApplication(argv[:1])
    signal.signal(signal.SIGINT, lambda *_: app.quit())  # also ends the waiting dialogs
    timer = QTimer()  # Ctrl-C / rosnode kill end the Qt loops (Python sees signals)
    timer.timeout.connect(lambda: app.quit() if rospy.is_shutdown() else None)
    timer.start(200)
    params = OperatorGuiParams()
    env_uri = os.environ.get("ROS_MASTER_URI", "")
    try:
        uri = master_uri(opts.master or env_uri) if (opts.master or env_uri) else ""
        ns = namespace(opts.ns or os.environ.get("ROS_NAMESPACE", ""))
    except ValueError as exc:
        print("operator_gui: %s" % exc, file=sys.stderr)
        return 2
    picked = pick_robot(app, uri, ns, params, opts.dialog or not uri)
    if picked is None:
        return 1
    uri, ns = picked
    os.environ["ROS_MASTER_URI"] = uri
    if ns != "/":
        os.environ["ROS_NAMESPACE"] = ns
    rospy.init_node("operator_gui", argv=argv, anonymous=False, disable_signals=True)
    adapter, window, watch = make_window(uri, "%s %s" % (uri, ns))
    rospy.on_shutdown(lambda: app.quit())
    rc = app.exec_()
    watch.stop()
    window.lease.release_all()
    window.tick()
    rospy.signal_shutdown("window closed")
    return rc
