#!/usr/bin/env python3
"""rostest: the real driver node against the virtual Create on a pseudo-terminal.

Checks cmd_vel -> wheel speeds, odometry against the emulator's ground truth (1 m forward
within 2 %, 90 deg turns within 2 deg), the watchdog, NaN twists, the bump rule, the
services, and that garbage on the line and an unplugged-and-replugged port do not kill it.
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist, Vector3Stamped
from nav_msgs.msg import Odometry
from std_srvs.srv import SetBool, Trigger

from irobot_create_2_1.msg import SensorPacket
from irobot_create_2_1.srv import Brake, Tank

WHEEL_BASE_M = 0.258


def yaw_of(pose):
    q = pose.orientation
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class Latest:
    """Keeps the newest message of a topic and counts them."""

    def __init__(self, topic, cls):
        self.msg = None
        self.count = 0
        self.cond = threading.Condition()
        rospy.Subscriber(topic, cls, self._cb, queue_size=50)

    def _cb(self, msg):
        with self.cond:
            self.msg = msg
            self.count += 1
            self.cond.notify_all()

    def wait_for(self, predicate, timeout_s, what):
        deadline = time.time() + timeout_s
        with self.cond:
            while not (self.msg is not None and predicate(self.msg)):
                left = deadline - time.time()
                if left <= 0 or rospy.is_shutdown():
                    raise AssertionError("timed out after %.1f s waiting for %s (last: %s)"
                                         % (timeout_s, what, self.msg))
                self.cond.wait(min(left, 0.1))
            return self.msg


class DriverTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("driver_test")
        cls.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        cls.odom = Latest("odom", Odometry)
        cls.truth = Latest("virtual_create/ground_truth", Odometry)
        cls.wheels = Latest("virtual_create/wheel_speeds", Vector3Stamped)
        cls.packet = Latest("sensorPacket", SensorPacket)
        cls.odom.wait_for(lambda m: True, 30.0, "first odom from the driver")
        cls.truth.wait_for(lambda m: True, 30.0, "ground truth from the virtual Create")

    def tearDown(self):
        self.stop()

    # --- helpers ---------------------------------------------------------------------------
    def stop(self):
        self.cmd.publish(Twist())
        self.wheels.wait_for(lambda m: m.vector.x == 0 and m.vector.y == 0, 5.0, "wheels stop")

    def drive_until(self, v, w, done, timeout_s):
        """Publish (v, w) at 20 Hz until done() is true."""
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        deadline = time.time() + timeout_s
        while not done():
            self.assertLess(time.time(), deadline, "motion did not finish in time")
            self.cmd.publish(msg)
            time.sleep(0.05)

    def settled(self, what):
        """Wait until the robot stands still and odometry has caught up; return both poses."""
        self.stop()
        time.sleep(0.3)
        n = self.odom.count
        self.odom.wait_for(lambda m: self.odom.count >= n + 5, 5.0, what)
        return self.odom.msg.pose.pose, self.truth.msg.pose.pose

    # --- tests -----------------------------------------------------------------------------
    def test_cmd_vel_sets_wheel_speeds(self):
        msg = Twist()
        msg.linear.x = 0.2
        for _ in range(3):
            self.cmd.publish(msg)
        self.wheels.wait_for(lambda m: abs(m.vector.x - 0.2) < 1e-3 and abs(m.vector.y - 0.2)
                             < 1e-3, 3.0, "wheels at 0.2 m/s")
        msg.linear.x, msg.angular.z = 0.0, 1.0
        self.cmd.publish(msg)
        half = 0.5 * WHEEL_BASE_M
        self.wheels.wait_for(lambda m: abs(m.vector.x + half) < 2e-3
                             and abs(m.vector.y - half) < 2e-3, 3.0, "spin in place")

    def test_odometry_one_metre_forward(self):
        odom0, truth0 = self.settled("odom before")
        self.drive_until(0.25, 0.0, lambda: math.hypot(
            self.truth.msg.pose.pose.position.x - truth0.position.x,
            self.truth.msg.pose.pose.position.y - truth0.position.y) >= 1.0, 15.0)
        odom1, truth1 = self.settled("odom after")
        d_truth = math.hypot(truth1.position.x - truth0.position.x,
                             truth1.position.y - truth0.position.y)
        d_odom = math.hypot(odom1.position.x - odom0.position.x,
                            odom1.position.y - odom0.position.y)
        self.assertGreater(d_truth, 0.99)
        self.assertLess(abs(d_odom - d_truth), 0.02 * d_truth,
                        "odometry %.4f m vs truth %.4f m" % (d_odom, d_truth))
        # x grows when driving forward (the old driver had it backwards)
        heading = yaw_of(odom0)
        progress = ((odom1.position.x - odom0.position.x) * math.cos(heading)
                    + (odom1.position.y - odom0.position.y) * math.sin(heading))
        self.assertGreater(progress, 0.98)

    def _turn(self, w, angle):
        odom0, truth0 = self.settled("odom before turn")
        yaw0 = yaw_of(truth0)
        turned = [0.0]
        last = [yaw0]

        def done():
            yaw = yaw_of(self.truth.msg.pose.pose)
            turned[0] += math.atan2(math.sin(yaw - last[0]), math.cos(yaw - last[0]))
            last[0] = yaw
            return abs(turned[0]) >= angle
        self.drive_until(0.0, w, done, 20.0)
        odom1, truth1 = self.settled("odom after turn")
        d_truth = math.atan2(math.sin(yaw_of(truth1) - yaw0), math.cos(yaw_of(truth1) - yaw0))
        d_odom = math.atan2(math.sin(yaw_of(odom1) - yaw_of(odom0)),
                            math.cos(yaw_of(odom1) - yaw_of(odom0)))
        self.assertGreater(abs(d_truth), math.radians(85))
        self.assertLess(abs(math.degrees(d_odom - d_truth)), 2.0,
                        "odometry turn %.2f deg vs truth %.2f deg"
                        % (math.degrees(d_odom), math.degrees(d_truth)))

    def test_odometry_turn_90_left(self):
        self._turn(0.6, math.pi / 2)

    def test_odometry_turn_90_right(self):
        self._turn(-0.6, math.pi / 2)

    def test_watchdog_stops_robot(self):
        msg = Twist()
        msg.linear.x = 0.15
        self.cmd.publish(msg)
        self.wheels.wait_for(lambda m: m.vector.x > 0.1, 3.0, "moving")
        t_last = time.time()  # no more cmd_vel from now on
        self.wheels.wait_for(lambda m: m.vector.x == 0 and m.vector.y == 0, 3.0,
                             "watchdog stop")
        elapsed = time.time() - t_last
        # cmd_timeout_s = 0.5 plus one command period (20 Hz) and transport
        self.assertLess(elapsed, 0.5 + 0.25, "watchdog took %.3f s" % elapsed)
        self.assertGreater(elapsed, 0.3, "stopped before the timeout: %.3f s" % elapsed)

    def test_nan_twist_stops_robot(self):
        msg = Twist()
        msg.linear.x = 0.2
        self.cmd.publish(msg)
        self.wheels.wait_for(lambda m: m.vector.x > 0.1, 3.0, "moving")
        bad = Twist()
        bad.linear.x = float("nan")
        for _ in range(5):
            self.cmd.publish(bad)
            time.sleep(0.02)
        self.wheels.wait_for(lambda m: m.vector.x == 0 and m.vector.y == 0, 0.4,
                             "stop after a NaN twist")

    def test_saturated_twist_keeps_turn_ratio(self):
        msg = Twist()
        msg.linear.x, msg.angular.z = 1.0, 2.0
        self.cmd.publish(msg)
        m = self.wheels.wait_for(lambda m: m.vector.y > 0.45, 3.0, "saturated drive")
        self.assertAlmostEqual(m.vector.y, 0.5, places=3)
        v = 0.5 * (m.vector.x + m.vector.y)
        w = (m.vector.y - m.vector.x) / WHEEL_BASE_M
        self.assertAlmostEqual(w / v, 2.0, delta=0.05)

    def test_bump_stops_forward_motion(self):
        set_bump = rospy.ServiceProxy("virtual_create/set_bump", SetBool)
        set_bump.wait_for_service(10.0)
        try:
            set_bump(True)
            self.packet.wait_for(lambda m: m.bumpLeft and m.bumpRight, 3.0, "bump reported")
            msg = Twist()
            msg.linear.x = 0.2
            for _ in range(10):
                self.cmd.publish(msg)
                time.sleep(0.05)
            self.assertEqual((self.wheels.msg.vector.x, self.wheels.msg.vector.y), (0.0, 0.0))
            msg.linear.x = -0.1  # backing away is allowed
            self.cmd.publish(msg)
            self.wheels.wait_for(lambda m: m.vector.x < -0.05, 3.0, "reverse while bumped")
        finally:
            set_bump(False)

    def test_services_tank_and_brake(self):
        tank = rospy.ServiceProxy("tank", Tank)
        brake = rospy.ServiceProxy("brake", Brake)
        tank.wait_for_service(10.0)
        self.assertTrue(tank(False, -100, 150).success)
        self.wheels.wait_for(lambda m: abs(m.vector.x + 0.1) < 1e-3
                             and abs(m.vector.y - 0.15) < 1e-3, 2.0, "tank speeds")
        self.assertTrue(brake(True).success)
        self.wheels.wait_for(lambda m: m.vector.x == 0 and m.vector.y == 0, 1.0, "brake")

    def test_z_garbage_and_reconnect_do_not_kill_the_driver(self):
        garbage = rospy.ServiceProxy("virtual_create/inject_garbage", Trigger)
        close = rospy.ServiceProxy("virtual_create/close_link", Trigger)
        garbage.wait_for_service(10.0)
        odom_before, truth_before = self.settled("odom before garbage")
        for _ in range(10):
            self.assertTrue(garbage().success)
            time.sleep(0.05)
        n = self.odom.count
        self.odom.wait_for(lambda m: self.odom.count > n + 20, 5.0, "odom after garbage")
        odom_after, truth_after = self.settled("odom after garbage")
        # garbage must not have been integrated into odometry
        self.assertAlmostEqual(odom_after.position.x, odom_before.position.x, delta=0.005)
        self.assertAlmostEqual(odom_after.position.y, odom_before.position.y, delta=0.005)
        self.assertTrue(close().success)
        time.sleep(0.5)
        n = self.packet.count
        self.packet.wait_for(lambda m: self.packet.count > n + 10, 20.0,
                             "sensor packets after the port came back")
        msg = Twist()
        msg.linear.x = 0.1
        self.cmd.publish(msg)
        self.wheels.wait_for(lambda m: abs(m.vector.x - 0.1) < 1e-3, 5.0,
                             "driving after the reconnect")


if __name__ == "__main__":
    rostest.rosrun("irobot_create_2_1", "driver_against_virtual_create", DriverTest)
