"""follow_monitor: measures a target-following run in the simulator (tests, benchmarks).

Subscribes (relative names): `ground_truth/<~robot>/pose` (PoseStamped), `ground_truth/people`
(ascc_sim/SimObjectArray: the followed person's pose, heading, speed and radius),
`target_follower/state` (std_msgs/String, the follower's state) and `sensorPacket`
(bumper hits); and, for what the follower believed, `target` (target_follower/Target: the
detector's best detection), `target_follower/followed` (geometry_msgs/PointStamped, in
odom or base_link) and `odom` (nav_msgs/Odometry, to put the followed point in
base_link). Every `~sample_period_s` of simulated time it stores one sample in an
ascc_eval.follow_eval.FollowRecord. The run ends when `~max_time_s` passed, or the person
has stood still for `~end_after_stop_s` after walking (its route ended), or the node shuts
down; then it publishes `~summary` (std_msgs/String, JSON, latched), writes `<label>.json`,
`<label>.csv` and `<label>.png` to `~output_dir` when set, and exits if
`~shutdown_when_finished`.
Parameters: ascc_eval.follow_eval.FollowMonitorParams. All the measuring is FollowRecord;
this file only wires it.
"""

import json
import math
import threading

import rospy
from geometry_msgs.msg import PointStamped, PoseStamped
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from ascc_common.pose2d import relative, yaw_of
from ascc_eval.follow_eval import FollowMonitorParams, FollowRecord, FollowSample
from ascc_sim.msg import SimObjectArray
from irobot_create_2_1.msg import SensorPacket
from target_follower.msg import Detection, Target

RANGE_SOURCES = {Detection.RANGE_NONE: "none", Detection.RANGE_LASER: "laser",
                 Detection.RANGE_SIZE: "size"}


class FollowMonitor:
    def __init__(self):
        self.p = from_params(FollowMonitorParams, rospy.get_param, "~")
        self.record = FollowRecord(self.p)
        self.lock = threading.Lock()
        self.robot = self.person = None
        self.state = ""
        self.bumping = False
        self.walked = False
        self.still_since = None
        self.t_start = None
        self.finished = False
        # the follower's view: (receipt time [s], range [m], bearing [rad][, source])
        self.detected = None
        self.followed = None
        self.odom = None  # (frame_id, x, y, yaw) of the newest odometry
        self.sum_pub = rospy.Publisher("~summary", String, queue_size=1, latch=True)
        rospy.Subscriber("ground_truth/%s/pose" % self.p.robot, PoseStamped, self._on_pose,
                         queue_size=5)
        rospy.Subscriber("ground_truth/people", SimObjectArray, self._on_people, queue_size=5)
        rospy.Subscriber("target_follower/state", String, self._on_state, queue_size=5)
        rospy.Subscriber("sensorPacket", SensorPacket, self._on_sensors, queue_size=20)
        rospy.Subscriber("target", Target, self._on_target, queue_size=5)
        rospy.Subscriber("target_follower/followed", PointStamped, self._on_followed,
                         queue_size=5)
        rospy.Subscriber("odom", Odometry, self._on_odom, queue_size=5)
        # PacedTimer: wakes once per sample, not on every /clock message (ascc_common.
        # paced_timer), beside the follow pipeline it measures
        self.timer = PacedTimer(self.p.sample_period_s, self._sample, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="sample")
        rospy.on_shutdown(lambda: self._finish("shutdown"))

    def _on_pose(self, msg):
        p = msg.pose
        self.robot = (p.position.x, p.position.y, yaw_of(p.orientation))

    def _on_people(self, msg):
        for o in msg.objects:
            if not self.p.person or o.name == self.p.person:
                self.person = o
                return
        rospy.logwarn_throttle(10.0, "follow_monitor: no person %r in ground_truth/people"
                               % self.p.person)

    def _on_target(self, msg):
        t = rospy.get_time()
        if not msg.detections:
            self.detected = (t, math.nan, math.nan, "")
            return
        d = msg.detections[0]
        self.detected = (t, float(d.range_m), float(d.bearing_rad),
                         RANGE_SOURCES.get(d.range_source, str(d.range_source)))

    def _on_odom(self, msg):
        p = msg.pose.pose
        self.odom = (msg.header.frame_id, p.position.x, p.position.y, yaw_of(p.orientation))

    def _on_followed(self, msg):
        x, y = msg.point.x, msg.point.y
        frame = msg.header.frame_id.lstrip("/")
        odom = self.odom
        if frame not in ("", "base_link"):
            if odom is None or frame != odom[0].lstrip("/"):
                rospy.logwarn_throttle(10.0, "follow_monitor: followed point in frame %r, "
                                       "odometry in %r: not recorded"
                                       % (frame, odom[0] if odom else None))
                return
            # odom -> base_link with the newest odometry (at 0.3 m/s, a 50 ms old pose is
            # 1.5 cm off)
            x, y, _ = relative(odom[1:], (x, y, 0.0))
        self.followed = (rospy.get_time(), math.hypot(x, y), math.atan2(y, x), "")

    def _fresh(self, view, t):
        """(range, bearing, source) of a view received within ~belief_max_age_s, else
        NaNs."""
        if view is None or t - view[0] > self.p.belief_max_age_s:
            return (math.nan, math.nan, "")
        return view[1:]

    def _on_state(self, msg):
        self.state = msg.data

    def _on_sensors(self, msg):
        hit = bool(msg.bumpLeft or msg.bumpRight)
        if hit and not self.bumping:
            with self.lock:
                self.record.add_bump(rospy.get_time())
            rospy.logwarn("follow_monitor: bumper hit at t=%.1f s" % rospy.get_time())
        self.bumping = hit

    def _sample(self):
        if self.finished or self.robot is None or self.person is None:
            return
        t = rospy.get_time()
        o = self.person
        pose = o.pose
        det_range, det_bearing, source = self._fresh(self.detected, t)
        fol_range, fol_bearing, _ = self._fresh(self.followed, t)
        sample = FollowSample(t, self.robot, (pose.position.x, pose.position.y,
                                              yaw_of(pose.orientation)),
                              o.speed, o.radius, self.state, det_range, det_bearing,
                              source, fol_range, fol_bearing)
        with self.lock:
            self.record.add(sample)
        if self.t_start is None:
            self.t_start = t
        if o.speed > 1e-3:
            self.walked, self.still_since = True, None
        elif self.walked and self.still_since is None:
            self.still_since = t
        if self.p.max_time_s > 0 and t - self.t_start >= self.p.max_time_s:
            self._finish("max_time")
        elif self.still_since is not None and t - self.still_since >= self.p.end_after_stop_s:
            self._finish("route_done")

    def _finish(self, reason):
        with self.lock:
            if self.finished:
                return
            self.finished = True
            self.record.end_reason = reason
            summary = self.record.summary()
            files = self.record.write(self.p.output_dir) if self.p.output_dir else []
        self.sum_pub.publish(String(data=json.dumps(summary)))
        rospy.loginfo("follow_monitor: %s after %s s: straight error mean %s m, p95 %s m, "
                      "bumps %d%s" % (reason, summary.get("duration_s"),
                                      summary.get("straight_error_mean_m"),
                                      summary.get("straight_error_p95_m"),
                                      summary.get("bumps", 0),
                                      "; wrote " + ", ".join(files) if files else ""))
        if self.p.shutdown_when_finished and reason != "shutdown":
            rospy.Timer(rospy.Duration(0.5), lambda _e: rospy.signal_shutdown(reason),
                        oneshot=True)


def main():
    rospy.init_node("follow_monitor")
    FollowMonitor()
    rospy.spin()
