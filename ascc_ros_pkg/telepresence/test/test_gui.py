"""The operator GUI's widgets offscreen (QT_QPA_PLATFORM=offscreen), driven with QTest;
the ROS side replaced by a recorder with the adapter's signals (the node's adapter runs in
operator_gui.test against the simulator)."""
import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

pytest.importorskip("PyQt5.QtWidgets", reason="PyQt5 comes from Debian/Ubuntu's python3-pyqt5")
from PyQt5.QtCore import QPoint, Qt  # noqa: E402
from PyQt5.QtTest import QTest  # noqa: E402
from PyQt5.QtWidgets import QApplication  # noqa: E402

from ascc_common.grid import GridInfo  # noqa: E402
from telepresence.gui.widgets import ConnectDialog, MapWidget, VideoWidget  # noqa: E402
from telepresence.gui.window import AdapterSignals, OperatorWindow  # noqa: E402
from telepresence.teleop import FORWARD, OperatorGuiParams  # noqa: E402

APP = QApplication.instance() or QApplication([])


class Recorder(AdapterSignals):
    """The adapter's signals; records what the window asks of the ROS side."""

    def __init__(self):
        super().__init__()
        self.cmds, self.estops, self.goals, self.cancels = [], [], [], 0
        self.t = 100.0
        self.map_side_px = None

    def publish_cmd(self, v, w):
        self.cmds.append((v, w))

    def publish_estop(self, engaged):
        self.estops.append(engaged)

    def send_goal(self, x, y, yaw):
        self.goals.append((x, y, yaw))

    def cancel_goal(self):
        self.cancels += 1

    def now(self):
        return self.t


@pytest.fixture
def gui():
    rec = Recorder()
    w = OperatorWindow(rec, OperatorGuiParams(cmd_rate_hz=10.0), "test")
    w.resize(1200, 600)
    w.show()
    w.activateWindow()
    QTest.qWaitForWindowActive(w, 1000)
    yield w, rec
    w.timer.stop()
    w.close()


def a_map():
    grid = np.full((200, 300), -1, dtype=np.int8)
    grid[20:180, 20:280] = 0
    grid[20:180, 20] = 100
    return grid, GridInfo(0.05, 300, 200, -5.0, -2.0)


def test_button_drives_while_held_and_stops_at_release(gui):
    """The repeat is counted on the window's own tick, not on wall time: a loaded machine
    may fire a late QTimer once for several periods, so a wall-clock count would test
    the scheduler. That the timer does drive the tick is checked with a guard only."""
    w, rec = gui
    assert w.lease.focus
    assert w.timer.isActive() and w.timer.interval() == 100  # cmd_rate_hz 10
    b = w.drive.buttons[FORWARD]
    QTest.mousePress(b, Qt.LeftButton)
    assert rec.cmds == [pytest.approx((0.15, 0.0))]  # at once: half of 0.3 m/s
    for _ in range(200):  # the timer repeats the command (guard: 10 s)
        if len(rec.cmds) >= 2:
            break
        QTest.qWait(50)
    assert len(rec.cmds) >= 2
    w.timer.stop()
    n = len(rec.cmds)
    for _ in range(3):
        w.tick()
    assert len(rec.cmds) == n + 3 and all(c == pytest.approx((0.15, 0.0)) for c in rec.cmds)
    QTest.mouseRelease(b, Qt.LeftButton)
    assert rec.cmds[-1] == (0.0, 0.0) and len(rec.cmds) == n + 4
    for _ in range(3):
        w.tick()
    assert len(rec.cmds) == n + 4  # then silence


def test_keyboard_and_focus_loss(gui):
    w, rec = gui
    QTest.keyPress(w, Qt.Key_Left)
    assert rec.cmds[-1] == pytest.approx((0.0, 0.5))
    w.lease.set_focus(False)  # what changeEvent does on deactivation
    w.tick()
    assert rec.cmds[-1] == (0.0, 0.0)
    QTest.keyRelease(w, Qt.Key_Left)
    w.lease.set_focus(True)
    QTest.keyPress(w, Qt.Key_W)
    QTest.keyPress(w, Qt.Key_D)
    assert rec.cmds[-1] == pytest.approx((0.15, -0.5))
    QTest.keyRelease(w, Qt.Key_W)
    QTest.keyRelease(w, Qt.Key_D)
    assert rec.cmds[-1] == (0.0, 0.0)


def test_speed_slider_scales_the_command(gui):
    w, rec = gui
    w.drive.speed.setValue(100)
    QTest.mousePress(w.drive.buttons[FORWARD], Qt.LeftButton)
    assert rec.cmds[-1] == pytest.approx((0.3, 0.0))
    QTest.mouseRelease(w.drive.buttons[FORWARD], Qt.LeftButton)
    assert "0.30 m/s" in w.drive.speed_label.text()


def test_link_drop_stops_and_is_shown(gui):
    w, rec = gui
    QTest.mousePress(w.drive.buttons[FORWARD], Qt.LeftButton)
    rec.link.emit(False, "robot silent: no odometry for 1.2 s")
    assert rec.cmds[-1] == (0.0, 0.0)
    assert "silent" in w.status.text("link")
    assert "c00" in w.status.labels["link"].styleSheet()
    QTest.qWait(250)
    assert rec.cmds[-1] == (0.0, 0.0)
    QTest.mouseRelease(w.drive.buttons[FORWARD], Qt.LeftButton)


def test_emergency_stop_latched_until_rearm(gui):
    w, rec = gui
    QTest.mousePress(w.drive.buttons[FORWARD], Qt.LeftButton)
    QTest.mouseClick(w.drive.estop_button, Qt.LeftButton)
    assert rec.estops == [True] and rec.cmds[-1] == (0.0, 0.0)
    assert not w.drive.buttons[FORWARD].isEnabled() and w.drive.rearm_button.isEnabled()
    n = len(rec.cmds)
    QTest.keyPress(w, Qt.Key_Up)
    QTest.qWait(250)
    assert len(rec.cmds) == n
    QTest.keyRelease(w, Qt.Key_Up)
    QTest.mouseClick(w.drive.rearm_button, Qt.LeftButton)
    assert rec.estops == [True, False] and w.drive.buttons[FORWARD].isEnabled()
    assert len(rec.cmds) == n
    QTest.keyPress(w, Qt.Key_Space)
    assert rec.estops == [True, False, True]
    rec.mux_active.emit("idle")  # the mux's news do not hide the engaged e-stop
    assert w.status.text("mode") == "EMERGENCY STOP (mux: idle)"
    QTest.mouseClick(w.drive.rearm_button, Qt.LeftButton)
    assert w.status.text("mode") == "idle" and "c00" not in w.status.labels["mode"].styleSheet()


def test_map_click_sends_a_goal_in_the_map_frame(gui):
    w, rec = gui
    grid, info = a_map()
    rec.grid.emit(grid, info, None)
    rec.pose.emit(0.0, 0.0, 0.0)
    view = w.map.view
    px, py = view.to_pixel(2.0, 1.0)
    QTest.mouseClick(w.map, Qt.LeftButton, Qt.NoModifier, QPoint(int(round(px)),
                                                                  int(round(py))))
    assert len(rec.goals) == 1
    x, y, yaw = rec.goals[0]
    tol = 1.0 / view.px_per_m
    assert abs(x - 2.0) <= tol and abs(y - 1.0) <= tol
    assert yaw == pytest.approx(np.arctan2(y, x))
    rec.goal_status.emit("active (2.00, 1.00)", True, False)
    assert w.drive.cancel_button.isEnabled()
    QTest.mouseClick(w.drive.cancel_button, Qt.LeftButton)
    assert rec.cancels == 1
    rec.goal_status.emit("refused by move_base", False, True)
    assert "refused" in w.status.text("goal") and not w.drive.cancel_button.isEnabled()
    QTest.mouseClick(w.map, Qt.LeftButton, Qt.NoModifier, QPoint(2, 2))  # outside the map
    assert len(rec.goals) == 1


def test_screenshot_shows_map_robot_and_video(gui):
    w, rec = gui
    grid, info = a_map()
    rec.grid.emit(grid, info, None)
    for i in range(20):
        rec.pose.emit(-2.0 + 0.1 * i, 0.5, 0.0)
    img = np.zeros((240, 320, 3), dtype=np.uint8)
    img[:, :, 2] = 200  # red
    jpg = cv2.imdecode(cv2.imencode(".jpg", img)[1], cv2.IMREAD_COLOR)
    for i in range(5):
        rec.t = 100.0 + 0.1 * i
        rec.frame.emit(jpg, rec.t - 0.05)
    shot = w.grab().toImage()
    assert not shot.isNull()
    vid = w.video.grab().toImage()
    c = vid.pixelColor(vid.width() // 2, vid.height() // 2)
    assert c.red() > 150 and c.green() < 60
    assert "fps" in w.video.status_text() and "age 50 ms" in w.video.status_text()
    m = w.map.grab().toImage()
    # robot drawn in red where the pose is; free space white elsewhere
    px, py = w.map.view.to_pixel(-0.1, 0.5)
    c = m.pixelColor(int(px), int(py))
    assert c.red() > 150 and c.green() < 100
    px, py = w.map.view.to_pixel(3.0, -1.0)
    assert m.pixelColor(int(px), int(py)).lightness() > 240


def test_status_lines(gui):
    w, rec = gui
    rec.battery.emit("15 %, 13.10 V", True)
    rec.hazards.emit("left", "caster", True)
    rec.mux_active.emit("gesture")
    rec.gesture_state.emit("coming")
    assert w.status.text("battery").startswith("15 %")
    assert w.status.text("bumpers") == "left" and w.status.text("wheel drops") == "caster"
    assert w.status.text("mode") == "gesture"
    assert "gesture control has the robot" in w.status.text("gesture")


def test_video_without_frames_and_stale():
    t = [10.0]
    v = VideoWidget(stale_s=1.0, clock=lambda: t[0])
    assert v.status_text() == "no video"
    v.show_frame(np.zeros((10, 10, 3), dtype=np.uint8), 9.9)
    t[0] = 12.0
    assert "stale" in v.status_text()


def test_map_widget_without_map_and_rerender_on_resize():
    m = MapWidget()
    m.resize(400, 400)
    assert m.grab().toImage().pixelColor(200, 200).name() == "#3c3c46"
    grid = np.zeros((1000, 2000), dtype=np.int8)  # larger than the widget: scaled down
    m.set_map(grid, GridInfo(0.05, 2000, 1000))
    assert m.image.width() == 400 and m.view.px_per_m == pytest.approx(4.0)
    m.resize(800, 800)
    m.show()
    QApplication.processEvents()
    assert m.image.width() == 800 and m.view.px_per_m == pytest.approx(8.0)
    m.close()


def test_map_image_made_off_the_ui_thread_is_used_when_it_fits():
    m = MapWidget()
    m.resize(400, 400)
    grid = np.zeros((1000, 2000), dtype=np.int8)
    info = GridInfo(0.05, 2000, 1000)
    marked = np.full((200, 400), 7, dtype=np.uint8)  # not what grid_image would make
    m.set_map(grid, info, marked)
    assert m.image.width() == 400 and m.image.pixelColor(5, 5).red() == 7
    m.set_map(grid, info, np.full((50, 100), 7, dtype=np.uint8))  # too small: re-rendered
    assert m.image.width() == 400 and m.image.pixelColor(5, 5).red() == 254


def test_connect_dialog_checks_what_was_typed():
    d = ConnectDialog("", "/")
    d.uri_edit.setText("https://x")
    d.accept()
    assert d.result() != d.Accepted and "address" in d.error.text()
    d.uri_edit.setText("10.0.0.7")
    d.ns_edit.setText("robotA")
    d.accept()
    assert d.result() == d.Accepted
    assert d.result_uri == "http://10.0.0.7:11311/" and d.result_ns == "/robotA"
