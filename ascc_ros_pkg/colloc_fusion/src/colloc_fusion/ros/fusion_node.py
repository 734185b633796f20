"""fusion: the robots' target estimates fused (thesis eq. 3.1-3.5, or a covariance fusion).

Subscribes ``<~topic_prefix><robot>/<~estimate_topic>`` for each of ``~robots``
(geometry_msgs/PoseWithCovarianceStamped from target_estimator). Centralized (one node
on the workstation, in the root namespace) or distributed (one node in each robot's
namespace, ``~topic_prefix`` "/"): the same node. Every 1/``~rate_hz`` s it fuses each
robot's newest estimate that is within ``~window_s`` (colloc_fusion.fuser) and publishes
``fused_target`` (PoseWithCovarianceStamped in ``~map_frame``, stamped with the newest
estimate's stamp), ``fused_target/status`` (std_msgs/String, JSON: method, robots fused,
robots left out with why, clock offsets) and ``fused_target/markers``
(visualization_msgs/MarkerArray: each robot's estimate and ellipse, the fusion and its
ellipse, the truth when ``~truth_xy_m`` is set). A robot whose estimate is bad, stale,
from the future or from a clock beyond ``~max_clock_offset_s`` is left out with a
throttled warning naming it; the others are still fused. No fused estimate is ever NaN.
Parameters: colloc_fusion.node_params.FusionParams.
"""
from __future__ import annotations

import json
import math
import re
import threading

import numpy as np
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from std_msgs.msg import ColorRGBA, String
from visualization_msgs.msg import Marker, MarkerArray

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import ParamError, from_params
from ascc_common.pose2d import quaternion_from_yaw
from ascc_common.throttle import Throttle
from colloc_fusion.estimate import TargetEstimate, cov6_of_xy
from colloc_fusion.fuser import FusionCore, ellipse
from colloc_fusion.node_params import FusionParams

WARN_PERIOD_S = 5.0  # [s] throttle of each robot's each kind of warning
PALETTE = [(0.9, 0.2, 0.2), (0.2, 0.4, 0.95), (0.95, 0.8, 0.1), (0.6, 0.3, 0.8),
           (0.2, 0.8, 0.8)]


def estimate_from_msg(robot, msg):
    c = msg.pose.covariance
    cov = np.array([[c[0], c[1]], [c[6], c[7]]], dtype=float)
    p = msg.pose.pose.position
    return TargetEstimate(robot, p.x, p.y, cov, msg.header.stamp.to_sec(),
                          msg.header.frame_id)


class FusionNode:
    def __init__(self):
        self.p = from_params(FusionParams, rospy.get_param, "~")
        self.core = FusionCore(self.p)
        self.lock = threading.Lock()
        self.throttle = Throttle(WARN_PERIOD_S)
        self.pub = rospy.Publisher("fused_target", PoseWithCovarianceStamped, queue_size=5)
        self.status_pub = rospy.Publisher("fused_target/status", String, queue_size=5)
        self.marker_pub = rospy.Publisher("fused_target/markers", MarkerArray, queue_size=2)
        topics = []
        for robot in self.core.robots:
            topic = "%s%s/%s" % (self.p.topic_prefix, robot, self.p.estimate_topic)
            topics.append(rospy.resolve_name(topic))
            rospy.Subscriber(topic, PoseWithCovarianceStamped, self.on_estimate,
                             callback_args=robot, queue_size=5)
        # PacedTimer: stops when the shutdown starts, before rospy closes the publishers,
        # and wakes once per period, not on every /clock message (ascc_common.paced_timer)
        self.timer = PacedTimer(1.0 / self.p.rate_hz, self.tick, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="fusion")
        rospy.loginfo("fusion: %s of %s, window %.2f s", self.p.method, ", ".join(topics),
                      self.p.window_s)

    def warn(self, robot, reason, text):
        """``text`` at most once per WARN_PERIOD_S for each robot and kind of ``reason``
        (the reason without its numbers, matrices and quoted names)."""
        kind = re.sub(r"\[.*\]|\(.*?\)|'.*?'|[-+0-9.]+", "#", reason)
        if self.throttle.ready("%s/%s" % (robot, kind), rospy.get_time()):
            rospy.logwarn("fusion: %s" % text)

    def on_estimate(self, msg, robot):
        est = estimate_from_msg(robot, msg)
        with self.lock:
            reason = self.core.add(est, rospy.get_time())
        if reason:
            self.warn(robot, reason, reason + "; estimate dropped")

    def tick(self):
        now = rospy.get_time()
        with self.lock:
            fused, left = self.core.step(now)
            status = self.core.status(now, fused, left)
            latest = dict(self.core.latest)
        for robot, reason in left.items():
            self.warn(robot, reason, "left out: " + reason)
        if fused is not None:
            stamp = max(latest[r].stamp_s for r in fused.robots)
            self.pub.publish(self.pose_msg(fused.x, fused.y, fused.cov, stamp))
        self.status_pub.publish(String(data=json.dumps(status)))
        if self.marker_pub.get_num_connections():
            self.marker_pub.publish(self.markers(fused, latest, left))

    def pose_msg(self, x, y, cov, stamp):
        out = PoseWithCovarianceStamped()
        out.header.stamp = rospy.Time.from_sec(stamp)
        out.header.frame_id = self.p.map_frame
        out.pose.pose.position.x, out.pose.pose.position.y = x, y
        out.pose.pose.orientation.w = 1.0
        out.pose.covariance = cov6_of_xy(cov)
        return out

    def _marker(self, ns, mid, mtype, x, y, scale, rgb, alpha=1.0, yaw=0.0):
        m = Marker()
        m.header.frame_id = self.p.map_frame
        m.header.stamp = rospy.Time.now()
        m.ns, m.id, m.type, m.action = ns, mid, mtype, Marker.ADD
        m.pose.position.x, m.pose.position.y = x, y
        q = quaternion_from_yaw(yaw)
        m.pose.orientation.x, m.pose.orientation.y = q[0], q[1]
        m.pose.orientation.z, m.pose.orientation.w = q[2], q[3]
        m.scale.x, m.scale.y, m.scale.z = scale
        m.color = ColorRGBA(rgb[0], rgb[1], rgb[2], alpha)
        m.lifetime = rospy.Duration(2.0 / self.p.rate_hz + 0.5)
        return m

    def _ellipse(self, ns, mid, x, y, cov, rgb):
        major, minor, angle = ellipse(cov, self.p.ellipse_sigma)
        return self._marker(ns, mid, Marker.CYLINDER, x, y, (max(major, 0.005),
                            max(minor, 0.005), 0.01), rgb, 0.35, angle)

    def markers(self, fused, latest, left):
        arr = MarkerArray()
        for i, robot in enumerate(self.core.robots):
            est = latest.get(robot)
            if est is None or robot in left:
                continue
            rgb = PALETTE[i % len(PALETTE)]
            arr.markers.append(self._marker("estimates", i, Marker.SPHERE, est.x, est.y,
                                            (0.06, 0.06, 0.06), rgb))
            arr.markers.append(self._ellipse("ellipses", i, est.x, est.y, est.cov, rgb))
            text = self._marker("labels", i, Marker.TEXT_VIEW_FACING, est.x, est.y + 0.12,
                                (0.1, 0.1, 0.1), rgb)
            text.text = robot
            arr.markers.append(text)
        if fused is not None:
            arr.markers.append(self._marker("fused", 0, Marker.SPHERE, fused.x, fused.y,
                                            (0.08, 0.08, 0.08), (1.0, 1.0, 1.0)))
            arr.markers.append(self._ellipse("fused_ellipse", 0, fused.x, fused.y, fused.cov,
                                             (1.0, 1.0, 1.0)))
        if self.p.truth_xy_m is not None and all(map(math.isfinite, self.p.truth_xy_m)):
            arr.markers.append(self._marker("truth", 0, Marker.CUBE, self.p.truth_xy_m[0],
                                            self.p.truth_xy_m[1], (0.05, 0.05, 0.05),
                                            (0.1, 0.9, 0.1)))
        return arr


def main():
    rospy.init_node("fusion")
    try:
        FusionNode()
    except (ParamError, ValueError) as err:
        rospy.logfatal("fusion: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
