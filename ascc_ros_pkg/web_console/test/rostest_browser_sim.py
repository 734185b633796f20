#!/usr/bin/env python3
"""rostest: the console page in headless Chromium against the simulator (browser_sim.test).

launch/sim/office.launch web_console:=true runs the simulated robot, camera, mapper,
move_base, velocity mux and the console; Selenium (Debian's python3-selenium with
chromium-driver) opens the page like an operator: the video element shows frames, a
joystick drag moves the robot, closing the page stops it, a map click starts a goal.
Without chromium/chromedriver/selenium every case is skipped, naming what is missing.
``WEB_CONSOLE_SCREENSHOT=PATH`` saves the page (docs/images/web_console.png).
"""
import math
import os
import shutil
import sys
import time
import unittest

import rospy
import rostest
from actionlib_msgs.msg import GoalStatusArray
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from ascc_testing.waits import Recorder, wait_for

NODE = "/web_console"
CHROMIUM = ("chromium", "chromium-browser", "google-chrome")


def missing_browser():
    """Why the browser test cannot run here, or None."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "python3-selenium is not installed (scripts/setup.sh installs it)"
    if not any(shutil.which(c) for c in CHROMIUM):
        return "no chromium browser (apt-get install chromium; scripts/setup.sh)"
    if not shutil.which("chromedriver"):
        return "no chromedriver (apt-get install chromium-driver; scripts/setup.sh)"
    return None


def start_browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--window-size=1280,860", "--disable-background-timer-throttling"):
        opts.add_argument(arg)
    opts.binary_location = next(shutil.which(c) for c in CHROMIUM if shutil.which(c))
    return webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)


class BrowserSimTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rostest_browser_sim")
        cls.why_not = missing_browser()
        if cls.why_not:
            return
        cls.cmd = Recorder("cmd_vel", Twist)
        cls.odom = Recorder("odom", Odometry)
        cls.nav_status = Recorder("move_base/status", GoalStatusArray)
        port = None
        deadline = time.monotonic() + 60.0
        while port is None and time.monotonic() < deadline:
            port = rospy.get_param(NODE + "/bound_port", None)
            time.sleep(0.1)
        assert port, "web_console did not bind a port within 60 s"
        cls.url = "http://127.0.0.1:%d/" % port
        cls.browser = start_browser()
        cls.keeper = cls.browser.current_window_handle  # a blank tab keeps the session

    @classmethod
    def tearDownClass(cls):
        if not cls.why_not:
            cls.browser.quit()

    def setUp(self):
        if self.why_not:
            self.skipTest(self.why_not)

    def tearDown(self):
        if self.why_not:
            return
        for handle in self.browser.window_handles:
            if handle != self.keeper:
                self.browser.switch_to.window(handle)
                self.browser.close()
        self.browser.switch_to.window(self.keeper)

    def page_state(self):
        return self.js("""const s = window.consoleState;
            const t = (id) => document.getElementById(id).textContent;
            return {stick: s.stick, driving: s.driving, message: t('message'), driver: t('driver'),
                    mode: t('mode'), link: t('link'), viewport: [innerWidth, innerHeight]};""")

    # -- helpers ---------------------------------------------------------------------
    def open_page(self):
        self.browser.switch_to.new_window("tab")
        self.browser.get(self.url)
        self.js_wait("return window.consoleState && window.consoleState.hello !== null", 20.0,
                     "the page connected")
        self.js_wait("return window.consoleState.frames > 0", 20.0, "the first video frame")

    def js(self, script, *args):
        return self.browser.execute_script(script, *args)

    def js_wait(self, script, timeout_s, what):
        wait_for(lambda: self.js(script), timeout_s, what)

    def pose(self):
        msg = self.odom.last()
        return msg.pose.pose.position.x, msg.pose.pose.position.y

    def hold_joystick(self, dx, dy):
        from selenium.webdriver.common.action_chains import ActionChains
        stick = self.browser.find_element("id", "joystick")
        ActionChains(self.browser).move_to_element(stick).click_and_hold() \
            .move_by_offset(dx, dy).perform()

    def release_joystick(self):
        from selenium.webdriver.common.action_chains import ActionChains
        ActionChains(self.browser).release().perform()

    def save_page(self, path):
        """The documentation's screenshot: the whole page, taken when a fresh frame is shown
        (up to 5 s; a stale one is saved as it is, the page's own state)."""
        height = int(self.js("return document.documentElement.scrollHeight"))
        self.browser.set_window_size(1280, height + 140)  # the window's chrome is not page
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            if "STALE" not in self.js("return document.getElementById('age').textContent"):
                break
            time.sleep(0.05)
        self.browser.save_screenshot(path)

    # -- cases -----------------------------------------------------------------------
    def test_1_video_shows_frames(self):
        self.open_page()
        self.js_wait("return window.consoleState.frames >= 20", 30.0, "20 video frames")
        width = self.js("return document.getElementById('video').naturalWidth")
        self.assertGreater(width, 100, "the video element shows no image")
        # the label agrees with the age it shows: stale beyond max_frame_age_s (0.5 s)
        for _ in range(10):
            label = self.js("return document.getElementById('age').textContent")
            self.assertIn("frame age", label)
            shown_ms = float(label.split("frame age")[1].split("ms")[0])
            self.assertEqual("STALE" in label, shown_ms > 500.0, label)
            time.sleep(0.1)
        self.assertLess(float(self.js("return (performance.now() - window.consoleState.frameAt)")),
                        2000.0, "no frame in the last 2 s")

    def test_2_joystick_drag_moves_the_robot_and_closing_the_page_stops_it(self):
        self.open_page()
        wait_for(lambda: self.odom.last() is not None, 30.0, "odometry")
        start = self.pose()
        self.hold_joystick(0, -60)  # up: forward
        try:
            wait_for(lambda: math.hypot(self.pose()[0] - start[0], self.pose()[1] - start[1])
                     > 0.15, 15.0, "the robot moving 0.15 m under the joystick")
        except AssertionError as err:
            raise AssertionError("%s; page: %s" % (err, self.page_state())) from err
        moving = [m.linear.x for _, m in self.cmd.since(time.monotonic() - 0.5)]
        self.assertTrue(moving and max(moving) > 0.05, "no forward command: %s" % moving)
        t_close = time.monotonic()
        self.browser.close()  # the tab, with the joystick still held
        self.browser.switch_to.window(self.keeper)

        def first_zero():
            for t, m in self.cmd.since(t_close):
                if m.linear.x == 0.0 and m.angular.z == 0.0:
                    return t - t_close
            return None
        wait_for(lambda: first_zero() is not None, 5.0, "a zero command after closing")
        latency = first_zero()
        self.assertLess(latency, 0.3, "closing the page stopped the robot after %.3f s"
                        % latency)

    def test_3_map_click_starts_a_goal(self):
        self.open_page()
        self.js_wait("const s = window.consoleState; return s.map && s.status && s.status.pose",
                     60.0, "the map and the robot's pose on the page")
        x, y, _ = self.js("return window.consoleState.status.pose")
        goal = (x + 3.0, y)  # along the corridor: far enough not to be reached before cancel
        off = self.js("""
            const c = document.getElementById('map'), r = c.getBoundingClientRect();
            const q = window.consoleWorldToCanvas(arguments[0], arguments[1]);
            return [q[0] * r.width / c.width - r.width / 2,
                    q[1] * r.height / c.height - r.height / 2];
            """, goal[0], goal[1])
        from selenium.webdriver.common.action_chains import ActionChains
        canvas = self.browser.find_element("id", "map")
        t_click = time.monotonic()
        ActionChains(self.browser).move_to_element_with_offset(canvas, off[0], off[1]) \
            .click().perform()
        self.js_wait("const g = window.consoleState.status.goal; "
                     "return g && g.state === 'active'", 20.0, "the goal active on the page")
        g = self.js("return window.consoleState.status.goal")
        self.assertLess(math.hypot(g["x"] - goal[0], g["y"] - goal[1]), 0.1,
                        "clicked %s, goal %s" % (goal, g))
        active = [s for _, m in self.nav_status.since(t_click) for s in m.status_list
                  if s.status == 1]
        self.assertTrue(active, "move_base reported no active goal")
        wait_for(lambda: any(m.linear.x > 0.0 for _, m in self.cmd.since(t_click)), 20.0,
                 "move_base driving toward the goal")
        shot = os.environ.get("WEB_CONSOLE_SCREENSHOT")
        if shot:
            self.save_page(shot)
        self.browser.find_element("id", "cancel").click()
        self.js_wait("const g = window.consoleState.status.goal; "
                     "return g && g.state === 'cancelled'", 20.0, "the goal cancelled")


if __name__ == "__main__":
    rostest.rosrun("web_console", "browser_sim", BrowserSimTest, sys.argv)
