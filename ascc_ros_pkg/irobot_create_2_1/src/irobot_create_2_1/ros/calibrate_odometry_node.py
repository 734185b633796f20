"""Node `calibrate_odometry`: the odometry's distance scale measured against a wall with the
laser (irobot_create_2_1.calibration).

Put the robot 2-3.5 m in front of a flat wall, facing it, with ``~distance_m`` of free floor
behind it. The node drives ``~distance_m`` towards the wall and back, ``~runs`` times,
stopping between runs; at each stop it averages the laser's distance to the wall. It logs
each run's ratio and the factor (true / odometry distance) times ``~current_correction``:
the value for the driver's ``~odom_linear_scale_correction``. Publishes it, latched, on
``~odom_linear_scale_correction`` (std_msgs/Float64), writes it to ``~output_file`` if set,
and exits. It stops the robot and exits with an error if no wall is seen ahead, the wall
comes closer than ``~min_wall_m``, or odom or scan go stale for ``~cmd_timeout_s``.
Parameters: ``irobot_create_2_1.calibration.CalibrationParams``. Topics (relative):
``scan`` (sensor_msgs/LaserScan, the laser facing forward), ``odom`` (nav_msgs/Odometry),
``cmd_vel`` (geometry_msgs/Twist).
"""
import math

import rospy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64

from ascc_common.params import from_params
from ascc_common.pose2d import yaw_of
from irobot_create_2_1.calibration import CalibrationParams, Stop, fit_wall, scale_factor


class CalibrationAborted(Exception):
    pass


class Calibrator:
    def __init__(self):
        self.p = from_params(CalibrationParams, rospy.get_param, "~")
        self.pose = None
        self.pose_time = None
        self.fit = None
        self.scan_time = None
        self.fits = None  # collecting while measuring
        self.cmd = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.result = rospy.Publisher("~odom_linear_scale_correction", Float64, queue_size=1,
                                      latch=True)
        rospy.Subscriber("odom", Odometry, self.on_odom, queue_size=1)
        rospy.Subscriber("scan", LaserScan, self.on_scan, queue_size=1)
        self.rate = rospy.Rate(20)

    def on_odom(self, msg):
        q = msg.pose.pose
        pose = (q.position.x, q.position.y, yaw_of(q.orientation))
        if not all(math.isfinite(v) for v in pose):
            # not used: the odometry goes stale and a run in progress is aborted
            rospy.logwarn_throttle(5.0, "calibrate_odometry: odom pose is not finite: %s",
                                   pose)
            return
        self.pose = pose
        self.pose_time = rospy.get_time()

    def on_scan(self, msg):
        fit = fit_wall(msg.ranges, msg.angle_min, msg.angle_increment, msg.range_min,
                       msg.range_max, self.p.half_width_rad)
        if fit is None:
            rospy.logwarn_throttle(5.0, "calibrate_odometry: no flat wall within %.0f deg of "
                                   "straight ahead in the scan",
                                   math.degrees(self.p.half_width_rad))
        self.fit = fit
        self.scan_time = rospy.get_time()
        if self.fits is not None and fit is not None:
            self.fits.append(fit)

    def send(self, v):
        t = Twist()
        t.linear.x = v
        self.cmd.publish(t)

    def check_fresh(self):
        now = rospy.get_time()
        for name, stamp in (("odom", self.pose_time), ("scan", self.scan_time)):
            if stamp is None or now - stamp > self.p.cmd_timeout_s:
                raise CalibrationAborted("no %s for %.1f s" % (name, self.p.cmd_timeout_s))

    def measure(self):
        rospy.sleep(self.p.settle_s)
        self.fits = []
        end = rospy.get_time() + self.p.measure_s
        while not rospy.is_shutdown() and rospy.get_time() < end:
            self.check_fresh()
            self.send(0.0)
            self.rate.sleep()
        fits, self.fits = self.fits, None
        if not fits:
            raise CalibrationAborted("no scan saw a flat wall ahead while at rest")
        stop = Stop(self.pose, fits)
        rospy.loginfo("calibrate_odometry: at rest, wall %.4f m ahead (normal %.1f deg, %d "
                      "scans), odom x=%.4f y=%.4f", stop.distance_m, math.degrees(stop.angle_rad),
                      stop.scans, stop.odom[0], stop.odom[1])
        return stop

    def drive(self, direction, wall_m):
        if direction > 0 and wall_m - self.p.distance_m < self.p.min_wall_m:
            raise CalibrationAborted(
                "the wall is %.2f m ahead: driving %.2f m towards it would come closer than "
                "min_wall_m %.2f m; start further away" % (wall_m, self.p.distance_m,
                                                          self.p.min_wall_m))
        x0, y0, _ = self.pose
        while not rospy.is_shutdown():
            self.check_fresh()
            left = self.p.distance_m - math.hypot(self.pose[0] - x0, self.pose[1] - y0)
            if left <= 0.0:
                break
            if direction > 0 and self.fit is not None and self.fit.distance_m < self.p.min_wall_m:
                raise CalibrationAborted("the wall came closer than min_wall_m %.2f m"
                                         % self.p.min_wall_m)
            # slow down over the last 10 cm so the 20 Hz loop does not overshoot much
            self.send(direction * min(self.p.speed_m_s, max(0.03, 1.5 * left)))
            self.rate.sleep()
        self.send(0.0)

    def run(self):
        while not rospy.is_shutdown() and (self.pose is None or self.scan_time is None):
            rospy.loginfo_throttle(2.0, "calibrate_odometry: waiting for odom and scan")
            rospy.sleep(0.1)
        rospy.sleep(self.p.start_delay_s)
        stops = [self.measure()]
        for i in range(self.p.runs):
            self.drive(1 if i % 2 == 0 else -1, stops[-1].distance_m)
            stops.append(self.measure())
        factor, stderr, ratios = scale_factor(stops)
        value = self.p.current_correction * factor
        rospy.loginfo("calibrate_odometry: runs' laser / odometry distance: %s",
                      " ".join("%.4f" % r for r in ratios))
        rospy.loginfo("calibrate_odometry: factor %.4f +- %.4f (standard error, %d runs); "
                      "set the driver's odom_linear_scale_correction: %.4f",
                      factor, stderr, len(ratios), value)
        self.result.publish(Float64(value))
        if self.p.output_file:
            with open(self.p.output_file, "w") as f:
                f.write("odom_linear_scale_correction: %.5f  # +- %.5f, %d runs\n"
                        % (value, stderr * self.p.current_correction, len(ratios)))
        return value


def main():
    rospy.init_node("calibrate_odometry")
    try:
        calibrator = Calibrator()
    except ValueError as exc:
        rospy.logfatal("calibrate_odometry: bad parameter: %s", exc)
        raise SystemExit(1) from exc
    try:
        calibrator.run()
    except CalibrationAborted as exc:
        rospy.logerr("calibrate_odometry: aborted, stopping the robot: %s", exc)
        raise SystemExit(1) from exc
    finally:
        calibrator.send(0.0)  # every way out, an abort included, stops the robot
    rospy.sleep(1.0)  # let the latched result reach late subscribers before exiting
