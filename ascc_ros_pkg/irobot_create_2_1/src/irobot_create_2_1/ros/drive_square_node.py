"""Drive a square with odometry feedback (a demo and a quick check of a real Create).

Drives `~side_m` forward, turns 90 deg left, four times, at `~speed_m_s` and
`~turn_rate_rad_s`, closing each leg on `odom`; logs the odometry at every corner and, when
`~compare_topic` (nav_msgs/Odometry, e.g. the virtual Create's ground truth) is set, the
odometry error against it. Exits when done (use required="true" in a launch file).
Parameters: ``irobot_create_2_1.square.DriveSquareParams``.
"""
import math

import rospy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from ascc_common.params import from_params
from ascc_common.pose2d import wrap_angle, yaw_of
from irobot_create_2_1.square import DriveSquareParams


class SquareDriver:
    def __init__(self):
        p = from_params(DriveSquareParams, rospy.get_param, "~")
        self.side_m = p.side_m
        self.speed = p.speed_m_s
        self.turn_rate = p.turn_rate_rad_s
        compare = p.compare_topic
        self.pose = None
        self.truth = None
        self.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=1)
        if compare:
            rospy.Subscriber(compare, Odometry, self.on_truth, queue_size=1)
        self.rate = rospy.Rate(20)

    def on_odom(self, msg):
        p = msg.pose.pose
        self.pose = (p.position.x, p.position.y, yaw_of(p.orientation))

    def on_truth(self, msg):
        p = msg.pose.pose
        self.truth = (p.position.x, p.position.y, yaw_of(p.orientation))

    def send(self, v, w):
        t = Twist()
        t.linear.x, t.angular.z = v, w
        self.cmd.publish(t)

    def leg(self):
        x0, y0, _ = self.pose
        while not rospy.is_shutdown() and math.hypot(self.pose[0] - x0,
                                                     self.pose[1] - y0) < self.side_m:
            self.send(self.speed, 0.0)
            self.rate.sleep()
        turned, last = 0.0, self.pose[2]
        while not rospy.is_shutdown() and turned < math.pi / 2:
            # slow down over the last radians so the 20 Hz loop does not overshoot
            self.send(0.0, min(self.turn_rate, max(0.1, 1.5 * (math.pi / 2 - turned))))
            self.rate.sleep()
            turned += wrap_angle(self.pose[2] - last)
            last = self.pose[2]
        self.send(0.0, 0.0)

    def run(self):
        while not rospy.is_shutdown() and self.pose is None:
            rospy.loginfo_throttle(2.0, "drive_square: waiting for odom")
            rospy.sleep(0.1)
        start = self.pose
        for corner in range(1, 5):
            self.leg()
            rospy.sleep(0.5)
            x, y, th = self.pose
            rospy.loginfo("drive_square: corner %d  odom x=%.3f m y=%.3f m yaw=%.1f deg",
                          corner, x, y, math.degrees(th))
        x, y, th = self.pose
        rospy.loginfo("drive_square: done; odometry closes the square with %.3f m and "
                      "%.1f deg", math.hypot(x - start[0], y - start[1]),
                      math.degrees(wrap_angle(th - start[2])))
        if self.truth is not None:
            tx, ty, tth = self.truth
            rospy.loginfo("drive_square: ground truth x=%.3f y=%.3f yaw=%.1f deg "
                          "(odometry error %.3f m)", tx, ty, math.degrees(tth),
                          math.hypot(x - tx, y - ty))


def main():
    rospy.init_node("drive_square")
    try:
        driver = SquareDriver()
    except ValueError as exc:
        rospy.logfatal("drive_square: bad parameter: %s", exc)
        raise SystemExit(1) from exc
    driver.run()

