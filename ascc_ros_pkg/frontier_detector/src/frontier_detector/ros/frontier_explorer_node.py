"""frontier_explorer: integrated exploration (thesis fig. 2.7) as a move_base client.

Wiring only; the loop's rules live in frontier_detector.explorer, the algorithms in
frontiers.py / utility.py / scenario.py. Topics, services and parameters: see README.md;
all parameters are read as ``frontier_detector.explorer.ExplorerNodeParams``.
Callbacks only store the newest message; the planning runs on a timer.
"""

import functools
import threading

import actionlib
import rospy
import tf2_ros
from actionlib.simple_action_client import SimpleGoalState
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid
from rospy.numpy_msg import numpy_msg
from std_msgs.msg import Float64, String
from std_srvs.srv import Trigger, TriggerResponse
from visualization_msgs.msg import MarkerArray

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from frontier_detector import explorer as ex
from frontier_detector.goal_selection import warm_up
from frontier_detector.rosmsg import goal_pose, grid_from_msg, plan_markers

_OUTCOMES = {GoalStatus.SUCCEEDED: ex.SUCCEEDED, GoalStatus.ABORTED: ex.ABORTED,
             GoalStatus.REJECTED: ex.REJECTED, GoalStatus.PREEMPTED: ex.PREEMPTED,
             GoalStatus.RECALLED: ex.PREEMPTED}
PROBLEM_WARN_PERIOD_S = 10.0   # each problem status is warned about at most this often
_PROBLEMS = (ex.WAITING_MAP, ex.WAITING_POSE, ex.WAITING_MOVE_BASE, "empty_map",
             "robot_outside_map", "robot_not_in_free_space")


class ExplorerNode:
    def __init__(self):
        p = from_params(ex.ExplorerNodeParams, rospy.get_param, "~")
        self.ctrl = ex.ExplorationController(p.explorer, p.planner)
        self.robot_frame = p.robot_frame
        self.free_max = p.free_max_percent
        self.occupied_min = p.occupied_min_percent
        self.tf_timeout = rospy.Duration(p.tf_timeout_s)
        self.max_points = p.max_marker_points
        self.shutdown_when_done = p.shutdown_when_done
        period = p.planning_period_s
        self.lock = threading.Lock()
        self.map_msg = None
        self.map_count = 0                      # identifies map updates for re-planning
        self.entropy = None
        self.outcome = None                     # (goal seq, outcome)
        self.goal_seq = 0
        self.grid_cache = (None, None, None, "map")  # (newest map msg, grid, info, frame)
        self.last_status = None
        self.warned_at = {}                     # problem status -> ROS time of its warning
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        self.status_pub = rospy.Publisher("~status", String, queue_size=1, latch=True)
        self.marker_pub = rospy.Publisher("~markers", MarkerArray, queue_size=1, latch=True)
        # numpy_msg: the map's cells arrive as one array, not a tuple of a million ints
        # (rospy's default: ~50 ms per message of a 100 m map).
        rospy.Subscriber("map", numpy_msg(OccupancyGrid), self._on_map, queue_size=1)
        rospy.Subscriber("slam_gmapping/entropy", Float64, self._on_entropy, queue_size=1)
        rospy.Service("~start", Trigger, self._srv_start)
        rospy.Service("~stop", Trigger, self._srv_stop)
        self._publish_status(ex.IDLE)
        if p.autostart:
            self.ctrl.start()
        # the search's compiled kernels loaded (or compiled, after a source change) now,
        # not in the first plan
        rospy.loginfo("frontier_explorer: compiled search ready (%.2f s of CPU)" % warm_up())
        # PacedTimer, not rospy.Timer: under simulated time that wakes on every /clock
        # message (ascc_common.paced_timer); a clock that went back restarts it
        self.timer = PacedTimer(period, self._tick_guarded, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="planning")

    def _tick_guarded(self):
        try:
            self._tick()
        except Exception as exc:  # noqa: BLE001 - the loop must survive
            rospy.logerr_throttle(10.0, "frontier_explorer: planning failed: %s: %s"
                                  % (type(exc).__name__, exc))

    # -- callbacks: store only -------------------------------------------------------
    def _on_map(self, msg):
        with self.lock:
            self.map_msg = msg
            self.map_count += 1

    def _on_entropy(self, msg):
        with self.lock:
            self.entropy = msg.data

    def _on_goal_done(self, seq, state, _result):
        with self.lock:
            self.outcome = (seq, _OUTCOMES.get(state, ex.LOST))

    def _srv_start(self, _req):
        with self.lock:
            self.ctrl.start()
        return TriggerResponse(True, "exploring")

    def _srv_stop(self, _req):
        with self.lock:
            active = self.ctrl.stop()
        if active and self.client.simple_state != SimpleGoalState.DONE:
            self.client.cancel_goal()
        self._publish_status(self.ctrl.state)
        return TriggerResponse(True, "stopped" + (" (goal cancelled)" if active else ""))

    # -- the timer: all work happens here ---------------------------------------------
    def _tick(self):
        with self.lock:
            msg, count, entropy = self.map_msg, self.map_count, self.entropy
            outcome = self.outcome
            self.outcome = None
        grid, info, frame = self._grid(msg)
        robot_xy = self._robot_xy(frame) if grid is not None else None
        ready = self.client.wait_for_server(rospy.Duration(0.05))
        with self.lock:
            if outcome is not None and outcome[0] == self.goal_seq:
                self.ctrl.report_outcome(outcome[1])
            d = self.ctrl.step(rospy.get_time(), grid, info, robot_xy, count, ready, entropy)
        if d.action == ex.SEND:
            self._send(frame, d.goal_xy, robot_xy, d.reason, d.goal_yaw)
        elif d.action == ex.CANCEL:
            self.client.cancel_all_goals()
        if d.plan is not None:
            self.marker_pub.publish(plan_markers(d.plan, frame, rospy.Time.now(), robot_xy,
                                                 self.ctrl.blacklist, self.max_points))
        reason = d.reason
        if d.status in ("robot_outside_map", "robot_not_in_free_space"):
            reason = "robot at (%.2f, %.2f) in %s" % (robot_xy[0], robot_xy[1], frame)
        self._publish_status(d.status, reason)
        if d.status == ex.DONE and self.shutdown_when_done:
            rospy.signal_shutdown("exploration done")

    def _grid(self, msg):
        """(grid, info, frame) of the newest well-formed map; a malformed one is ignored
        (warning), planning goes on with the last good map."""
        if msg is None:
            return None, None, "map"
        frame = msg.header.frame_id or "map"
        if self.grid_cache[0] is msg:
            return self.grid_cache[1], self.grid_cache[2], self.grid_cache[3]
        try:
            grid, info, counts = grid_from_msg(msg, self.free_max, self.occupied_min)
        except ValueError as exc:
            rospy.logwarn_throttle(10.0, "frontier_explorer: bad map ignored: %s" % exc)
            self.grid_cache = (msg,) + self.grid_cache[1:]      # keep the last good map
            return self.grid_cache[1], self.grid_cache[2], self.grid_cache[3]
        if counts["non_trinary"]:
            rospy.logwarn_throttle(
                30.0, "frontier_explorer: map has %d cells not in {-1, 0, 100} (%d invalid); "
                "thresholded: <= %d free, >= %d occupied, else unknown"
                % (counts["non_trinary"], counts["invalid"], self.free_max, self.occupied_min))
        self.grid_cache = (msg, grid, info, frame)
        return grid, info, frame

    def _robot_xy(self, frame):
        try:
            t = self.tf_buffer.lookup_transform(frame, self.robot_frame, rospy.Time(0),
                                                self.tf_timeout)
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                tf2_ros.ExtrapolationException) as exc:
            rospy.logwarn_throttle(10.0, "frontier_explorer: no %s -> %s transform: %s"
                                   % (frame, self.robot_frame, exc))
            return None
        return t.transform.translation.x, t.transform.translation.y

    def _send(self, frame, goal_xy, robot_xy, reason, yaw=None):
        self.goal_seq += 1
        goal = MoveBaseGoal(target_pose=goal_pose(frame, rospy.Time.now(), goal_xy, robot_xy,
                                                  yaw))
        self.client.send_goal(goal, done_cb=functools.partial(self._on_goal_done,
                                                              self.goal_seq))
        rospy.loginfo("frontier_explorer: goal %d (%.2f, %.2f): %s"
                      % (self.goal_seq, goal_xy[0], goal_xy[1], reason))

    def _publish_status(self, status, reason=""):
        if status in _PROBLEMS:
            # Throttled per problem: one problem's warning must not hide the next one's.
            now = rospy.get_time()
            last = self.warned_at.get(status)
            if last is None or now - last >= PROBLEM_WARN_PERIOD_S or now < last:
                self.warned_at[status] = now
                rospy.logwarn("frontier_explorer: %s: %s" % (status, reason))
        if status != self.last_status:
            self.last_status = status
            self.status_pub.publish(String(status))
            rospy.loginfo("frontier_explorer: status %s %s" % (status, reason))


def main():
    rospy.init_node("frontier_explorer")
    ExplorerNode()
    rospy.spin()
