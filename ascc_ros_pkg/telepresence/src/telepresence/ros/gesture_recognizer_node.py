"""Node ``gesture_recognizer``: Kinect gesture commands of thesis 4.4
(telepresence.gestures).

Subscribes ``/tf`` (tf2_msgs/TFMessage: openni_tracker's ``<joint>_<user>`` frames under
``~depth_frame``; TF's topic is global, as for every TF listener). Publishes ``gesture``
(telepresence/Gesture: command, match error, threshold, time scale, user; one per
recognized gesture) and ``~angles`` (geometry_msgs/Vector3Stamped: x = the right elbow's
yaw, y = its pitch [rad], per usable frame; for plots and recordings). Parameters:
``GestureNodeParams`` (package README).

The TF callback only stores the transforms (telepresence.gestures.SkeletonFrames); a timer
at ``~check_rate_hz`` takes each new frame through the recognizer. Bad data gives no
command and a throttled warning per kind: missing joints or NaN/inf positions (the frame
is skipped: a gap no window spans), a user id that changes while samples are in the
window (they are dropped), skeleton frames under another parent, a template that is
missing or malformed (that command is not recognized; retried every
``~template_retry_s``; none usable: an error, and the node keeps running and publishing
angles).
"""
import os
import threading
from dataclasses import dataclass

import rospkg
import rospy
from geometry_msgs.msg import Vector3Stamped
from tf2_msgs.msg import TFMessage

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import ParamError, from_params, nested, param
from ascc_common.throttle import Throttle
from telepresence.gestures import (
    GestureParams,
    GestureRecognizer,
    SkeletonFrames,
    TemplateError,
    load_template,
)
from telepresence.msg import Gesture

WARN_PERIOD_S = 5.0  # throttle period of repeated warnings, per kind [s]


@dataclass
class GestureNodeParams:
    depth_frame: str = param("openni_depth_frame", "parent frame of the skeleton's joints")
    come_close_template: str = param("", "template file of come_close; empty: the "
                                     "package's templates/come_close.yaml")
    go_away_template: str = param("", "template file of go_away; empty: the package's "
                                  "templates/go_away.yaml")
    check_rate_hz: float = param(60.0, "rate at which new skeleton frames are taken [Hz]",
                                 gt=0.0, le=1000.0)
    max_skew_s: float = param(0.05, "joints stamped within this of a frame's first "
                              "belong to it; a frame still lacking joints is taken this "
                              "long after its first [s]", gt=0.0)
    template_retry_s: float = param(5.0, "a missing or malformed template is loaded "
                                    "again (and warned about) at this period [s]", gt=0.0)
    matching: GestureParams = nested(GestureParams)


class GestureRecognizerNode:
    def __init__(self):
        self.p = from_params(GestureNodeParams, rospy.get_param, "~")
        templates, problems = self._load_templates()
        self.recognizer = GestureRecognizer(templates, self.p.matching)
        self.frames = SkeletonFrames(self.p.depth_frame, self.p.max_skew_s)
        self.lock = threading.Lock()
        self.throttle = Throttle(WARN_PERIOD_S)
        self.last_now = None
        self.gesture_pub = rospy.Publisher("gesture", Gesture, queue_size=10)
        self.angles_pub = rospy.Publisher("~angles", Vector3Stamped, queue_size=30)
        rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=100)
        # PacedTimer: wakes once per period, not on every /clock message of a simulator,
        # and stops when the shutdown starts (ascc_common.paced_timer)
        self.timer = PacedTimer(1.0 / self.p.check_rate_hz, self.on_timer, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="check")
        if problems:
            self.retry_timer = rospy.Timer(rospy.Duration(self.p.template_retry_s),
                                           self.on_retry)

    def _load_templates(self, quiet=False):
        """The usable templates; each problem warned (at most once per
        ``~template_retry_s`` for the same problem: they are retried at that period)."""
        pkg = rospkg.RosPack().get_path("telepresence")
        out, problems = [], []
        for command, path in (("come_close", self.p.come_close_template),
                              ("go_away", self.p.go_away_template)):
            path = path or os.path.join(pkg, "templates", command + ".yaml")
            try:
                tp = load_template(path)
            except TemplateError as err:
                problems.append("%s; '%s' will not be recognized" % (err, command))
                continue
            if tp.command != command:
                problems.append("template %s is of '%s', given as '%s'; '%s' will not be "
                                "recognized" % (path, tp.command, command, command))
                continue
            if not quiet:
                rospy.loginfo("gesture_recognizer: template '%s' from %s (%d samples, "
                              "%.2f s)", command, path, len(tp.yaw), tp.duration_s)
            out.append(tp)
        for text in problems:
            rospy.logwarn("gesture_recognizer: %s", text)
        if not out:
            rospy.logerr("gesture_recognizer: no usable template: no gesture will be "
                         "recognized (angles are still published); retrying in %.0f s",
                         self.p.template_retry_s)
        return out, bool(problems)

    def on_retry(self, _event):
        """Load the templates again while some is unusable (a file fixed or recorded
        after the start is taken up; the warnings repeat meanwhile)."""
        templates, problems = self._load_templates(quiet=True)
        with self.lock:
            if len(templates) > len(self.recognizer.matcher.templates):
                rospy.loginfo("gesture_recognizer: templates now: %s",
                              ", ".join(t.command for t in templates))
                self.recognizer = GestureRecognizer(templates, self.p.matching)
        if not problems:
            self.retry_timer.shutdown()

    def on_tf(self, msg):
        with self.lock:
            for tr in msg.transforms:
                p = tr.transform.translation
                problem = self.frames.add(tr.header.frame_id, tr.child_frame_id,
                                          tr.header.stamp.to_sec(), (p.x, p.y, p.z))
                if problem:
                    self._warn("parent", problem)

    def on_timer(self):
        with self.lock:
            now = rospy.get_time()
            if self.last_now is not None and now < self.last_now:
                rospy.logwarn("gesture_recognizer: time went back by %.2f s; forgetting "
                              "the skeleton and the gesture window", self.last_now - now)
                self.frames.clear()
                self.recognizer.reset()
            self.last_now = now
            frames = self.frames.take(now)
        for frame in frames:
            self._recognize(*frame)

    def _recognize(self, t, user, joints):
        step = self.recognizer.on_frame(t, user, joints)
        for kind, text in step.problems:
            self._warn(kind, text)
        stamp = rospy.Time.from_sec(t)
        if step.angles is not None:
            v = Vector3Stamped()
            v.header.stamp, v.header.frame_id = stamp, self.p.depth_frame
            v.vector.x, v.vector.y = step.angles
            self.angles_pub.publish(v)
        if step.match is not None:
            m = step.match
            g = Gesture(command=m.command, error_rad2=m.error_rad2,
                        threshold_rad2=self.p.matching.threshold_rad2,
                        time_scale=m.time_scale, user=user)
            g.header.stamp, g.header.frame_id = stamp, self.p.depth_frame
            rospy.loginfo("gesture_recognizer: %s (error %.4f rad^2, user %d)", m.command,
                          m.error_rad2, user)
            self.gesture_pub.publish(g)

    def _warn(self, kind, text):
        if self.throttle.ready(kind, rospy.get_time()):
            rospy.logwarn("gesture_recognizer: %s", text)


def main():
    rospy.init_node("gesture_recognizer")
    try:
        GestureRecognizerNode()
    except ParamError as err:
        rospy.logfatal("gesture_recognizer: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
