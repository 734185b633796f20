"""Node `activity_recognizer`: the recognized activity of the person wearing the motion
sensors (thesis 5.4.2). Subscribes ``wearable/<waist>/imu`` and ``wearable/<thigh>/imu``,
pairs their samples into one row per sample period, each sample once and in order
(`semantic_mapping.alignment.SampleAligner`: a sensor asleep under the power scheme
sends nothing and its last sample is held, as in training), feeds the rows to
`semantic_mapping.activity.OnlineRecognizer`, and publishes one
``semantic_mapping/Activity`` per window on ``activity``; the room belief's prior
(``activity_prior``, semantic_mapping/ActivityPrior, from semantic_mapper) weighs the
posterior (`Recognizer.prior_over_classes`, `Recognizer.apply_prior`). The model is the
file written by
``train_activity --out``. Parameters: `semantic_mapping.activity.RecognizerNodeParams`.
"""
import os
import threading
import time

import joblib
import numpy as np
import rospy
from sensor_msgs.msg import Imu

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from semantic_mapping.activity import OnlineRecognizer, Recognizer, RecognizerNodeParams
from semantic_mapping.alignment import SampleAligner
from semantic_mapping.msg import Activity, ActivityPrior
from semantic_mapping.ros import run


def load_model(path, wait_s):
    """The Recognizer in ``path``, waiting up to ``wait_s`` for the file; ValueError
    naming the file otherwise."""
    deadline = time.monotonic() + wait_s
    while not os.path.isfile(path):
        if time.monotonic() >= deadline or rospy.is_shutdown():
            raise ValueError("model_path: no file %s (make one with train_activity --out)"
                             % path)
        rospy.loginfo_throttle(10.0, "activity recognizer: waiting for %s" % path)
        time.sleep(0.2)
    rec = joblib.load(path)
    if not isinstance(rec, Recognizer):
        raise ValueError("model_path: %s holds a %s, not a semantic_mapping Recognizer"
                         % (path, type(rec).__name__))
    return rec


class ActivityRecognizerNode:
    def __init__(self):
        p = from_params(RecognizerNodeParams, rospy.get_param, "~")
        self.p = p
        self.rec = load_model(p.model_path, p.model_wait_s)
        self.online = OnlineRecognizer(self.rec)
        self.lock = threading.Lock()
        self.aligner = SampleAligner((p.waist_sensor, p.thigh_sensor),
                                     self.rec.config.rate_hz, p.silent_after_s,
                                     p.max_backlog_s)
        self.prior = None  # P_t(A) over the recognizer's classes (None: the training prior)
        self.pub = rospy.Publisher("activity", Activity, queue_size=10)
        for name in (p.waist_sensor, p.thigh_sensor):
            rospy.Subscriber("wearable/%s/imu" % name, Imu, self.on_imu, callback_args=name,
                             queue_size=50)
        rospy.Subscriber("activity_prior", ActivityPrior, self.on_prior, queue_size=1)
        cfg = self.rec.config
        # PacedTimer: wakes once per period, not on every /clock message of a simulator,
        # and stops when the shutdown starts (ascc_common.paced_timer)
        self.timer = PacedTimer(1.0 / cfg.rate_hz, self.on_tick, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="recognize")
        rospy.loginfo("activity recognizer: %s (%s, %s features, %g s windows every %g s)",
                      p.model_path, cfg.kind, cfg.features, cfg.window_s, cfg.hop_s)

    def on_imu(self, msg, name):
        """Queue the acceleration (the work is on the timer)."""
        a = msg.linear_acceleration
        value = np.array([a.x, a.y, a.z])
        if not np.all(np.isfinite(value)):
            rospy.logwarn_throttle(self.p.warn_period_s, "activity recognizer: non-finite "
                                   "acceleration from wearable/%s/imu ignored" % name)
            return
        with self.lock:
            kept = self.aligner.add(name, value, rospy.get_time())
        if not kept:
            rospy.logwarn_throttle(self.p.warn_period_s, "activity recognizer: more than "
                                   "max_backlog_s = %g s of wearable/%s/imu waiting; the "
                                   "oldest samples are dropped (%d so far)"
                                   % (self.p.max_backlog_s, name, self.aligner.dropped))

    def on_prior(self, msg):
        """The room belief's activity prior (semantic_mapper), over our classes."""
        try:
            prior = self.rec.prior_over_classes(msg.activities, msg.probability)
        except ValueError as err:
            rospy.logwarn_throttle(self.p.warn_period_s, "activity recognizer: activity "
                                   "prior ignored: %s" % err)
            return
        with self.lock:
            self.prior = prior

    def on_tick(self):
        with self.lock:
            missing = self.aligner.missing()
            rows = self.aligner.rows(rospy.get_time())
            prior = self.prior
        if missing:
            rospy.logwarn_throttle(self.p.warn_period_s, "activity recognizer: waiting for "
                                   "%s" % ", ".join("wearable/%s/imu" % n for n in missing))
            return
        for waist, thigh in rows:
            out = self.online.push(waist, thigh, prior)
            if out is not None:
                self.publish(*out)

    def publish(self, label, probability, posterior):
        """One window's result on ``activity``."""
        msg = Activity()
        msg.header.stamp = rospy.Time.now()
        msg.activity = label
        msg.probability = probability
        msg.classes = list(self.rec.config.classes)
        msg.posterior = [float(v) for v in posterior]
        self.pub.publish(msg)


def main():
    run("activity_recognizer", ActivityRecognizerNode, "activity recognizer")
