#!/usr/bin/env python3
"""rostest: a simulated gesture drives the robot through the mux, then the operator has
the base again (gesture_drive_sim.test)."""
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from ascc_testing.waits import Latest, pose_of, wait_for
from telepresence.gesture_control import GestureControlParams
from telepresence.msg import Gesture

P = GestureControlParams()  # gesture_control runs with its defaults
PERSON_FRONT_X = 4.6 - 0.2  # worlds/gesture.yaml: the person's centre minus radius [m]
START_X = 2.0  # the robot's start in the map, facing +x
TURN = 0.4  # the operator's command: turn in place [rad/s]


class GestureDriveTest(unittest.TestCase):
    def setUp(self):
        rospy.init_node("rostest_gesture_drive_sim")
        self.odom = Latest("odom", Odometry)
        self.state = Latest("gesture_control/state", String, keep_all=True)
        self.active = Latest("velocity_mux/active", String, keep_all=True)
        self.gesture = Latest("gesture", Gesture)
        self.teleop = rospy.Publisher("teleop/cmd_vel", Twist, queue_size=1)
        self.operator_on = False
        threading.Thread(target=self.operator, daemon=True).start()

    def operator(self):
        while not rospy.core.is_shutdown_requested():  # publishers close before is_shutdown()
            if self.operator_on:
                cmd = Twist()
                cmd.angular.z = TURN
                self.teleop.publish(cmd)
            time.sleep(0.1)

    def test_gesture_moves_the_robot_and_the_operator_gets_it_back(self):
        x0, y0, yaw0 = pose_of(self.odom.wait(60.0))
        wait_for(lambda: self.state.msg is not None and self.state.msg.data == "coming",
                 90.0, "gesture_control coming (a recognized come_close)")
        self.assertEqual(self.gesture.msg.command, "come_close")
        self.operator_on = True  # the operator drives, gesture control outranks them
        wait_for(lambda: self.active.msg.data == "gesture", 5.0, "the mux on gesture")
        wait_for(lambda: self.state.msg.data == "idle", 40.0, "the approach ended")
        wait_for(lambda: self.active.msg.data == "teleop", 5.0,
                 "the mux back on teleop")
        x, y, yaw = pose_of(self.odom.msg)
        # it drove straight toward the person: the operator's turn never passed the mux
        self.assertGreater(x - x0, 1.0)
        self.assertLess(abs(yaw - yaw0), 0.1)
        self.assertLess(abs(y - y0), 0.1)
        gap = PERSON_FRONT_X - (START_X + x - x0)  # odometry: close to the truth here
        self.assertGreater(gap, P.stop_distance_m - 0.15)
        self.assertLess(gap, P.stop_distance_m + 0.15)
        self.assertEqual([m.data for m in self.active.all][-2:], ["gesture", "teleop"])
        # the operator has the base: the robot turns
        wait_for(lambda: abs(pose_of(self.odom.msg)[2] - yaw) > 0.3, 15.0,
                 "the robot turning at the operator's command")


if __name__ == "__main__":
    rostest.rosrun("telepresence", "gesture_drive_sim", GestureDriveTest, sys.argv)
