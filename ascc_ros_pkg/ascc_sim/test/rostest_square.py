#!/usr/bin/env python3
"""rostest: drive a 1 m square through cmd_vel (closed loop on the driver's odom) in the
office world; the driver's odometry must end where the ground truth says, within the
odometry errors the simulator is configured with (square.test) or, with the encoder
errors off (square_noiseless.test), within the Create's whole-mm/whole-degree reports.

The robot comes to rest between manoeuvres (4 straight sides, 4 quarter turns on the
spot), so every comparison of odom with the truth is made at rest, where neither depends
on when a message was sampled: the bounds below come from the encoder model and the
Create's integer reports alone, not from timing slack.

The Create reports distance truncated to whole mm and angle truncated to whole degrees
and carries the remainders (irobot_create_2_1.virtual_create). All turns are
counter-clockwise, so the driver's heading lags the truth by the unreported remainder:
0 <= truth - odom < 1 deg, and each side's odom length is off by less than 1 mm (the
remainder before minus the one after). A side driven while the odometry's heading lags
by r comes out turned by r against the truth, up to 17 mm per metre: the test predicts
the final position error from the lags it measures and checks the rest against the
configured encoder errors (3 sigma) and the mm remainders; with the encoder errors off
that leaves the remainders only (4 mm)."""
import math
import sys
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry

from ascc_common.pose2d import compose, wrap_angle
from ascc_testing.waits import Latest, pose_of, wait_for

WHEEL_BASE_M = 0.258
MM = 0.001  # the Create's distance quantum [m]
DEG = math.radians(1.0)  # the Create's angle quantum [rad]
EPS = 1e-6  # float arithmetic of the integrations [m, rad]
# At rest, the odom must be unchanged over this long of frames measured after the truth
# showed the robot at rest [s of simulated time]; odom comes at 30 Hz (frames at 66 Hz);
# even the slow end of a turn (0.1 rad/s) reports a new degree every 0.17 s.
SETTLE_S = 0.5


def rotate(v, a):
    c, s = math.cos(a), math.sin(a)
    return c * v[0] - s * v[1], s * v[0] + c * v[1]


class SquareTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("square_test")
        robot = rospy.get_param("~robot", "asccbot")
        cls.side_m = float(rospy.get_param("~side_m", 1.0))
        cls.odom = Latest("odom", Odometry, keep_all=True)
        cls.truth = Latest("ground_truth/%s/odom" % robot, Odometry)
        cls.start = Latest("ground_truth/%s/start_pose" % robot, PoseStamped)
        cls.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        cls.scale_sigma = float(rospy.get_param("/simulator/robot/encoder_scale_sigma"))
        cls.noise_k = float(rospy.get_param("/simulator/robot/encoder_noise_m_per_sqrt_m"))
        cls.noisy = cls.scale_sigma > 0 or cls.noise_k > 0

    def drive(self, condition, v, w, timeout_s=120.0):
        rate = rospy.Rate(20.0)  # simulated time
        deadline = rospy.get_time() + timeout_s
        while not condition():
            self.assertLess(rospy.get_time(), deadline, "manoeuvre did not finish")
            t = Twist()
            t.linear.x, t.angular.z = v, w
            self.cmd.publish(t)
            rate.sleep()

    def rest(self):
        """Stop; wait until the truth shows the robot at rest and the driver's odom has
        not changed over SETTLE_S of frames measured after that (a driver catching up on
        a backlog may stamp a frame later than it was measured, but a moving robot's
        odom would change within SETTLE_S). Returns (odom pose in its frame, odom pose in
        map, true pose, index of that odom message in self.odom.all)."""
        self.cmd.publish(Twist())
        asked = rospy.get_time()
        wait_for(lambda: self.truth.msg.header.stamp.to_sec() > asked
                 and self.truth.msg.twist.twist.linear.x == 0.0
                 and self.truth.msg.twist.twist.angular.z == 0.0, 60.0,
                 "the robot to stand still (ground truth)")
        still = self.truth.msg.header.stamp.to_sec()
        found = []

        def settled():
            msgs = self.odom.all
            n = len(msgs) - 1
            last = msgs[n]
            t_last = last.header.stamp.to_sec()
            if t_last <= still + SETTLE_S:
                return False
            pose = pose_of(last)
            for m in reversed(msgs[:n]):
                if pose_of(m) != pose:
                    return False
                if m.header.stamp.to_sec() <= t_last - SETTLE_S:
                    found.append(n)
                    return True
            return False

        wait_for(settled, 60.0, "odom unchanged for %.1f s after the robot stopped"
                 % SETTLE_S)
        odom = pose_of(self.odom.all[found[0]])
        return odom, compose(self.start_pose, odom), pose_of(self.truth.msg), found[0]

    def travelled(self, x0, y0):
        x, y, _ = pose_of(self.odom.msg)
        return math.hypot(x - x0, y - y0)

    def turned(self, yaw0):
        return wrap_angle(pose_of(self.odom.msg)[2] - yaw0)

    def lag(self, rest):
        """How far the odometry's heading (in map) lags the true heading [rad]."""
        return wrap_angle(rest[2][2] - rest[1][2])

    def side_heading(self, first, last, truth_yaw):
        """Distance-weighted mean of the odometry's heading in map over odom messages
        first..last (a side), as an offset from truth_yaw; and the spread of the
        odometry's heading along the side (both [rad])."""
        msgs = self.odom.all[first:last + 1]
        offs, weights = [], []
        for a, b in zip(msgs, msgs[1:]):
            pa, pb = pose_of(a), pose_of(b)
            yaw = wrap_angle(self.start_pose[2] + pa[2] + 0.5 * wrap_angle(pb[2] - pa[2]))
            offs.append(wrap_angle(yaw - truth_yaw))
            weights.append(math.hypot(pb[0] - pa[0], pb[1] - pa[1]))
        total = sum(weights)
        mean = sum(o * w for o, w in zip(offs, weights)) / total if total else 0.0
        return mean, (max(offs) - min(offs)) if offs else 0.0

    def test_square(self):
        self.odom.wait(90.0)
        self.truth.wait(90.0)
        self.start.wait(30.0)
        self.start_pose = pose_of(self.start.msg)
        wait_for(lambda: self.cmd.get_num_connections() > 0, 30.0, "the driver on cmd_vel")
        s, k, b = self.scale_sigma, self.noise_k, WHEEL_BASE_M
        turn_travel = (b / 2) * (math.pi / 2)  # each wheel's travel in a quarter turn
        rests = [self.rest()]
        for _ in range(4):
            x0, y0, _ = rests[-1][0]
            self.drive(lambda a=x0, c=y0: self.travelled(a, c) >= self.side_m - 0.1, 0.2, 0.0)
            self.drive(lambda a=x0, c=y0: self.travelled(a, c) >= self.side_m, 0.05, 0.0)
            rests.append(self.rest())
            yaw0 = rests[-1][0][2]
            self.drive(lambda a=yaw0: self.turned(a) >= math.pi / 2 - 0.2, 0.0, 0.5)
            self.drive(lambda a=yaw0: self.turned(a) >= math.pi / 2 - 0.005, 0.0, 0.1)  # slow
            rests.append(self.rest())
        for i, r in enumerate(rests):
            rospy.loginfo("square: rest %d: odom in map %s truth %s lag %.3f deg", i, r[1],
                          r[2], math.degrees(self.lag(r)))

        # The simulated robot drives straight sides and turns on the spot (its wheels
        # do what they are told; the encoder errors are in what the Create measures):
        # the true heading does not change on a side, the true position not in a turn.
        for i in range(4):
            (_, _, t0, _), (_, _, t1, _), (_, _, t2, _) = rests[2 * i:2 * i + 3]
            self.assertLess(abs(wrap_angle(t1[2] - t0[2])), EPS, "side %d: true heading" % i)
            self.assertLess(math.hypot(t2[0] - t1[0], t2[1] - t1[1]), EPS,
                            "turn %d: true position" % i)

        # Each side. Length: the odometry's path length along the side = the true
        # length (the two wheels' scale errors averaged: sigma s/sqrt(2) per metre;
        # travel noise k*sqrt(d)/sqrt(2)) + the mm remainders (the one unreported before
        # the side minus the one after: < 1 mm). Direction: the odometry integrates each
        # increment along its own heading, which lags the true one; turned by the mean
        # lag along the side, the odom chord must lie along the true heading (with the
        # encoder errors off the lag is constant on a side: no angle increments at all;
        # with them it moves in whole degrees, and the chord of increments spread over
        # an angle a is shorter than their sum by at most d*a^2/2).
        predicted_err = [0.0, 0.0]
        var_total = 0.0
        odom_len = truth_len = 0.0
        for i in range(4):
            (_, o0, t0, n0), (_, o1, t1, n1) = rests[2 * i], rests[2 * i + 1]
            o = (o1[0] - o0[0], o1[1] - o0[1])
            t = (t1[0] - t0[0], t1[1] - t0[1])
            mean_off, spread = self.side_heading(n0, n1, t0[2])
            path = odom_path_length(self.odom.all[n0:n1 + 1])
            d_o, d_t = math.hypot(*o), math.hypot(*t)
            odom_len += path
            truth_len += d_t
            var_len = (s * s / 2) * path * path + (k * k / 2) * path
            var_total += var_len
            self.assertGreaterEqual(d_o, self.side_m, "side %d: odom %.4f m" % (i, d_o))
            tol_len = 3 * math.sqrt(var_len) + MM + EPS
            self.assertLess(abs(d_t - path), tol_len,
                            "side %d: true length %.4f m, odom path %.4f m (tol %.4f)"
                            % (i, d_t, path, tol_len))
            if not self.noisy:
                turned = wrap_angle(self.lag(rests[2 * i + 1]) - self.lag(rests[2 * i]))
                self.assertLess(abs(turned), EPS, "side %d: odom heading turned on a straight" % i)
            expect = rotate(o, -mean_off)
            miss = math.hypot(t[0] - expect[0], t[1] - expect[1])
            tol_dir = tol_len + path * spread * spread / 2
            self.assertLess(miss, tol_dir, "side %d: true chord %s; odom chord %s turned by "
                            "its mean heading lag %.3f deg: %s, %.4f m apart (tol %.4f)"
                            % (i, t, o, -math.degrees(mean_off), expect, miss, tol_dir))
            predicted_err[0] += expect[0] - o[0]
            predicted_err[1] += expect[1] - o[1]

        # Each quarter turn on the spot: the odometry's heading lag changes by the
        # whole-degree remainder (< 1 deg) plus the encoder errors of the turn (the two
        # wheels' scale errors and travel noise over (b/2)(pi/2) each); what the
        # odometry counts as distance meanwhile (noise only) moves it off the truth.
        sigma_turn = math.hypot(math.sqrt(2) * s * turn_travel,
                                math.sqrt(2 * turn_travel) * k) / b
        for i in range(4):
            before, after = rests[2 * i + 1], rests[2 * i + 2]
            change = wrap_angle(self.lag(after) - self.lag(before))
            self.assertLess(abs(change), DEG + 3 * sigma_turn + EPS,
                            "turn %d: the odometry's heading lag changed by %.3f deg"
                            % (i, math.degrees(change)))
            var_total += (s * s / 2) * turn_travel ** 2 + (k * k / 2) * turn_travel
            if not self.noisy:  # wheels exactly opposite: the Create counts no distance
                moved = math.hypot(after[1][0] - before[1][0], after[1][1] - before[1][1])
                self.assertLess(moved, EPS, "turn %d: odom moved %.4f m on the spot"
                                % (i, moved))

        # The end. Heading: the odometry lags by the unreported remainder, in [0, 1 deg)
        # (every turn is counter-clockwise), plus the 3-sigma heading error of the
        # configured encoder errors over the square: right wheel 4 sides + 4 quarter
        # turns forward, left wheel 4 sides forward and 4 quarter turns back (scale
        # errors s_r, s_l: (s_r*D_r - s_l*D_l)/b), travel noise k*sqrt(D) per wheel.
        d_r = 4 * self.side_m + 4 * turn_travel
        d_l = 4 * self.side_m - 4 * turn_travel
        sigma_heading = math.hypot(s * math.hypot(d_r, d_l),
                                   k * math.sqrt(d_r + d_l + 8 * turn_travel)) / b
        lag_end = self.lag(rests[-1])
        _, odom_in_map, truth, _ = rests[-1]
        err = (truth[0] - odom_in_map[0], truth[1] - odom_in_map[1])
        miss = math.hypot(err[0] - predicted_err[0], err[1] - predicted_err[1])
        # Position: the sides' odom chords turned by their heading lags; what is left
        # is the sides' length errors and the turns' counted distance (assumed
        # independent: the scale errors of a square's four sides largely cancel) and
        # the mm remainders, 4 sides.
        tol_pos = 3 * math.sqrt(var_total) + 4 * MM + EPS
        rospy.loginfo("square: odom %s truth %s -> error %.4f m, predicted from the heading "
                      "lags %s, %.4f m off it (tol %.4f); heading lag %.3f deg (tol %.3f .. "
                      "%.3f)", odom_in_map, truth, math.hypot(*err), predicted_err, miss,
                      tol_pos, math.degrees(lag_end), -3 * math.degrees(sigma_heading),
                      math.degrees(DEG + 3 * sigma_heading))
        self.assertGreater(lag_end, -3 * sigma_heading - EPS, "heading lag %.3f deg"
                           % math.degrees(lag_end))
        self.assertLess(lag_end, DEG + 3 * sigma_heading + EPS, "heading lag %.3f deg"
                        % math.degrees(lag_end))
        self.assertLess(miss, tol_pos, "final position error %s, predicted %s from the "
                        "heading lags" % (err, predicted_err))
        # Path length (the sides; the turns are on the spot). The wheels' scale errors
        # are the same on every side: they add up linearly here.
        self.assertGreater(truth_len, 4 * self.side_m - 0.05)
        tol_path = 3 * math.sqrt((s * s / 2) * odom_len ** 2 + (k * k / 2) * odom_len) \
            + 4 * MM + EPS
        self.assertAlmostEqual(truth_len, odom_len, delta=tol_path)


def odom_path_length(msgs):
    pts = [pose_of(m)[:2] for m in msgs]
    return sum(math.hypot(q[0] - p[0], q[1] - p[1]) for p, q in zip(pts, pts[1:]))


if __name__ == "__main__":
    rostest.rosrun("ascc_sim", "square", SquareTest, sys.argv)
