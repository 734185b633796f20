"""target_estimator: one robot's target estimate in map (thesis eq. 3.6-3.7).

Subscribes (relative names, run it in the robot's namespace) ``amcl_pose``
(geometry_msgs/PoseWithCovarianceStamped in ``~map_frame``) and ``target``
(target_follower/Target from target_detector, in ``~base_frame``). For each Target with a
detection of ``~kind`` with a laser range (``~laser_only``), publishes ``target_estimate``
(PoseWithCovarianceStamped in ``~map_frame``, stamped with the camera frame's stamp): the
position from the newest pose, the bearing and the range + ``~range_offset_m``, the x-y
covariance propagated to first order from the pose covariance and the range/bearing noise
(colloc_fusion.estimate); z and the rotations carry estimate.UNKNOWN_VARIANCE. Optionally
asks amcl for ``~nomotion_updates`` no-motion updates at the start (service
``request_nomotion_update``). Bad input (a pose in another frame, a NaN pose or
covariance, a Target in another frame, a NaN range) is dropped with a throttled warning
naming the robot. Parameters: colloc_fusion.node_params.EstimatorParams.
"""
from __future__ import annotations

import math

import numpy as np
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from std_srvs.srv import Empty

from ascc_common.params import ParamError, from_params
from ascc_common.pose2d import yaw_of
from ascc_common.throttle import Throttle
from colloc_fusion.estimate import (
    bad_measurement,
    cov6_of_xy,
    estimate_target,
    pick_detection,
    pose_cov3,
)
from colloc_fusion.node_params import EstimatorParams
from target_follower.msg import Detection, Target

WARN_PERIOD_S = 5.0  # [s] throttle of each kind of warning


class TargetEstimatorNode:
    def __init__(self):
        self.p = from_params(EstimatorParams, rospy.get_param, "~")
        self.robot = self.p.robot or rospy.get_namespace().strip("/") or "robot"
        self.throttle = Throttle(WARN_PERIOD_S)
        self.pose = None  # (stamp [s], (x, y, yaw), 3x3 covariance)
        self.pub = rospy.Publisher("target_estimate", PoseWithCovarianceStamped, queue_size=5)
        rospy.Subscriber("amcl_pose", PoseWithCovarianceStamped, self.on_pose, queue_size=2)
        rospy.Subscriber("target", Target, self.on_target, queue_size=5)
        self.nomotion_left = self.p.nomotion_updates
        if self.nomotion_left:
            self.nomotion = rospy.ServiceProxy("request_nomotion_update", Empty)
            self.nomotion_timer = rospy.Timer(rospy.Duration(self.p.nomotion_period_s),
                                              self.request_nomotion)
        rospy.loginfo("target_estimator: robot %s, kind %s, frames %s / %s", self.robot,
                      self.p.kind, self.p.map_frame, self.p.base_frame)

    def warn(self, key, text):
        if self.throttle.ready(key, rospy.get_time()):
            rospy.logwarn("target_estimator: robot %s: %s" % (self.robot, text))

    def request_nomotion(self, _event):
        if self.nomotion_left <= 0:
            self.nomotion_timer.shutdown()
            return
        try:
            self.nomotion()
            self.nomotion_left -= 1
        except (rospy.ServiceException, rospy.ROSException) as err:
            self.warn("nomotion", "amcl's request_nomotion_update failed: %s" % err)

    def on_pose(self, msg):
        frame = msg.header.frame_id.lstrip("/")
        if frame != self.p.map_frame.lstrip("/"):
            self.warn("pose_frame", "amcl_pose in frame %r, expected %r; ignored"
                      % (msg.header.frame_id, self.p.map_frame))
            return
        p = msg.pose.pose
        pose = (p.position.x, p.position.y, yaw_of(p.orientation))
        cov = pose_cov3(msg.pose.covariance)
        if not (np.isfinite(pose).all() and np.isfinite(cov).all()):
            self.warn("pose_nan", "amcl_pose has a non-finite pose or covariance; ignored")
            return
        if cov[0, 0] <= 0.0 or cov[1, 1] <= 0.0 or cov[2, 2] < 0.0:
            self.warn("pose_cov", "amcl_pose covariance has non-positive x/y variances "
                      "(%g, %g) or a negative yaw variance; ignored"
                      % (cov[0, 0], cov[1, 1]))
            return
        self.pose = (msg.header.stamp.to_sec(), pose, cov)

    def on_target(self, msg):
        if msg.header.frame_id.lstrip("/") != self.p.base_frame.lstrip("/"):
            self.warn("target_frame", "target in frame %r, expected %r; ignored"
                      % (msg.header.frame_id, self.p.base_frame))
            return
        det = pick_detection(msg.detections, self.p.kind, self.p.laser_only,
                             Detection.RANGE_LASER, Detection.RANGE_SIZE)
        if det is None:
            return  # no target of the kind with a usable range in this frame
        stamp = msg.header.stamp.to_sec()
        if self.pose is None:
            self.warn("no_pose", "no amcl_pose yet; target not localised")
            return
        pose_stamp, pose, cov = self.pose
        if self.p.max_pose_age_s > 0.0 and stamp - pose_stamp > self.p.max_pose_age_s:
            self.warn("pose_age", "newest amcl_pose is %.2f s older than the target frame "
                      "(max %.2f s); target not localised"
                      % (stamp - pose_stamp, self.p.max_pose_age_s))
            return
        rng = float(det.range_m)
        sigma = self.p.range_sigma_m if det.range_source == Detection.RANGE_LASER \
            else self.p.size_range_sigma_frac * rng
        reason = bad_measurement(rng, float(det.bearing_rad), sigma, self.p.bearing_sigma_rad)
        if reason:
            self.warn("measurement", "%s; target not localised" % reason)
            return
        est = estimate_target(self.robot, pose, cov, rng + self.p.range_offset_m,
                              float(det.bearing_rad), sigma, self.p.bearing_sigma_rad, stamp,
                              self.p.map_frame)
        out = PoseWithCovarianceStamped()
        out.header.stamp = msg.header.stamp
        out.header.frame_id = self.p.map_frame
        out.pose.pose.position.x, out.pose.pose.position.y = est.x, est.y
        out.pose.pose.orientation.w = 1.0
        out.pose.covariance = cov6_of_xy(est.cov)
        if math.isfinite(est.x) and math.isfinite(est.y):
            self.pub.publish(out)


def main():
    rospy.init_node("target_estimator")
    try:
        TargetEstimatorNode()
    except (ParamError, ValueError) as err:
        rospy.logfatal("target_estimator: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
