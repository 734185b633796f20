"""The operator's main window: video, map, drive panel and status, wired to the drive
lease and an adapter (the ROS side, or a test's) through Qt signals.

The adapter is an ``AdapterSignals`` (its signals) with the methods ``publish_cmd(v, w)``,
``publish_estop(bool)``, ``send_goal(x, y, yaw)``, ``cancel_goal()``, ``now()`` (the
clock of the frames' stamps [s]) and the attribute ``map_side_px`` (set by the window)."""
from __future__ import annotations

from PyQt5.QtCore import QEvent, QObject, Qt, QTimer, pyqtSignal
from PyQt5.QtWidgets import QHBoxLayout, QMainWindow, QSplitter, QVBoxLayout, QWidget

from telepresence.gui.widgets import DrivePanel, MapWidget, StatusPanel, VideoWidget
from telepresence.teleop import (
    BACKWARD,
    FORWARD,
    LEFT,
    RIGHT,
    DriveLease,
    EmergencyStop,
    OperatorGuiParams,
    goal_pose,
)

KEYS = {Qt.Key_Up: FORWARD, Qt.Key_W: FORWARD, Qt.Key_Down: BACKWARD, Qt.Key_S: BACKWARD,
        Qt.Key_Left: LEFT, Qt.Key_A: LEFT, Qt.Key_Right: RIGHT, Qt.Key_D: RIGHT}


class AdapterSignals(QObject):
    """What the ROS side tells the window (emitted from any thread, delivered in the UI
    thread)."""

    frame = pyqtSignal(object, float)  # BGR image, its stamp [s]
    grid = pyqtSignal(object, object, object)  # int8 grid, GridInfo, grey image or None
    pose = pyqtSignal(float, float, float)  # robot in the map frame: x, y [m], yaw [rad]
    battery = pyqtSignal(str, bool)  # text, fault
    hazards = pyqtSignal(str, str, bool)  # bumpers, wheel drops, fault
    mux_active = pyqtSignal(str)  # velocity_mux/active
    gesture_state = pyqtSignal(str)  # gesture_control/state
    goal_status = pyqtSignal(str, bool, bool)  # text, active, fault
    link = pyqtSignal(bool, str)  # up, what


class OperatorWindow(QMainWindow):
    def __init__(self, adapter, params: OperatorGuiParams = None, title: str = "ASCCbot"):
        super().__init__()
        self.p = params or OperatorGuiParams()
        self.adapter = adapter
        self.setWindowTitle("ASCCbot telepresence: %s" % title)
        self.lease = DriveLease(self.p.max_linear_mps, self.p.max_angular_radps)
        self.estop = EmergencyStop(self.lease)
        self.video = VideoWidget(self.p.video_stale_s, clock=adapter.now)
        self.map = MapWidget(self.p.path_step_m, self.p.path_points)
        self.drive = DrivePanel()
        self.status = StatusPanel()
        self.goal_active = False
        self.last_cmd = None
        self.mux_active = "-"


        side = QWidget()
        col = QVBoxLayout(side)
        col.addWidget(self.drive)
        col.addWidget(self.status)
        col.addStretch(1)
        split = QSplitter(Qt.Horizontal)
        split.addWidget(self.video)
        split.addWidget(self.map)
        central = QWidget()
        row = QHBoxLayout(central)
        row.addWidget(split, 1)
        row.addWidget(side)
        self.setCentralWidget(central)
        self.setFocusPolicy(Qt.StrongFocus)

        self.drive.pressed.connect(self.on_press)
        self.drive.released.connect(self.on_release)
        self.drive.speed_changed.connect(self.on_speed)
        self.drive.estop.connect(self.on_estop)
        self.drive.rearm.connect(self.on_rearm)
        self.drive.cancel_goal.connect(self.on_cancel_goal)
        self.map.goal_clicked.connect(self.on_map_click)
        adapter.frame.connect(self.on_frame)
        adapter.grid.connect(self.map.set_map)
        self.map.side_changed.connect(self.on_map_side)
        self.on_map_side(self.map.side_px())
        adapter.pose.connect(self.map.set_robot)
        adapter.battery.connect(lambda t, f: self.status.show("battery", t, f))
        adapter.hazards.connect(self.on_hazards)
        adapter.mux_active.connect(self.on_mux_active)
        adapter.gesture_state.connect(
            lambda t: self.status.show("gesture", t if t == "idle" else
                                       "%s: gesture control has the robot" % t, False))
        adapter.goal_status.connect(self.on_goal_status)
        adapter.link.connect(self.on_link)
        self.on_speed(self.drive.speed.value() / 100.0)

        self.timer = QTimer(self)
        self.timer.timeout.connect(self.tick)
        self.timer.start(int(round(1000.0 / self.p.cmd_rate_hz)))
        self.video_timer = QTimer(self)  # the video's age keeps growing without frames
        self.video_timer.timeout.connect(self.video.update)
        self.video_timer.start(250)

    # -- the drive lease --------------------------------------------------------------
    def tick(self):
        cmd = self.lease.tick()
        if cmd is not None:
            self.adapter.publish_cmd(*cmd)
        self.last_cmd = cmd

    def on_press(self, direction):
        self.lease.press(direction)
        self.tick()

    def on_release(self, direction):
        self.lease.release(direction)
        self.tick()

    def on_speed(self, fraction):
        self.lease.set_speed(fraction)
        self.drive.show_speed(self.lease.speed * self.lease.max_linear_mps,
                              self.lease.speed * self.lease.max_angular_radps)

    def keyPressEvent(self, event):
        if event.key() == Qt.Key_Space:
            self.on_estop()
        elif event.key() in KEYS and not event.isAutoRepeat():
            self.on_press(KEYS[event.key()])
        else:
            super().keyPressEvent(event)

    def keyReleaseEvent(self, event):
        if event.key() in KEYS and not event.isAutoRepeat():
            self.on_release(KEYS[event.key()])
        else:
            super().keyReleaseEvent(event)

    def changeEvent(self, event):
        if event.type() == QEvent.ActivationChange:
            self.lease.set_focus(self.isActiveWindow())
            self.tick()
        super().changeEvent(event)

    def focusOutEvent(self, event):
        self.lease.set_focus(self.isActiveWindow())
        self.tick()
        super().focusOutEvent(event)

    def on_link(self, up, what):
        self.lease.set_link(up)
        self.status.show("link", what, not up)
        self.tick()

    # -- emergency stop ---------------------------------------------------------------
    def on_estop(self):
        self.adapter.publish_estop(self.estop.engage())
        self.drive.show_estop(True)
        self.status.show("mode", "EMERGENCY STOP (mux: %s)" % self.mux_active, True)
        self.tick()

    def on_rearm(self):
        self.adapter.publish_estop(self.estop.rearm())
        self.drive.show_estop(False)
        self.status.show("mode", self.mux_active, False)

    # -- goals ------------------------------------------------------------------------
    def on_map_click(self, x, y):
        if self.estop.engaged:
            self.status.show("goal", "not sent: emergency stop engaged", True)
            return
        goal = goal_pose(x, y, self.map.robot)
        self.map.set_goal(goal)
        self.adapter.send_goal(*goal)

    def on_cancel_goal(self):
        self.adapter.cancel_goal()

    def on_goal_status(self, text, active, fault):
        self.goal_active = active
        self.drive.cancel_button.setEnabled(active)
        self.status.show("goal", text, fault)
        if not active and not fault:
            self.map.set_goal(None)

    def on_map_side(self, side_px):
        """The adapter renders map images for this size in its own thread."""
        self.adapter.map_side_px = side_px

    # -- status -----------------------------------------------------------------------
    def on_frame(self, bgr, stamp_s):
        self.video.show_frame(bgr, stamp_s)

    def on_mux_active(self, active):
        """The mux's active input; the e-stop stays visible while engaged."""
        self.mux_active = active
        if self.estop.engaged:
            self.status.show("mode", "EMERGENCY STOP (mux: %s)" % active, True)
        else:
            self.status.show("mode", active, False)

    def on_hazards(self, bumpers, drops, fault):
        self.status.show("bumpers", bumpers, fault and bumpers != "none")
        self.status.show("wheel drops", drops, fault and drops != "none")

    def closeEvent(self, event):
        self.lease.release_all()
        self.tick()
        super().closeEvent(event)
