"""move_base stand-in (run it as node name ``move_base``).

Action server ``move_base`` (move_base_msgs/MoveBaseAction) and ``move_base_simple/goal``
(PoseStamped, re-sent as an action goal, as move_base does). Subscribes ``map``
(OccupancyGrid, the global costmap's static layer) and ``scan`` (LaserScan, obstacle stop
and recovery); reads the robot pose from TF (global_frame -> robot_base_frame). Publishes
``cmd_vel`` (Twist) while a goal is active (one zero command when it ends),
``~NavfnROS/plan`` and ``~plan`` (nav_msgs/Path), ``~current_goal`` (PoseStamped).
Without a robot pose or a scan newer than ``~stand_in/scan_timeout_s`` the robot is
stopped (the goal stays active); so it is when the scan a command was checked against is
older than ``~stand_in/obstacle_horizon`` - ``~stand_in/base_cmd_timeout_s`` as the command
leaves (its checked arc would not cover the time the base's watchdog lets it drive).
Parameters: move_base's names (config/move_base.yaml, package README), all read as
``ascc_navigation.navigation.MoveBaseParams``. Callbacks only
store the newest message; a timer at ``~controller_frequency`` runs
ascc_navigation.navigation; plans are made in a planner
thread (``~stand_in/async_planning``, default true, as move_base's planner thread), so the
control loop keeps following the current path while a plan is being made.
"""

import threading
from concurrent.futures import ThreadPoolExecutor

import actionlib
import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import OccupancyGrid, Path
from rospy.numpy_msg import numpy_msg
from sensor_msgs.msg import LaserScan

from ascc_common.grid import map_from_msg
from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import compose, quaternion_from_yaw, yaw_from_quaternion
from ascc_navigation import navigation as nav
from ascc_navigation.ros.laser_tf import mount_from_tf

WARN_PERIOD_S = 5.0  # throttle period of repeated warnings [s]


class GoalServer(actionlib.SimpleActionServer):
    """actionlib's SimpleActionServer, but a clock that went back (bag loop, restarted
    simulator) does not make it cancel every new goal: it takes a goal only if stamped no
    earlier than the goals it holds, and after a jump back their stamps lie in the future
    (until the clock caught up, every goal would be cancelled). Such stamps are forgotten
    when a goal arrives."""

    def internal_goal_callback(self, goal):
        now = rospy.Time.now()
        with self.lock:  # called under the action server's lock: actionlib's lock order
            for handle in (self.current_goal, self.next_goal):
                if handle.get_goal() is not None and handle.get_goal_id().stamp > now:
                    handle.get_goal_id().stamp = rospy.Time()
        super().internal_goal_callback(goal)


class NavigatorNode:
    def __init__(self):
        p = from_params(nav.MoveBaseParams, rospy.get_param, "~")
        self.executor = ThreadPoolExecutor(max_workers=1) if p.async_planning else None
        self.navigator = nav.Navigator(p.planner, p.controller, p.nav, executor=self.executor)
        if self.navigator.max_command_latency() <= 0.0:
            rospy.logerr("move_base: stand_in/obstacle_horizon (%.2f s) is not longer than "
                         "stand_in/base_cmd_timeout_s (%.2f s): every command will be dropped "
                         "as late", p.controller.obstacle_horizon, p.nav.base_cmd_timeout)
        self.global_frame = p.global_frame
        self.base_frame = p.robot_base_frame
        self.tf_tolerance = p.transform_tolerance  # [s]
        self.scan_timeout = p.scan_timeout_s  # [s] scan age limit
        self.range_max = p.raytrace_range  # [m]
        self.period = 1.0 / p.controller_frequency  # [s]

        self.lock = threading.Lock()
        self.pending_map = None
        self.scan = None
        self.mounts = {}
        self.last_now = None
        self.was_active = False
        self.late_commands = 0  # commands dropped as late (drop_late_command)

        self.tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(30.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.cmd_pub = rospy.Publisher("cmd_vel", Twist, queue_size=1)
        self.plan_pubs = [rospy.Publisher("~NavfnROS/plan", Path, queue_size=1, latch=True),
                          rospy.Publisher("~plan", Path, queue_size=1, latch=True)]
        self.goal_pub = rospy.Publisher("~current_goal", PoseStamped, queue_size=1, latch=True)
        self.action_goal_pub = rospy.Publisher("move_base/goal", MoveBaseActionGoal,
                                               queue_size=1)
        # numpy_msg: the grid (the ranges) arrive as an array, not a tuple of a million
        # (hundreds of) Python numbers
        rospy.Subscriber("map", numpy_msg(OccupancyGrid), self.on_map, queue_size=1,
                         buff_size=2 ** 24)
        rospy.Subscriber("scan", numpy_msg(LaserScan), self.on_scan, queue_size=1)
        rospy.Subscriber("move_base_simple/goal", PoseStamped, self.on_simple_goal,
                         queue_size=1)
        self.server = GoalServer("move_base", MoveBaseAction, auto_start=False)
        self.server.start()
        self._status_timer_with_reset()
        # PacedTimer, not rospy.Timer: under simulated time that wakes on every /clock
        # message (ascc_common.paced_timer)
        self.timer = PacedTimer(self.period, self.on_timer, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="controller")
        rospy.on_shutdown(self.stop_robot)

    # -- callbacks: store the newest input -----------------------------------------------
    def on_map(self, msg):
        self.pending_map = msg

    def on_scan(self, msg):
        self.scan = msg

    def on_simple_goal(self, msg):
        """As move_base: wrap the pose into an action goal for our own server."""
        goal = MoveBaseActionGoal()
        goal.header.stamp = rospy.Time.now()
        goal.goal.target_pose = msg
        self.action_goal_pub.publish(goal)

    # -- the control loop ----------------------------------------------------------------
    def on_timer(self):
        with self.lock:
            now = rospy.Time.now()
            dt = self._dt(now)
            self._apply_map()
            self._handle_goals()
            if self.navigator.status != nav.ACTIVE:
                self._stop_once()
                return
            now = rospy.Time.now()  # a large map update may have taken a while
            scan = self.scan
            pose = self._robot_pose()
            obstacles = self._obstacles(now, scan)
            if pose is None or obstacles is None:  # blind or lost: stand still, keep the goal
                self._stop_once(force=True)
                return
            step = self.navigator.step(now.to_sec(), pose, obstacles, dt)
            # the command's arc was checked against this scan: its age when the command
            # leaves, not only the cycle's time, is what the arc has to cover
            latency = (rospy.Time.now() - scan.header.stamp).to_sec()
            if step.status == nav.ACTIVE and self.navigator.drop_late_command(latency):
                self.late_commands += 1
                rospy.logwarn_throttle(
                    WARN_PERIOD_S, "move_base: the scan behind this command is %.2f s old "
                    "(CPU starved?), more than obstacle_horizon - base_cmd_timeout_s = %.2f s: "
                    "command dropped, robot stopped (%d late commands so far)"
                    % (latency, self.navigator.max_command_latency(), self.late_commands))
                step = nav.Step(0.0, 0.0, step.status, step.reason, step.new_path,
                                step.controller_state)
            self._publish(step, pose, now)

    def _dt(self, now):
        if self.last_now is not None and now < self.last_now:
            rospy.logwarn("move_base: time went back by %.2f s (bag loop or restarted clock); "
                          "clearing TF", (self.last_now - now).to_sec())
            self.tf_buffer.clear()
            self.mounts.clear()
            self.last_now = None
            self._action_server_after_jump()
        dt = self.period if self.last_now is None else (now - self.last_now).to_sec()
        self.last_now = now
        return float(np.clip(dt, 0.0, 2.0 * self.period))

    def _status_timer_with_reset(self):
        """actionlib's status timer is a rospy.Timer without reset: when the clock goes back
        (a bag loop, a restarted simulator) it dies with a ROSTimeMovedBackwardsException
        traceback, and move_base/status then comes with goal transitions only; under
        simulated time it also wakes on every /clock message. Replace it by a PacedTimer of
        the same period, which survives the jump (and has actionlib's shutdown())."""
        server = self.server.action_server
        with server.lock:
            old = server.status_timer
            if old is not None:
                server.status_timer = PacedTimer(
                    old._period.to_sec(), lambda: server.publish_status_async(None),
                    rospy.get_time, rospy.core.is_shutdown_requested, name="move_base_status")
        if old is not None:
            old.shutdown()

    def _action_server_after_jump(self):
        """actionlib after the clock went back: a cancel request stamped in the now future
        would cancel every new goal stamped before it, so forget that stamp. (The status
        timer survives: _status_timer_with_reset; the held goals' stamps: GoalServer.)"""
        server = self.server.action_server
        with server.lock:
            server.last_cancel = rospy.Time()

    def _apply_map(self):
        msg, self.pending_map = self.pending_map, None
        if msg is None:
            return
        try:
            grid, info = map_from_msg(msg)
            info.check_axis_aligned()
        except ValueError as e:
            rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: ignoring map: %s" % e)
            return
        self.navigator.set_map(grid, info)

    def _handle_goals(self):
        if self.server.is_new_goal_available():
            goal = self.server.accept_new_goal()
            self._start_goal(goal.target_pose)
        if self.server.is_active() and self.server.is_preempt_requested():
            self.navigator.cancel()
            self._stop_once(force=True)
            self.server.set_preempted(MoveBaseResult(), "Goal cancelled or preempted.")

    def _start_goal(self, target):
        """Validates a goal, transforms it into the global frame and hands it over."""
        p, q = target.pose.position, target.pose.orientation
        try:
            if not np.all(np.isfinite([p.x, p.y])):
                raise ValueError("goal position has NaN/inf components")
            yaw = nav.goal_yaw(q.x, q.y, q.z, q.w)
            x, y, yaw = self._to_global(target.header.frame_id, (p.x, p.y, yaw))
        except (ValueError, tf2_ros.TransformException) as e:
            rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: aborting goal: %s" % e)
            self.navigator.cancel()
            self.server.set_aborted(MoveBaseResult(), "Invalid goal: %s" % e)
            return
        self.navigator.set_goal(x, y, yaw, rospy.Time.now().to_sec())
        self.goal_pub.publish(self._pose_stamped(x, y, yaw, rospy.Time.now()))
        rospy.loginfo("move_base: new goal (%.2f, %.2f, %.2f) in %s", x, y, yaw,
                      self.global_frame)

    def _to_global(self, frame, pose):
        if not frame or frame == self.global_frame:
            if not frame:
                rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: goal has no frame_id; "
                                       "taking it as %s" % self.global_frame)
            return pose
        t = self.tf_buffer.lookup_transform(self.global_frame, frame, rospy.Time(0),
                                            rospy.Duration(0.2))
        return tuple(compose(self._yaw_pose(t.transform), pose))

    @staticmethod
    def _yaw_pose(transform):
        tr, q = transform.translation, transform.rotation
        return (tr.x, tr.y, yaw_from_quaternion(q.x, q.y, q.z, q.w))

    def _robot_pose(self):
        try:
            t = self.tf_buffer.lookup_transform(self.global_frame, self.base_frame,
                                                rospy.Time(0), rospy.Duration(0.05))
        except tf2_ros.TransformException as e:
            rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: no robot pose (%s -> %s): %s; "
                                   "stopped" % (self.global_frame, self.base_frame, e))
            return None
        age = (rospy.Time.now() - t.header.stamp).to_sec()
        if age > self.tf_tolerance + 1.0:
            rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: robot pose is %.1f s old; "
                                   "stopped" % age)
            return None
        return np.array(self._yaw_pose(t.transform))

    def _obstacles(self, now, scan):
        """Laser end points (K, 2) of ``scan`` in the base frame; None if it is missing,
        not recent or unusable."""
        if scan is None or abs((now - scan.header.stamp).to_sec()) > self.scan_timeout:
            rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: no laser scan newer than %.1f s "
                                   "on %s; stopped" % (self.scan_timeout,
                                                       rospy.resolve_name("scan")))
            return None
        frame = scan.header.frame_id
        try:
            if frame not in self.mounts:
                self.mounts[frame] = mount_from_tf(self.tf_buffer, self.base_frame, frame)
        except (tf2_ros.TransformException, ValueError) as e:
            rospy.logwarn_throttle(WARN_PERIOD_S, "move_base: scan frame '%s' unusable: %s"
                                   % (frame, e))
            return None
        mount = self.mounts[frame]
        r = np.asarray(scan.ranges, dtype=float)
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(r) & (r >= scan.range_min) & (r < min(scan.range_max,
                                                                   self.range_max))
        a = mount.beam_angles(r.size, scan.angle_min, scan.angle_increment)[ok]
        return np.column_stack([mount.x + r[ok] * np.cos(a), mount.y + r[ok] * np.sin(a)])

    # -- outputs --------------------------------------------------------------------------
    def _publish(self, step, pose, now):
        if step.new_path is not None:
            path = Path()
            path.header.stamp = now
            path.header.frame_id = self.global_frame
            path.poses = [self._pose_stamped(x, y, 0.0, now) for x, y in step.new_path]
            for pub in self.plan_pubs:
                pub.publish(path)
        if step.status == nav.ACTIVE:
            self._send(step.v, step.w)
            self.was_active = True
            fb = MoveBaseFeedback()
            fb.base_position = self._pose_stamped(pose[0], pose[1], pose[2], now)
            self.server.publish_feedback(fb)
        elif step.status == nav.SUCCEEDED:
            self._stop_once(force=True)
            self.server.set_succeeded(MoveBaseResult(), "Goal reached.")
        elif step.status == nav.ABORTED:
            self._stop_once(force=True)
            rospy.logwarn("move_base: goal aborted: %s", step.reason)
            self.server.set_aborted(MoveBaseResult(), step.reason)

    def _pose_stamped(self, x, y, yaw, stamp):
        msg = PoseStamped()
        msg.header.stamp = stamp
        msg.header.frame_id = self.global_frame
        msg.pose.position.x, msg.pose.position.y = x, y
        o = msg.pose.orientation
        o.x, o.y, o.z, o.w = quaternion_from_yaw(yaw)
        return msg

    def _send(self, v, w):
        cmd = Twist()
        cmd.linear.x, cmd.angular.z = v, w
        self.cmd_pub.publish(cmd)

    def _stop_once(self, force=False):
        """One zero command when driving ends (cmd_vel stays free for others when idle)."""
        if self.was_active or force:
            self._send(0.0, 0.0)
        self.was_active = False

    def stop_robot(self):
        self._send(0.0, 0.0)
        if self.executor is not None:
            self.executor.shutdown(wait=False)


def main():
    rospy.init_node("move_base")
    NavigatorNode()
    rospy.spin()
