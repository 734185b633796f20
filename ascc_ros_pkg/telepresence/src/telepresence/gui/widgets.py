"""The operator GUI's widgets: video, live map, drive buttons, status, robot dialog."""
from __future__ import annotations

import math
import time
from typing import Optional, Tuple

import cv2
import numpy as np
from PyQt5.QtCore import QPointF, QRectF, Qt, pyqtSignal
from PyQt5.QtGui import QColor, QFont, QImage, QPainter, QPen, QPolygonF
from PyQt5.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QFormLayout,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)

from ascc_common.grid import GridInfo
from telepresence.teleop import (
    BACKWARD,
    FORWARD,
    LEFT,
    RIGHT,
    FrameStats,
    MapView,
    PathTrail,
    grid_image,
    master_uri,
    namespace,
)


def _qimage_grey(img: np.ndarray) -> QImage:
    img = np.ascontiguousarray(img)
    h, w = img.shape
    return QImage(img.data, w, h, img.strides[0], QImage.Format_Grayscale8).copy()


def _qimage_bgr(img: np.ndarray) -> QImage:
    rgb = np.ascontiguousarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB))
    h, w, _ = rgb.shape
    return QImage(rgb.data, w, h, rgb.strides[0], QImage.Format_RGB888).copy()


class VideoWidget(QWidget):
    """The robot's camera: the newest decoded frame fitted to the widget, its frame rate
    and age (display time - stamp) written on it; 'no video' / 'stale' when so."""

    def __init__(self, stale_s: float = 1.0, clock=time.time, parent=None):
        super().__init__(parent)
        self.setMinimumSize(320, 180)
        self.stale_s = stale_s
        self.clock = clock
        self.stats = FrameStats()
        self.image: Optional[QImage] = None
        self.last_age: Optional[float] = None

    def show_frame(self, bgr: np.ndarray, stamp_s: float) -> float:
        """Show a decoded frame stamped ``stamp_s`` (in ``clock``'s time); returns its age
        at display [s] (the repaint is immediate: glass-to-glass up to the screen)."""
        self.image = _qimage_bgr(bgr)
        self.repaint()
        now = self.clock()
        self.last_age = self.stats.add(stamp_s, now)
        return self.last_age

    def status_text(self) -> str:
        now = self.clock()
        age = self.stats.age(now)
        if age is None:
            return "no video"
        text = "%.1f fps, age %.0f ms" % (self.stats.fps(now), 1000.0 * (self.last_age or 0.0))
        if age > self.stale_s:
            text = "video stale: last frame %.1f s ago" % age
        return text

    def paintEvent(self, _event):
        p = QPainter(self)
        p.fillRect(self.rect(), QColor(20, 20, 20))
        if self.image is not None:
            iw, ih = self.image.width(), self.image.height()
            s = min(self.width() / iw, self.height() / ih)
            target = QRectF((self.width() - iw * s) / 2, (self.height() - ih * s) / 2,
                            iw * s, ih * s)
            p.drawImage(target, self.image)
        p.setPen(QColor(255, 255, 0))
        p.setFont(QFont("Sans", 10))
        p.drawText(8, 18, self.status_text())
        p.end()


class MapWidget(QWidget):
    """The live 2D map (north up, fitted), the robot's pose and path, the goal; a left
    click inside the map emits ``goal_clicked(x, y)`` in the map frame [m]."""

    goal_clicked = pyqtSignal(float, float)
    side_changed = pyqtSignal(int)  # side_px after a resize (the adapter renders for it)

    def __init__(self, path_step_m: float = 0.05, path_points: int = 2000, parent=None):
        super().__init__(parent)
        self.setMinimumSize(320, 320)
        self.grid: Optional[np.ndarray] = None
        self.info: Optional[GridInfo] = None
        self.image: Optional[QImage] = None
        self.view: Optional[MapView] = None
        self.robot: Optional[Tuple[float, float, float]] = None
        self.goal: Optional[Tuple[float, float, float]] = None
        self.trail = PathTrail(path_step_m, path_points)
        self.last_render_s = 0.0

    def side_px(self) -> int:
        """The longest side [device px] a map image needs for this widget."""
        return max(64, int(max(self.width(), self.height()) * self.devicePixelRatioF()))

    def set_map(self, grid: np.ndarray, info: GridInfo, image: np.ndarray = None) -> None:
        """A new map; ``image``: its ``grid_image`` made off the UI thread (the node's
        adapter makes it for ``side_px``), used if it still fits the widget."""
        info.check_axis_aligned()
        self.grid, self.info = grid, info
        self._render(image)
        self.update()

    def _render(self, image: np.ndarray = None) -> None:
        if self.grid is None:
            return
        t0 = time.perf_counter()
        side = self.side_px()
        if image is None or not (max(image.shape) >= min(side, max(self.grid.shape))
                                 and max(image.shape) <= 2 * side):
            image, _ = grid_image(self.grid, side)
        self.image = _qimage_grey(image)
        self.view = MapView(self.info, self.width(), self.height())
        self.last_render_s = time.perf_counter() - t0

    def resizeEvent(self, event):
        self._render()
        self.side_changed.emit(self.side_px())
        super().resizeEvent(event)

    def set_robot(self, x: float, y: float, yaw: float) -> None:
        self.robot = (x, y, yaw)
        self.trail.add(x, y)
        self.update()

    def set_goal(self, goal: Optional[Tuple[float, float, float]]) -> None:
        self.goal = goal
        self.update()

    def mousePressEvent(self, event):
        if event.button() != Qt.LeftButton or self.view is None:
            return
        px, py = event.pos().x(), event.pos().y()
        if self.view.inside(px, py):
            self.goal_clicked.emit(*self.view.to_map(px, py))

    def paintEvent(self, _event):
        p = QPainter(self)
        p.fillRect(self.rect(), QColor(60, 60, 70))
        if self.image is None or self.view is None:
            p.setPen(QColor(255, 255, 255))
            p.drawText(self.rect(), Qt.AlignCenter, "no map")
            p.end()
            return
        p.setRenderHint(QPainter.Antialiasing)
        p.drawImage(QRectF(*self.view.rect()), self.image)
        if len(self.trail.points) >= 2:
            xs, ys = self.view.to_pixel(*np.array(self.trail.points).T)
            p.setPen(QPen(QColor(0, 120, 255), 2))
            p.drawPolyline(QPolygonF([QPointF(a, b) for a, b in zip(xs, ys)]))
        if self.goal is not None:
            gx, gy = self.view.to_pixel(self.goal[0], self.goal[1])
            p.setPen(QPen(QColor(0, 170, 0), 3))
            p.drawLine(QPointF(gx - 7, gy - 7), QPointF(gx + 7, gy + 7))
            p.drawLine(QPointF(gx - 7, gy + 7), QPointF(gx + 7, gy - 7))
        if self.robot is not None:
            x, y, yaw = self.robot
            r = max(6.0, 0.17 * self.view.px_per_m)  # the Create's radius, at least 6 px
            pts = []
            for a, d in ((0.0, 1.6), (2.5, 1.0), (-2.5, 1.0)):
                px, py = self.view.to_pixel(x + d * r / self.view.px_per_m * math.cos(yaw + a),
                                            y + d * r / self.view.px_per_m * math.sin(yaw + a))
                pts.append(QPointF(float(px), float(py)))
            p.setPen(QPen(QColor(200, 0, 0), 2))
            p.setBrush(QColor(255, 60, 60))
            p.drawPolygon(QPolygonF(pts))
        p.end()


class DrivePanel(QWidget):
    """Drive buttons (held = drive), speed slider, emergency stop and re-arm, goal cancel."""

    pressed = pyqtSignal(str)
    released = pyqtSignal(str)
    speed_changed = pyqtSignal(float)
    estop = pyqtSignal()
    rearm = pyqtSignal()
    cancel_goal = pyqtSignal()

    def __init__(self, parent=None):
        super().__init__(parent)
        grid = QGridLayout()
        self.buttons = {}
        for d, label, r, c in ((FORWARD, "Forward (Up/W)", 0, 1), (LEFT, "Left (A)", 1, 0),
                               (RIGHT, "Right (D)", 1, 2), (BACKWARD, "Back (Down/S)", 2, 1)):
            b = QPushButton(label)
            b.setFocusPolicy(Qt.NoFocus)  # keys stay with the window
            b.pressed.connect(lambda d=d: self.pressed.emit(d))
            b.released.connect(lambda d=d: self.released.emit(d))
            grid.addWidget(b, r, c)
            self.buttons[d] = b
        self.speed = QSlider(Qt.Horizontal)
        self.speed.setRange(0, 100)
        self.speed.setValue(50)
        self.speed.setFocusPolicy(Qt.NoFocus)
        self.speed.valueChanged.connect(lambda v: self.speed_changed.emit(v / 100.0))
        self.speed_label = QLabel()
        self.estop_button = QPushButton("EMERGENCY STOP (Space)")
        self.estop_button.setFocusPolicy(Qt.NoFocus)
        self.estop_button.setStyleSheet("background-color: #d00; color: white; font-weight: bold")
        self.estop_button.clicked.connect(self.estop.emit)
        self.rearm_button = QPushButton("Re-arm")
        self.rearm_button.setFocusPolicy(Qt.NoFocus)
        self.rearm_button.setEnabled(False)
        self.rearm_button.clicked.connect(self.rearm.emit)
        self.cancel_button = QPushButton("Cancel goal")
        self.cancel_button.setFocusPolicy(Qt.NoFocus)
        self.cancel_button.setEnabled(False)
        self.cancel_button.clicked.connect(self.cancel_goal.emit)
        box = QVBoxLayout(self)
        box.addLayout(grid)
        row = QHBoxLayout()
        row.addWidget(QLabel("speed"))
        row.addWidget(self.speed)
        row.addWidget(self.speed_label)
        box.addLayout(row)
        box.addWidget(self.estop_button)
        row = QHBoxLayout()
        row.addWidget(self.rearm_button)
        row.addWidget(self.cancel_button)
        box.addLayout(row)

    def show_speed(self, linear_mps: float, angular_radps: float) -> None:
        self.speed_label.setText("%.2f m/s, %.2f rad/s" % (linear_mps, angular_radps))

    def show_estop(self, engaged: bool) -> None:
        self.rearm_button.setEnabled(engaged)
        for b in self.buttons.values():
            b.setEnabled(not engaged)


class StatusPanel(QWidget):
    """Robot status lines: link, battery, bumpers, wheel drops, mux mode, gesture control,
    goal. A fault is shown in red."""

    FIELDS = ("link", "battery", "bumpers", "wheel drops", "mode", "gesture", "goal")

    def __init__(self, parent=None):
        super().__init__(parent)
        form = QFormLayout(self)
        self.labels = {}
        for name in self.FIELDS:
            label = QLabel("-")
            label.setTextInteractionFlags(Qt.TextSelectableByMouse)
            form.addRow(name + ":", label)
            self.labels[name] = label

    def show(self, name: str, text: str, fault: bool = False) -> None:  # noqa: A003
        label = self.labels[name]
        label.setText(text)
        label.setStyleSheet("color: #c00; font-weight: bold" if fault else "")

    def text(self, name: str) -> str:
        return self.labels[name].text()


class ConnectDialog(QDialog):
    """Pick the robot: its master (IP, host[:port] or URI) and namespace. ``result_uri``
    and ``result_ns`` hold the checked values after OK; a bad entry is named in the
    dialog, which stays open."""

    def __init__(self, uri: str = "", ns: str = "/", parent=None):
        super().__init__(parent)
        self.setWindowTitle("ASCCbot telepresence: pick the robot")
        self.uri_edit = QLineEdit(uri)
        self.uri_edit.setPlaceholderText("192.168.1.20 or host:11311 or http://host:11311")
        self.ns_edit = QLineEdit(ns)
        self.error = QLabel("")
        self.error.setStyleSheet("color: #c00")
        form = QFormLayout(self)
        form.addRow("robot (master)", self.uri_edit)
        form.addRow("namespace", self.ns_edit)
        form.addRow(self.error)
        buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form.addRow(buttons)
        self.result_uri = ""
        self.result_ns = "/"

    def accept(self):
        try:
            self.result_uri = master_uri(self.uri_edit.text())
            self.result_ns = namespace(self.ns_edit.text())
        except ValueError as exc:
            self.error.setText(str(exc))
            return
        super().accept()
