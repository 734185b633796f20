"""Node ``skeleton_sim``: a simulated person in front of the Kinect, published as
openni_tracker publishes it (telepresence.skeleton_sim).

Publishes on TF, at ``~rate_hz`` of ROS time, the 15 joints ``<joint>_<user>`` (head_1,
neck_1, torso_1, right_elbow_1, ...) as children of ``~depth_frame`` (rotation: the
person's facing); nothing while the person is not tracked or a frame is dropped. A static
``~parent_frame -> ~depth_frame`` (the Kinect's mount) unless ``~parent_frame`` is empty.
For evaluation only (no algorithm may read it): ``ground_truth/gestures``
(std_msgs/String, latched, JSON, at each script's start: ``seed`` and ``episodes``, a
list of ``kind``, ``start``, ``motion_end``, ``end`` in ROS seconds). Parameters:
``telepresence.skeleton_sim.SkeletonSimParams`` (package README).
"""
import json
import math

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped
from std_msgs.msg import String

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import ParamError, from_params
from telepresence.skeleton_sim import SkeletonSimParams, SkeletonSource


def _transform(stamp, parent, child, xyz, yaw):
    tf = TransformStamped()
    tf.header.stamp = stamp
    tf.header.frame_id, tf.child_frame_id = parent, child
    tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = \
        (float(v) for v in xyz)
    tf.transform.rotation.z, tf.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return tf


class SkeletonSimNode:
    def __init__(self):
        self.p = from_params(SkeletonSimParams, rospy.get_param, "~")
        self.round = 0
        self.t0 = None  # ROS time [s] of the current script's start
        self.source = None
        self.tf = tf2_ros.TransformBroadcaster()
        self.truth_pub = rospy.Publisher("ground_truth/gestures", String, queue_size=1,
                                         latch=True)
        if self.p.parent_frame:
            self.static_tf = tf2_ros.StaticTransformBroadcaster()
            self.static_tf.sendTransform(_transform(
                rospy.Time.now(), self.p.parent_frame, self.p.depth_frame,
                (self.p.mount_x_m, 0.0, self.p.mount_z_m), 0.0))
        # PacedTimer: wakes once per period, not on every /clock message of a simulator,
        # and stops when the shutdown starts (ascc_common.paced_timer)
        self.timer = PacedTimer(1.0 / self.p.rate_hz, self.on_timer, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="skeletons")

    def _start(self, now_s, user):
        seed = self.p.seed + self.round
        self.source = SkeletonSource(self.p.script(seed), self.p.sensor, seed)
        self.source.user = user  # user ids keep counting across rounds
        self.t0 = now_s
        self.truth_pub.publish(String(data=json.dumps({"seed": seed, "episodes": [
            {"kind": e.kind, "start": now_s + e.t0, "motion_end": now_s + e.motion_end,
             "end": now_s + e.t1} for e in self.source.script]})))
        rospy.loginfo("skeleton_sim: script of %d episodes, %.1f s, seed %d",
                      len(self.source.script), self.source.end_s, seed)

    def on_timer(self):
        now = rospy.Time.now()
        now_s = now.to_sec()
        if self.t0 is not None and now_s < self.t0:
            rospy.logwarn("skeleton_sim: time went back; restarting the script")
            self.t0 = None
        if self.t0 is None:
            self._start(now_s, 0)
        t = now_s - self.t0
        if t >= self.source.end_s:
            if not self.p.loop:
                return
            self.round += 1
            self._start(now_s, self.source.user)
            t = 0.0
        frame = self.source.frame(t)
        if frame is None:
            return
        yaw = self.source.body.posture(t).facing
        self.tf.sendTransform([
            _transform(now, self.p.depth_frame, "%s_%d" % (name, frame.user), xyz, yaw)
            for name, xyz in frame.joints.items()])


def main():
    rospy.init_node("skeleton_sim")
    try:
        SkeletonSimNode()
    except ParamError as err:
        rospy.logfatal("skeleton_sim: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
