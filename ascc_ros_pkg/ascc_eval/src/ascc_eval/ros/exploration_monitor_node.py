"""exploration_monitor: measures an exploration run in the simulator (for tests and demos).

Subscribes (relative names): `map` (the explored map), `ground_truth/map` (the simulator's
truth, latched), `ground_truth/<~robot>/start_pose` and `ground_truth/<~robot>/pose`
(PoseStamped, truth frame), `move_base/goal` (goals sent), `sensorPacket` (bumper hits),
`frontier_explorer/status`, and the first `scan` (the laser's range and field of view; its
mount from TF `~robot_frame` -> the scan's frame) for the seen coverage (see
ascc_eval.report.SeenArea). The explored map's frame is taken to sit at the robot's start
pose in the truth frame (a mapper started with the robot: gmapping's map = odom at start),
unless `~map_pose_in_truth` [x, y, yaw] is given.
Publishes `~coverage` (std_msgs/Float64, each `~period_s` = 1 s) and `~summary`
(std_msgs/String, JSON, latched) when the run ends: the explorer's status becomes `done`,
or `~max_time_s` of simulated time passed (0 = no limit), or the node shuts down. With
`~output_dir` set it also writes `<label>.json`, `<label>_map.png`, `<label>_coverage.png`
there (label made file-safe). Then, if `~shutdown_when_finished` (default true), the node
exits, which ends a launch that marks it required.
Parameters: ``ascc_eval.report.MonitorParams`` (~robot, ~label, ~output_dir, ~max_time_s,
~clearance_m, ~period_s, ~shutdown_when_finished, ~progress_period_s, ~file_stem: the demo
uses `summary`, ~robot_frame, ~map_pose_in_truth: [x, y, yaw] or unset).
All the measuring is ascc_eval.report.ExplorationRecord; this file only wires it.
"""

import json
import threading
import time

import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseActionGoal
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64, String

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import transform_points, yaw_of
from ascc_eval.report import ExplorationRecord, LaserGeometry, MonitorParams, compose
from frontier_detector.rosmsg import grid_from_msg
from irobot_create_2_1.msg import SensorPacket

# [s, wall] after the summary is published and before the node shuts itself down: rospy
# sends on its own threads, and a shutdown right after publish() dropped the message for
# connected subscribers (seen in explorer_fake_move_base.test under load)
SUMMARY_FLUSH_S = 1.0


class Monitor:
    def __init__(self):
        p = from_params(MonitorParams, rospy.get_param, "~")
        robot = p.robot
        self.label = p.label
        self.out_dir = p.output_directory()
        self.max_time = p.max_time_s
        self.shutdown_when_finished = p.shutdown_when_finished
        self.status = ""
        self.t_start = None
        self.clearance = p.clearance_m
        self.progress_period_s = p.progress_period_s
        self.file_stem = p.file_stem
        self.fixed_pose = p.map_pose_in_truth
        self.robot_frame = p.robot_frame
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.scan_msg = None
        self.laser_set = False
        self.lock = threading.Lock()
        self.finish_lock = threading.Lock()
        self.map_msg = self.truth_msg = self.start = None
        self.record = None
        self.pending_poses, self.pending_goals = [], []
        self.bumps = 0 if p.count_bumps else None
        self.bumping = False
        self.finished = False
        self.cov_pub = rospy.Publisher("~coverage", Float64, queue_size=1)
        self.sum_pub = rospy.Publisher("~summary", String, queue_size=1, latch=True)
        rospy.Subscriber("map", OccupancyGrid, self._store("map_msg"), queue_size=1)
        rospy.Subscriber("ground_truth/map", OccupancyGrid, self._store("truth_msg"),
                         queue_size=1)
        rospy.Subscriber("ground_truth/%s/start_pose" % robot, PoseStamped, self._store("start"),
                         queue_size=1)
        rospy.Subscriber("ground_truth/%s/pose" % robot, PoseStamped, self._on_pose,
                         queue_size=20)
        rospy.Subscriber("move_base/goal", MoveBaseActionGoal, self._on_goal, queue_size=10)
        if p.count_bumps:
            rospy.Subscriber("sensorPacket", SensorPacket, self._on_sensors, queue_size=20)
        rospy.Subscriber("frontier_explorer/status", String, self._on_status, queue_size=5)
        self.scan_sub = rospy.Subscriber("scan", LaserScan, self._on_scan, queue_size=1)
        # PacedTimer: stops when the shutdown starts (a rospy.Timer ticks on while rospy's
        # pre-shutdown hooks close the publishers) and wakes once per period, not on every
        # /clock message (ascc_common.paced_timer)
        self.timer = PacedTimer(p.period_s, self._tick, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="monitor")
        rospy.on_shutdown(lambda: self._finish("shutdown"))

    def _store(self, name):
        def cb(msg):
            with self.lock:
                setattr(self, name, msg)
        return cb

    def _on_pose(self, msg):
        with self.lock:
            self.pending_poses.append((msg.header.stamp.to_sec(), msg.pose.position.x,
                                       msg.pose.position.y, yaw_of(msg.pose.orientation)))

    def _on_scan(self, msg):
        with self.lock:
            if self.scan_msg is None:
                self.scan_msg = msg

    def _laser(self):
        """The laser's geometry from the first scan and TF, or None while unknown."""
        with self.lock:
            scan = self.scan_msg
        if scan is None:
            rospy.logwarn_throttle(30.0, "exploration_monitor: no scan yet, seen coverage "
                                   "waits for the laser's range and field of view")
            return None
        try:
            tr = self.tf_buffer.lookup_transform(self.robot_frame, scan.header.frame_id,
                                                 rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException) as exc:
            rospy.logwarn_throttle(30.0, "exploration_monitor: no TF %s -> %s (%s), seen "
                                   "coverage waits for the laser's mount"
                                   % (self.robot_frame, scan.header.frame_id, exc))
            return None
        t = tr.transform.translation
        if abs(t.y) > 1e-3 or abs(yaw_of(tr.transform.rotation)) > 1e-3:
            rospy.logwarn_once("exploration_monitor: the laser is mounted off the robot's "
                               "x axis or turned; seen coverage uses its x offset only")
        return LaserGeometry(range_m=float(scan.range_max),
                             fov_rad=float(scan.angle_max - scan.angle_min),
                             offset_x_m=float(t.x))

    def _on_goal(self, msg):
        p = msg.goal.target_pose.pose.position
        with self.lock:
            self.pending_goals.append((p.x, p.y))

    def _on_sensors(self, msg):
        with self.lock:
            hit = bool(msg.bumpLeft or msg.bumpRight)
            if hit and not self.bumping:
                self.bumps += 1
            self.bumping = hit

    def _on_status(self, msg):
        self.status = msg.data
        if msg.data == "done":
            rospy.Timer(rospy.Duration(0.1), lambda _e: self._finish("done"), oneshot=True)

    def _map_pose(self):
        if self.fixed_pose is not None:
            return tuple(float(v) for v in self.fixed_pose)
        p = self.start.pose
        return p.position.x, p.position.y, yaw_of(p.orientation)

    def _tick(self):
        if self.finished:
            return
        now = rospy.get_time()
        if self.t_start is None and now > 0.0:
            self.t_start = now
        if (self.max_time > 0.0 and self.t_start is not None
                and now - self.t_start >= self.max_time):
            rospy.logwarn("exploration_monitor: ~max_time_s %.0f s reached" % self.max_time)
            self._finish("max_time")
            return
        # a tick under way when the shutdown starts (its publishers closed) ends quietly:
        # PacedTimer swallows a callback's exception once the shutdown is requested
        self._update()

    def _update(self):
        with self.lock:
            map_msg, truth_msg, start = self.map_msg, self.truth_msg, self.start
            poses, goals = self.pending_poses, self.pending_goals
            self.pending_poses, self.pending_goals = [], []
        if self.record is None:
            if truth_msg is None or (start is None and self.fixed_pose is None):
                rospy.logwarn_throttle(10.0, "exploration_monitor: waiting for the ground truth")
                with self.lock:                       # keep what arrived meanwhile
                    self.pending_poses[:0], self.pending_goals[:0] = poses, goals
                return
            truth, tinfo, _ = grid_from_msg(truth_msg)
            sp = start.pose.position if start is not None else None
            start_xy = (sp.x, sp.y) if sp is not None else tuple(self.fixed_pose[:2])
            self.record = ExplorationRecord(truth, tinfo, start_xy, self.clearance, self.label)
        if not self.laser_set:
            laser = self._laser()
            if laser is not None:
                self.record.set_laser(laser)
                self.laser_set = True
                self.scan_sub.unregister()
                # The laser's mount was all it needed TF for: stay off /tf, whose 30 Hz
                # odometry transforms would otherwise cost the driver a connection.
                self.tf_listener.unregister()
                rospy.loginfo("exploration_monitor: seen coverage with %s" % (laser,))
        pose = self._map_pose()
        for t, x, y, yaw in poses:
            self.record.add_pose(t, x, y, yaw)
        for gx, gy in goals:                                  # goal points into the truth frame
            g = transform_points(pose, [[gx, gy]])[0]
            self.record.add_goal(float(g[0]), float(g[1]))
        self.record.bumps = self.bumps
        if map_msg is not None:
            try:
                grid, info, _ = grid_from_msg(map_msg)
            except ValueError as exc:
                rospy.logwarn_throttle(10.0, "exploration_monitor: bad map: %s" % exc)
                return
            c = self.record.add_map(rospy.get_time(), grid, compose(pose, info))
            self.cov_pub.publish(Float64(c))
            s = self.record.summary()
            rospy.loginfo_throttle(
                self.progress_period_s, "exploration_monitor: coverage %5.1f %%  seen %s"
                "  path %.1f m  goals %s  bumps %s  explorer %s"
                % (100.0 * c, "-" if s.get("seen_coverage") is None
                   else "%5.1f %%" % (100.0 * s["seen_coverage"]), s.get("path_m", 0.0),
                   s.get("goals", "?"), "-" if self.bumps is None else self.bumps,
                   self.status or "-"))

    def _finish(self, reason="shutdown"):
        with self.finish_lock:
            if self.finished:
                return
            self.finished = True
        try:
            self._update()
        except rospy.ROSException:
            pass                                  # shutting down: publishers closed
        if self.record is None:
            rospy.logwarn("exploration_monitor: ended (%s) before the ground truth arrived"
                          % reason)
        else:
            extra = {"end_reason": reason, "explorer_status": self.status}
            if self.out_dir:
                s = self.record.write(self.out_dir, extra, self.file_stem or None)
            else:
                s = dict(self.record.summary(), **extra)
            published = not rospy.is_shutdown()
            if published:
                self.sum_pub.publish(String(json.dumps(s)))
            rospy.loginfo("exploration_monitor: %s" % json.dumps(s))
            if (published and self.shutdown_when_finished and reason != "shutdown"
                    and self.sum_pub.get_num_connections() > 0):
                time.sleep(SUMMARY_FLUSH_S)  # let the summary reach its subscribers
        if self.shutdown_when_finished and reason != "shutdown":
            rospy.signal_shutdown("exploration finished: %s" % reason)


def main():
    rospy.init_node("exploration_monitor")
    Monitor()
    rospy.spin()
