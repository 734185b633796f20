"""ROS driver for the iRobot Create and Create 2 (Open Interface over serial;
``~robot_model``).

Interface-compatible with Brown University's irobot_create_2_1: publishes `sensorPacket`,
`odom` (+ TF odom->base_link), subscribes `cmd_vel`, serves tank/turn/circle/brake/leds/
demo/dock/song. Adds `battery`, `hazards` and `/diagnostics` (and, on a Create 2,
`light_bumper` and the motors' status). The protocol, odometry, model check and safety
logic live in irobot_create_2_1.driver_core; this file only wires ROS to it.
Parameters: ``irobot_create_2_1.driver_core.DriverParams``.
"""
import math
import threading
import time

import diagnostic_updater
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Quaternion, TransformStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

from ascc_common.params import from_params
from ascc_common.pose2d import quaternion_from_yaw, wrap_angle
from ascc_common.throttle import Throttle
from irobot_create_2_1 import protocol, sensor_state
from irobot_create_2_1.driver_core import CreateDriverCore, DriverParams
from irobot_create_2_1.link import SerialLink
from irobot_create_2_1.models import model as robot_model
from irobot_create_2_1.msg import Hazards, LightBumper, SensorPacket
from irobot_create_2_1.odometry import twist_covariance
from irobot_create_2_1.ros.inline_publisher import InlinePublisher
from irobot_create_2_1.srv import (
    Brake,
    BrakeResponse,
    Circle,
    CircleResponse,
    Demo,
    DemoResponse,
    Dock,
    DockResponse,
    Leds,
    LedsResponse,
    Song,
    SongResponse,
    Tank,
    TankResponse,
    Turn,
    TurnResponse,
)

WARN_PERIOD_S = 5.0


class CreateDriverNode:
    def __init__(self):
        p = from_params(DriverParams, rospy.get_param, "~")
        self.port = p.port
        self.odom_frame = p.odom_frame
        self.base_frame = p.base_frame
        self.publish_tf = p.publish_tf
        self.sensor_timeout_s = p.sensor_timeout_s
        self.core = CreateDriverCore(
            wheel_base_m=p.wheel_base_m, mode=p.mode, cmd_timeout_s=p.cmd_timeout_s,
            stop_on_bump=p.stop_on_bump, max_wheel_speed_m_s=p.max_wheel_speed_m_s,
            robot=robot_model(p.robot_model), baud=p.baud,
            light_bump_speed_m_s=p.light_bump_speed_m_s, stuck_after_s=p.stuck_after_s,
            linear_scale=p.odom_linear_scale_correction)
        self.create2 = self.core.robot.encoder_odometry
        # The reader waits for frames_per_read frames at once, sleeping for the time they
        # take at the stream's rate rather than waking on every frame the port delivers:
        # one wake-up of the Python thread per frames_per_read x 15 ms. Its timeout bounds
        # the wait when frames are late or missing; the loop also runs the command timer,
        # so it must come round.
        self.read_bytes = p.frames_per_read * self.core.frame_bytes
        self.stream_bytes_s = self.core.frame_bytes / protocol.STREAM_PERIOD_S
        self.link = SerialLink(self.port, self.core.baud, read_timeout_s=(
            p.frames_per_read * protocol.STREAM_PERIOD_S + 0.01))
        self.lock = threading.Lock()
        # Times are ROS time in float seconds: rospy.Time arithmetic costs microseconds
        # per operation, at the stream's 66.7 Hz that showed in the node's CPU share.
        self.publish_period_s = 1.0 / max(p.publish_rate_hz, 1e-3)
        self.sensor_period_s = 1.0 / p.sensor_rate_hz
        self.cmd_period_s = 1.0 / max(p.cmd_rate_hz, 1e-3)
        self.last_publish = None  # stamp [s] of the last odom message
        self.last_sensor_publish = None  # stamp [s] of the last sensorPacket
        self.event_key = None  # core.event_key() in the last sensorPacket
        self.next_cmd = None  # when the command timer is due next [s, ROS time]
        self.next_slow = None  # when the once-a-second work is due next
        self.last_pose = None  # (time, x, y, theta) of the last odom message
        self.last_init = -math.inf
        self.stopping = False  # set by shutdown(): no more commands, no reopening
        self.throttle = Throttle(WARN_PERIOD_S)  # one period per kind of warning
        self.corrupt_reported = (0, 0, 0)  # parser counters named in the last warning
        self.mismatch_reported = False

        # Odometry and its TF go out from the reader thread itself (30 Hz to every TF
        # listener): no writer thread per subscriber to wake, and a subscriber that stops
        # reading is skipped, never waited for (the reader also runs the watchdog).
        self.odom_pub = InlinePublisher("odom", Odometry, on_skip=self.on_skip)
        self.packet_pub = rospy.Publisher("sensorPacket", SensorPacket, queue_size=10)
        self.hazard_pub = rospy.Publisher("hazards", Hazards, queue_size=10)
        self.battery_pub = rospy.Publisher("battery", BatteryState, queue_size=1)
        self.light_pub = (rospy.Publisher("light_bumper", LightBumper, queue_size=10)
                          if self.create2 else None)
        self.tf_pub = InlinePublisher("/tf", TFMessage, on_skip=self.on_skip)
        rospy.Subscriber("cmd_vel", Twist, self.on_cmd_vel, queue_size=1)
        self._services()

        if not rospy.has_param("~diagnostic_period"):
            # The updater re-reads this parameter with get_param_cached, which caches only
            # parameters that exist: absent, it cost one master call per update.
            rospy.set_param("~diagnostic_period", 1.0)
        self.diag = diagnostic_updater.Updater()
        self.diag.setHardwareID("iRobot %s @ %s" % (
            "Create 2" if self.create2 else "Create", self.port))
        self.diag.add("serial link", self.diag_link)
        self.diag.add("battery", self.diag_battery)
        self.diag.add("safety", self.diag_safety)
        if self.create2:
            self.diag.add("motors", self.diag_motors)

        rospy.on_shutdown(self.shutdown)
        # One thread does the reading, the command timer and the once-a-second work (no
        # rospy.Timer: under simulated time each one wakes on every /clock message).
        self.reader = threading.Thread(target=self.read_loop, name="create_reader", daemon=True)
        self.reader.start()
        rospy.loginfo("create driver: %s on port %s at %d baud, mode %s, cmd_timeout_s %.2f",
                      self.core.robot.name, self.port, self.core.baud, self.core.mode,
                      self.core.cmd_timeout_s)

    def _services(self):
        def srv(name, cls, resp, handler):
            rospy.Service(name, cls, lambda req: resp(self._guard(handler, req)))
        srv("tank", Tank, TankResponse, self.srv_tank)
        srv("turn", Turn, TurnResponse, self.srv_turn)
        srv("circle", Circle, CircleResponse, self.srv_circle)
        srv("brake", Brake, BrakeResponse, self.srv_brake)
        srv("leds", Leds, LedsResponse,
            lambda r: self.write(protocol.leds(r.play, r.advance, r.color, r.intensity)))
        srv("demo", Demo, DemoResponse, lambda r: self.write(self.core.demo_bytes(r.demo)))
        srv("dock", Dock, DockResponse,
            lambda r: self.write(protocol.cover_and_dock()) if r.dock else True)
        srv("song", Song, SongResponse,
            lambda r: self.write(protocol.song(0, list(bytearray(r.notes)),
                                               list(bytearray(r.durations)))
                                 + protocol.play(0)))

    @staticmethod
    def _guard(handler, req):
        try:
            return bool(handler(req))
        except ValueError as exc:
            rospy.logwarn("create driver: service request refused: %s", exc)
            return False

    # --- I/O ----------------------------------------------------------------------------
    def write(self, data):
        with self.lock:
            return not self.stopping and self.link.write(data)

    def warn(self, kind, text):
        """Warn at most once per WARN_PERIOD_S per kind (rospy's throttle keys on the
        calling line, so one line logging several kinds would let one hide the others)."""
        with self.lock:
            ready = self.throttle.ready(kind, rospy.get_time())
        if ready:
            rospy.logwarn("create driver: " + text)

    def on_skip(self, subscriber, count):
        """A subscriber of odom or TF whose socket is full was skipped (InlinePublisher)."""
        self.warn("skip " + subscriber, "subscriber %s is not reading odom/TF (its socket is "
                  "full): %d message(s) skipped for it so far, the others get every one"
                  % (subscriber, count))

    def read_loop(self):
        was_open = False
        while not rospy.is_shutdown():
            try:
                self.periodic(rospy.get_time())
            except rospy.ROSException:
                return  # shutting down
            with self.lock:
                if self.stopping:
                    return  # shutdown() closes the port once this thread is gone
                opened = self.link.ensure_open()
                if opened and not was_open:
                    rospy.loginfo("create driver: %s open, starting the stream", self.port)
                    self.link.write(self.core.init_sequence())
                    self.last_init = time.monotonic()
                elif was_open and not opened:
                    rospy.logwarn("create driver: lost %s (%s); reopening with back-off",
                                  self.port, self.link.last_error)
                was_open = opened
            if not opened:
                rospy.logwarn_throttle(WARN_PERIOD_S, "create driver: cannot open %s: %s"
                                       % (self.port, self.link.last_error))
                time.sleep(0.05)
                continue
            # Blocks up to the read timeout, outside the lock: the loop comes round at
            # least that often, so the command timer keeps its mean period.
            data = self.link.read_paced(self.read_bytes, self.stream_bytes_s)
            if not data:
                continue
            try:
                now = rospy.get_time()
            except rospy.ROSException:
                return  # shutting down
            try:
                self.handle_bytes(data, now)
            except Exception as exc:  # noqa: BLE001 - the reader thread must survive
                # A dead reader thread leaves the robot without odometry while the node
                # looks alive; name the problem and carry on with the next bytes.
                rospy.logerr_throttle(WARN_PERIOD_S, "create driver: %d bytes from %s not "
                                      "processed: %s: %s" % (len(data), self.port,
                                                             type(exc).__name__, exc))

    def periodic(self, now):
        """The command timer (every ``cmd_period_s``) and the once-a-second work, when
        due at ``now`` [s, ROS time]; a clock that went back restarts both."""
        if self.next_cmd is None or now >= self.next_cmd or \
                now < self.next_cmd - 2.0 * self.cmd_period_s:
            # Due times step by the period (not from now), so that a loop coming round
            # every 30 ms keeps the timer's 20 Hz on average.
            late = self.next_cmd is None or now - self.next_cmd > self.cmd_period_s \
                or now < self.next_cmd - 2.0 * self.cmd_period_s
            self.next_cmd = (now if late else self.next_cmd) + self.cmd_period_s
            self.send_wheels(lambda: self.core.command_bytes(now))
        if self.next_slow is None or now >= self.next_slow or now < self.next_slow - 2.0:
            self.next_slow = now + 1.0
            self.on_slow_timer(now)

    def handle_bytes(self, data, now):
        """Parse bytes read at ``now`` [s]; publish odometry for the frames they complete."""
        with self.lock:
            self.core.on_bytes(data, now)
            poses = self.core.frame_poses  # one entry per completed frame (a new list)
            mismatch = self.core.mismatch and not (self.stopping or self.mismatch_reported)
            self.mismatch_reported |= mismatch
        if poses:
            # The watchdog also runs at the reader's cadence (frames_per_read stream
            # frames), not only on the command timer: a stale command stops the wheels
            # within that many 15 ms frames.
            self.send_wheels(lambda: self.core.watchdog_bytes(now))
        if self.core.mismatch:
            if not mismatch:
                return  # reported once; the node is shutting down
            # Driving on would mean odometry from bytes of another robot: stop the node.
            rospy.logfatal("create driver: %s", self.core.model_check.message)
            rospy.signal_shutdown("robot model mismatch")
            return
        if poses:
            # Stamped when each frame was measured, not when it was read: a backlog on
            # a busy machine would make the odometry lag, then jump. A backlog's older
            # frames still go out as odom/TF at the publish rate, so TF interpolates
            # along the path the robot took.
            for stamp, pose in poses[:-1]:
                if self.last_publish is not None and \
                        self.last_publish + self.publish_period_s <= stamp:
                    self.last_publish = stamp
                    self.publish_odom(stamp, *pose, self.core.odom.pose_covariance())
            self.maybe_publish(poses[-1][0])

    # --- publishing -----------------------------------------------------------------------
    def maybe_publish(self, now):
        """Odometry and TF at most every ``publish_period_s``; the sensor messages at most
        every ``sensor_period_s``, or at once when an event packet changed. ``now`` [s]."""
        if self.last_publish is not None and now < self.last_publish:
            rospy.logwarn("create driver: time jumped back %.3f s; resetting publish timing",
                          self.last_publish - now)
            self.last_pose = None
            self.last_publish = self.last_sensor_publish = None
        with self.lock:
            key = self.core.event_key()
            sensors = (key != self.event_key or self.last_sensor_publish is None
                       or now - self.last_sensor_publish >= self.sensor_period_s)
            odom = (self.last_publish is None
                    or now - self.last_publish >= self.publish_period_s)
            if not (odom or sensors):
                return
            values = dict(self.core.values) if sensors else None
            x, y, theta = self.core.odom.pose
            pose_cov = self.core.odom.pose_covariance()
        stamp = rospy.Time.from_sec(now)
        if odom:
            self.last_publish = now
            self.publish_odom(now, x, y, theta, pose_cov, stamp)
        if sensors:
            self.last_sensor_publish, self.event_key = now, key
            self.publish_sensors(values, stamp)

    def publish_sensors(self, values, stamp):
        """sensorPacket, hazards and light_bumper, each built only while someone
        subscribes to it (nothing is latched, so an unheard message is lost anyway)."""
        header = Header(stamp=stamp, frame_id=self.base_frame)
        if self.packet_pub.get_num_connections() > 0:
            self.packet_pub.publish(SensorPacket(header=header,
                                                 **sensor_state.brown_fields(values)))
        if self.hazard_pub.get_num_connections() > 0:
            self.hazard_pub.publish(Hazards(header=header, **sensor_state.hazards(values)))
        if self.light_pub is not None and self.light_pub.get_num_connections() > 0:
            light = sensor_state.light_bumper(values)
            if light:
                self.light_pub.publish(LightBumper(header=header, **light))

    def publish_odom(self, now, x, y, theta, pose_cov, stamp=None):
        """Odometry (and TF) at ``now`` [s] (``stamp``: the same as a rospy.Time). The
        Odometry message is built only while someone subscribes to it (in the exploration
        stack no node does: they all read TF)."""
        stamp = rospy.Time.from_sec(now) if stamp is None else stamp
        orientation = Quaternion(*quaternion_from_yaw(theta))
        last, self.last_pose = self.last_pose, (now, x, y, theta)
        if self.odom_pub.get_num_connections() > 0:
            msg = Odometry()
            msg.header.stamp = stamp
            msg.header.frame_id = self.odom_frame
            msg.child_frame_id = self.base_frame
            msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
            msg.pose.pose.orientation = orientation
            msg.pose.covariance = pose_cov
            if last is not None:
                t0, x0, y0, th0 = last
                dt = now - t0
                if dt > 0:
                    msg.twist.twist.linear.x = ((x - x0) * math.cos(th0)
                                                + (y - y0) * math.sin(th0)) / dt
                    msg.twist.twist.angular.z = wrap_angle(theta - th0) / dt
            msg.twist.covariance = twist_covariance()
            self.odom_pub.publish(msg)
        if self.publish_tf:
            t = TransformStamped()
            t.header.stamp = stamp
            t.header.frame_id = self.odom_frame
            t.child_frame_id = self.base_frame
            t.transform.translation.x, t.transform.translation.y = x, y
            t.transform.rotation = orientation
            self.tf_pub.publish(TFMessage([t]))

    # --- commands -------------------------------------------------------------------------
    def on_cmd_vel(self, msg):
        with self.lock:
            warning = self.core.set_twist(msg.linear.x, msg.angular.z, rospy.get_time())
            kind = self.core.warning_kind
        if warning:
            self.warn(kind, warning)

    def send_wheels(self, make_bytes):
        """Write ``make_bytes()`` (a wheel command or None) under the lock, unless
        stopping; warn (throttled) when it was a watchdog stop."""
        with self.lock:
            if self.stopping:
                return
            stale_before = self.core.watchdog_stops
            data = make_bytes()
            if data is not None:
                self.link.write(data)
            tripped = self.core.watchdog_stops > stale_before
        if tripped:
            self.warn("watchdog", "no cmd_vel for %.2f s, robot stopped"
                      % self.core.cmd_timeout_s)

    def on_slow_timer(self, now):
        """Once a second [ROS time]: stream restart, battery, stuck and corrupt-data
        warnings, diagnostics."""
        with self.lock:
            stale = (not self.stopping and self.link.is_open
                     and self.core.sensors_stale(now, self.sensor_timeout_s))
            if stale and time.monotonic() - self.last_init > 2.0:
                # The robot may have been power-cycled: wake it and restart the stream.
                self.link.write(self.core.init_sequence())
                self.last_init = time.monotonic()
            battery = sensor_state.battery_si(self.core.values)
            silent = self.core.bytes_received == 0
            stuck = not self.stopping and self.core.update_stuck(now)
            if stuck:
                self.core.stuck_seconds += 1
            p = self.core.parser
            corrupt = (p.bad_checksum, p.bad_body, p.dropped_bytes)
            report = corrupt != self.corrupt_reported and self.throttle.ready("corrupt", now)
            if report:
                d = [a - b for a, b in zip(corrupt, self.corrupt_reported)]
                self.corrupt_reported = corrupt
        if report:
            rospy.logwarn("create driver: corrupt data from %s dropped: %d frame(s) with a "
                          "bad checksum, %d with a bad header or body, %d byte(s) in all "
                          "(since the last warning)" % (self.port, d[0], d[1], d[2]))
        if stale:
            hint = (" (nothing at all at %d baud: a create_1 talks at 57600, a create_2 at "
                    "115200; is ~robot_model %s right?)" % (self.core.baud,
                                                           self.core.robot.name)
                    if silent else "")
            rospy.logwarn_throttle(WARN_PERIOD_S, "create driver: no sensor frame from %s "
                                   "for > %.1f s; re-sent start/stream%s" %
                                   (self.port, self.sensor_timeout_s, hint))
        if stuck:
            self.warn("stuck", "wheels driven forward for > %.1f s but the stasis sensor "
                      "sees no progress: the robot is stuck" % self.core.stuck_after_s)
        if self.core.values:
            self.publish_battery(battery)
        self.diag.update()

    def publish_battery(self, b):
        msg = BatteryState()
        msg.header.stamp = rospy.Time.now()
        msg.voltage, msg.current = b["voltage_v"], b["current_a"]
        msg.temperature = b["temperature_c"]
        msg.charge, msg.capacity = b["charge_ah"], b["capacity_ah"]
        msg.design_capacity = b["capacity_ah"]
        msg.percentage = b["percentage"]
        msg.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_NIMH
        msg.power_supply_status = (BatteryState.POWER_SUPPLY_STATUS_CHARGING
                                   if b["charging_state"] in (1, 2, 3)
                                   else BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        msg.present = True
        self.battery_pub.publish(msg)

    # --- services ---------------------------------------------------------------------------
    def _clear(self, clear):
        if clear:
            # Stop a demo or docking and take the robot back into the driver's mode (in
            # passive mode wheel commands are ignored): core.clear_bytes per model.
            self.write(self.core.clear_bytes())

    def _wheels(self, left_mm_s, right_mm_s):
        with self.lock:
            warning = self.core.set_wheels(left_mm_s / 1000.0, right_mm_s / 1000.0,
                                           rospy.get_time())
            kind = self.core.warning_kind
        if warning:
            self.warn(kind, warning)
        return self.link.is_open

    def srv_tank(self, req):
        self._clear(req.clear)
        return self._wheels(req.left, req.right)

    def srv_turn(self, req):
        self._clear(req.clear)
        return self._wheels(-req.turn, req.turn)

    def srv_circle(self, req):
        self._clear(req.clear)
        if req.radius == 0:
            raise ValueError("circle radius 0 mm is not a circle")
        v = req.speed / 1000.0
        with self.lock:
            warning = self.core.set_twist(v, v / (req.radius / 1000.0), rospy.get_time())
            kind = self.core.warning_kind
        if warning:
            self.warn(kind, warning)
        return self.link.is_open

    def srv_brake(self, req):
        if req.brake:
            with self.lock:
                self.core.stop(rospy.get_time())
            return self.write(protocol.drive_direct(0, 0))
        return True

    # --- diagnostics ------------------------------------------------------------------------
    def diag_link(self, stat):
        p = self.core.parser
        if not self.link.is_open:
            stat.summary(DiagnosticStatus.ERROR, "port closed: %s" % self.link.last_error)
        elif self.core.sensors_stale(rospy.get_time(), self.sensor_timeout_s):
            stat.summary(DiagnosticStatus.WARN, "no sensor stream")
        else:
            stat.summary(DiagnosticStatus.OK, "streaming")
        stat.add("port", self.port)
        stat.add("opens", self.link.opens)
        stat.add("failures", self.link.failures)
        stat.add("frames ok", p.frames_ok)
        stat.add("bad checksum", p.bad_checksum)
        stat.add("bad body", p.bad_body)
        stat.add("dropped bytes", p.dropped_bytes)
        return stat

    def diag_battery(self, stat):
        b = sensor_state.battery_si(self.core.values)
        if not self.core.values:
            stat.summary(DiagnosticStatus.STALE, "no data")
        elif b["percentage"] < 0.1:
            stat.summary(DiagnosticStatus.WARN, "battery low")
        else:
            stat.summary(DiagnosticStatus.OK, "ok")
        for key, value in sorted(b.items()):
            stat.add(key, "%.3f" % value)
        return stat

    def diag_safety(self, stat):
        h = sensor_state.hazards(self.core.values)
        active = sorted(k for k, v in h.items() if v and k not in ("wall",))
        stat.summary(DiagnosticStatus.WARN if active else DiagnosticStatus.OK,
                     ", ".join(active) if active else "no hazard")
        stat.add("watchdog stops", self.core.watchdog_stops)
        stat.add("rejected commands", self.core.rejected_cmds)
        stat.add("saturated commands", self.core.saturated_cmds)
        return stat

    def diag_motors(self, stat):
        """Create 2: wheel and brush motor currents, stasis, light bumper."""
        m = sensor_state.motors(self.core.values)
        if not m:
            stat.summary(DiagnosticStatus.STALE, "no data")
            return stat
        if self.core.stuck_now:
            stat.summary(DiagnosticStatus.WARN, "stuck: wheels turning, stasis still")
        elif m["stasis_disabled"]:
            stat.summary(DiagnosticStatus.WARN, "stasis sensor disabled")
        else:
            stat.summary(DiagnosticStatus.OK, "ok")
        for key, value in sorted(m.items()):
            stat.add(key, "%.3f" % value if isinstance(value, float) else str(value))
        stat.add("seconds stuck", self.core.stuck_seconds)
        stat.add("light bump slowdowns", self.core.light_bump_slowdowns)
        return stat

    def shutdown(self):
        """Stop the wheels, then close the port.

        rospy runs this hook before rospy.is_shutdown() turns true, so the reader thread
        and the timers must be told by ``stopping``: otherwise the reader, blocked in a
        read outside the lock, failed inside pyserial when the port was closed under it
        ("'NoneType' object cannot be interpreted as an integer"), took that for a lost
        port and reopened it - and the command timer could then send the last cmd_vel
        again after the zero command, leaving the robot driving with no driver."""
        with self.lock:
            self.stopping = True
            self.core.stop(rospy.get_time())
            self.link.write(protocol.drive_direct(0, 0))
        if self.reader is not threading.current_thread():
            self.reader.join(timeout=2.0)  # returns within one read timeout (40 ms)
        with self.lock:
            self.link.close()


def main():
    rospy.init_node("irobot_create_2_1")
    try:
        CreateDriverNode()
    except ValueError as exc:
        rospy.logfatal("create driver: bad parameter: %s", exc)
        raise SystemExit(1) from exc
    rospy.spin()

