#!/usr/bin/env python3
"""rostest: the operator GUI offscreen against the simulator (operator_gui.test).

The test process is the GUI: ``operator_gui``'s own window and ROS adapter
(``make_window``), driven through its widgets with QTest, on real topics, TF and the
move_base action of launch/sim/telepresence.launch; the effects are checked on the
simulator's ground truth."""
import math
import os
import subprocess
import sys
import time
import unittest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np  # noqa: E402
import rospy  # noqa: E402
import rostest  # noqa: E402
from actionlib_msgs.msg import GoalStatusArray  # noqa: E402
from geometry_msgs.msg import Twist  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from PyQt5.QtCore import QPoint, Qt  # noqa: E402
from PyQt5.QtTest import QTest  # noqa: E402
from PyQt5.QtWidgets import QApplication  # noqa: E402
from std_msgs.msg import Bool, String  # noqa: E402

from ascc_testing.waits import Latest, pose_of  # noqa: E402
from telepresence.ros.operator_gui_node import make_window  # noqa: E402
from telepresence.teleop import FORWARD  # noqa: E402

STOP_WITHIN_S = 0.3  # the lease: stopped this soon after the operator lets go
STOPPED_MPS = 0.01


def qt_wait_for(condition, timeout_s, what):
    """Poll while the Qt loop runs (the adapter's signals are delivered in it)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if rospy.is_shutdown() or time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s" % (timeout_s, what))
        QTest.qWait(20)


def grey(qimage):
    """QImage -> numpy grey (height, width)."""
    img = qimage.convertToFormat(qimage.Format_Grayscale8)
    ptr = img.constBits()
    ptr.setsize(img.byteCount())
    return np.frombuffer(ptr, np.uint8).reshape(img.height(), img.bytesPerLine())[
        :, :img.width()].copy()


class OperatorGuiTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("operator_gui", disable_signals=True)
        cls.app = QApplication.instance() or QApplication(sys.argv[:1])
        cls.truth = Latest("ground_truth/asccbot/odom", Odometry, keep_all=True)
        cls.estop = Latest("e_stop", Bool, keep_all=True)
        cls.active = Latest("velocity_mux/active", String, keep_all=True)
        cls.status = Latest("move_base/status", GoalStatusArray, keep_all=True)
        cls.adapter, cls.window, cls.watch = make_window(os.environ["ROS_MASTER_URI"], "test")
        QTest.qWaitForWindowActive(cls.window, 5000)
        cls.truth.wait(60.0)

    @classmethod
    def tearDownClass(cls):
        cls.watch.stop()
        cls.window.close()

    def speed(self):
        t = self.truth.msg.twist.twist
        return math.hypot(t.linear.x, t.linear.y)

    def test_1_map_and_video_shown_and_screenshot(self):
        w = self.window
        qt_wait_for(lambda: w.map.image is not None, 60.0,
                    "the map in the GUI (maps received: %d)" % self.adapter.counts["map"])
        qt_wait_for(lambda: len(w.video.stats.ages) >= 10, 30.0, "10 video frames shown")
        qt_wait_for(lambda: w.map.robot is not None, 20.0, "the robot's pose on the map")
        qt_wait_for(lambda: w.status.text("link") == "up", 10.0, "link up")
        QTest.qWait(500)
        video = grey(w.video.grab().toImage())
        self.assertGreater(video.std(), 20.0, "the video area is blank")
        left, top, width, height = (int(v) for v in w.map.view.rect())
        area = grey(w.map.grab().toImage())[top:top + height, left:left + width]
        self.assertGreater((area >= 250).mean(), 0.005, "no free space drawn on the map")
        self.assertGreater((area <= 40).mean(), 0.001, "no walls drawn on the map")
        # frames keep coming; their age at display (the simulated camera lags on a busy
        # machine, so only that it is measured and below the test's patience)
        self.assertGreaterEqual(len(w.video.stats.ages), 10)
        ages = sorted(w.video.stats.ages)
        rospy.loginfo("operator_gui test: %d frames shown, age median %.3f s, max %.3f s",
                      len(ages), ages[len(ages) // 2], ages[-1])
        self.assertTrue(0.0 <= ages[len(ages) // 2] < 5.0, ages)
        self.assertRegex(w.video.status_text(), r"fps, age \d+ ms|video stale")
        # the robot (TF map -> base_link) is drawn where the map is free space (within
        # 0.3 m: the laser does not see the robot's own cell)
        rx, ry, _ = w.map.robot
        ix, iy = w.map.info.world_to_cell(rx, ry)
        r = int(round(0.3 / w.map.info.resolution))
        near = w.map.grid[max(0, iy - r):iy + r + 1, max(0, ix - r):ix + r + 1]
        self.assertTrue(((near >= 0) & (near <= 50)).any(), near)
        px, py = w.map.view.to_pixel(rx, ry)
        c = w.map.grab().toImage().pixelColor(int(px), int(py))
        self.assertGreater(c.red(), 150)
        self.assertLess(c.green(), 100)

    def test_2_teleop_button_moves_the_robot_and_release_stops_it(self):
        w = self.window
        qt_wait_for(lambda: w.lease.focus and w.lease.link, 10.0, "focus and link")
        x0, y0, yaw0 = pose_of(self.truth.msg)
        b = w.drive.buttons[FORWARD]
        QTest.mousePress(b, Qt.LeftButton)
        qt_wait_for(lambda: self.speed() > 0.1, 5.0, "the robot moving forward")
        self.assertEqual(self.active.msg.data, "teleop")
        QTest.qWait(1500)
        x1, y1, _ = pose_of(self.truth.msg)
        moved = (x1 - x0) * math.cos(yaw0) + (y1 - y0) * math.sin(yaw0)
        self.assertGreater(moved, 0.15)
        QTest.mouseRelease(b, Qt.LeftButton)
        t0 = time.monotonic()
        qt_wait_for(lambda: self.speed() < STOPPED_MPS, 2.0, "the robot stopped")
        took = time.monotonic() - t0
        rospy.loginfo("operator_gui test: stopped %.3f s after release", took)
        self.assertLess(took, STOP_WITHIN_S)
        QTest.qWait(800)  # nothing from the GUI any more: the mux goes idle
        self.assertEqual(self.active.msg.data, "idle")
        self.assertLess(self.speed(), STOPPED_MPS)

    def test_3_emergency_stop_latched_until_rearmed(self):
        w = self.window
        QTest.mouseClick(w.drive.estop_button, Qt.LeftButton)
        qt_wait_for(lambda: self.estop.msg is not None and self.estop.msg.data, 5.0,
                    "e_stop true")
        x0, y0, _ = pose_of(self.truth.msg)
        QTest.keyPress(w, Qt.Key_Up)  # ignored while stopped
        QTest.qWait(1000)
        QTest.keyRelease(w, Qt.Key_Up)
        x1, y1, _ = pose_of(self.truth.msg)
        self.assertLess(math.hypot(x1 - x0, y1 - y0), 0.02)
        self.assertTrue(self.estop.msg.data)  # latched
        QTest.mouseClick(w.drive.rearm_button, Qt.LeftButton)
        qt_wait_for(lambda: not self.estop.msg.data, 5.0, "e_stop false after re-arm")
        QTest.keyPress(w, Qt.Key_Up)
        qt_wait_for(lambda: self.speed() > 0.1, 5.0, "driving again after re-arm")
        QTest.keyRelease(w, Qt.Key_Up)
        qt_wait_for(lambda: self.speed() < STOPPED_MPS, 2.0, "stopped")

    def test_4_map_click_starts_a_goal_and_cancel_ends_it(self):
        w = self.window
        x, y, _ = w.map.robot  # map frame (SLAM's: x along the start heading)
        gx, gy = x + 0.8, y  # ahead in the corridor (the laser does not see behind)
        ix, iy = w.map.info.world_to_cell(gx, gy)
        self.assertTrue(0 <= w.map.grid[iy, ix] <= 50, "the goal is not on free space")
        px, py = w.map.view.to_pixel(gx, gy)
        n = self.status.count
        QTest.mouseClick(w.map, Qt.LeftButton, Qt.NoModifier,
                         QPoint(int(round(float(px))), int(round(float(py)))))

        def goal_active():
            msg = self.status.msg
            return self.status.count > n and any(s.status == 1 for s in msg.status_list)
        qt_wait_for(goal_active, 10.0, "move_base's goal active")
        qt_wait_for(lambda: w.drive.cancel_button.isEnabled(), 5.0, "cancel enabled")
        qt_wait_for(lambda: "active" in w.status.text("goal"), 5.0, "goal shown active")
        goal = self.adapter.goal_handle.comm_state_machine.action_goal.goal.target_pose
        self.assertEqual(goal.header.frame_id, "map")
        self.assertLess(math.hypot(goal.pose.position.x - gx, goal.pose.position.y - gy),
                        2.0 / w.map.view.px_per_m + 0.05)
        qt_wait_for(lambda: self.active.msg.data == "navigation", 15.0,
                    "move_base driving (mux on navigation)")
        qt_wait_for(lambda: w.status.text("mode") == "navigation", 5.0, "mode shown")
        QTest.qWait(1500)
        path = rospy.get_param("~screenshot", "")
        if path:  # the README's picture: driven, path, goal active
            w.grab().save(path)
        QTest.mouseClick(w.drive.cancel_button, Qt.LeftButton)
        qt_wait_for(lambda: "cancel" in w.status.text("goal"), 10.0, "goal cancelled")
        qt_wait_for(lambda: self.speed() < STOPPED_MPS, 3.0, "stopped after cancel")

    def test_5_goal_without_navigator_is_shown_as_a_fault(self):
        w = self.window
        subprocess.run(["rosnode", "kill", "move_base"], check=True, timeout=30,
                       stdout=subprocess.DEVNULL)
        qt_wait_for(lambda: not self.adapter.goal_client.wait_for_server(rospy.Duration(0.01)),
                    20.0, "move_base gone")
        x, y, _ = w.map.robot
        px, py = w.map.view.to_pixel(x + 0.5, y)
        t0 = time.monotonic()
        QTest.mouseClick(w.map, Qt.LeftButton, Qt.NoModifier,
                         QPoint(int(round(float(px))), int(round(float(py)))))
        self.assertLess(time.monotonic() - t0, 1.0)  # the UI did not hang on it
        QTest.qWait(200)
        self.assertIn("no move_base", w.status.text("goal"))
        self.assertIn("c00", w.status.labels["goal"].styleSheet())
        self.assertFalse(w.drive.cancel_button.isEnabled())

    def test_6_silent_robot_is_shown_and_does_not_take_commands(self):
        w = self.window
        teleop = Latest("teleop/cmd_vel", Twist)
        subprocess.run(["rosnode", "kill", "driver"], check=True, timeout=30,
                       stdout=subprocess.DEVNULL)  # no odometry from here on
        qt_wait_for(lambda: "silent" in w.status.text("link"), 10.0, "the link shown down")
        self.assertIn("c00", w.status.labels["link"].styleSheet())
        qt_wait_for(lambda: teleop.sub.get_num_connections() >= 1, 10.0,
                    "the test listening to the GUI's teleop/cmd_vel")
        QTest.mousePress(w.drive.buttons[FORWARD], Qt.LeftButton)
        QTest.qWait(600)
        QTest.mouseRelease(w.drive.buttons[FORWARD], Qt.LeftButton)
        self.assertEqual(teleop.count, 0, "teleop commands published to a silent robot")


if __name__ == "__main__":
    rostest.rosrun("telepresence", "operator_gui", OperatorGuiTest, sys.argv)
