"""Waiting helpers for the stack's rostests: conditions with timeouts, never fixed sleeps.

``wait_for`` and ``Latest`` time out in wall-clock time (the simulated clock may run
faster or stall); ``ConditionWaitMixin`` waits on a test case's ``threading.Condition``
with a timeout in ROS time.
"""
import threading
import time

import rospy

from ascc_common.pose2d import yaw_of


def wait_for(condition, timeout_s, what):
    """Poll ``condition()`` until true; AssertionError naming ``what`` after timeout_s of
    wall-clock time."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if rospy.is_shutdown():
            raise AssertionError("ROS shut down while waiting for %s" % what)
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s" % (timeout_s, what))
        time.sleep(0.02)


class Latest:
    """Subscribes ``topic`` and keeps the newest message, a count and (optionally) all."""

    def __init__(self, topic, msg_type, keep_all=False):
        self.topic = topic
        self.msg = None
        self.count = 0
        self.all = [] if keep_all else None
        self._lock = threading.Lock()
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=50)

    def _cb(self, msg):
        with self._lock:
            self.msg = msg
            self.count += 1
            if self.all is not None:
                self.all.append(msg)

    def wait(self, timeout_s=60.0, count=1):
        wait_for(lambda: self.count >= count, timeout_s, "%d message(s) on %s"
                 % (count, self.sub.resolved_name))
        return self.msg


def pose_of(odom_or_pose_msg):
    """(x, y, yaw) of a nav_msgs/Odometry or geometry_msgs/PoseStamped."""
    p = odom_or_pose_msg.pose
    p = getattr(p, "pose", p)
    return p.position.x, p.position.y, yaw_of(p.orientation)



class ConditionWaitMixin:
    """Mixin for unittest.TestCase; expects ``self.cond`` (threading.Condition), which the
    test's subscriber callbacks notify, and optionally ``self.statuses`` (quoted in a
    timeout). ``wait_for`` re-checks the predicate on every notification and at least every
    0.5 s, with the timeout in ROS time."""

    def wait_for(self, predicate, timeout_s, what):
        deadline = rospy.get_time() + timeout_s
        with self.cond:
            while not predicate():
                left = deadline - rospy.get_time()
                if left <= 0 or rospy.is_shutdown():
                    self.fail("timed out waiting for %s (statuses %s)"
                              % (what, getattr(self, "statuses", None)))
                self.cond.wait(min(left, 0.5))


class Recorder:
    """Subscribes ``topic`` and keeps every message with its wall-clock arrival
    (``time.monotonic()``): for latencies measured from a moment in the test."""

    def __init__(self, topic, msg_type):
        self.items, self._lock = [], threading.Lock()
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=200)

    def _cb(self, msg):
        with self._lock:
            self.items.append((time.monotonic(), msg))

    def since(self, t):
        """[(arrival, msg)] of the messages that arrived at or after ``t``."""
        with self._lock:
            return [(s, m) for s, m in self.items if s >= t]

    def all(self):
        return [m for _, m in self.since(float("-inf"))]

    def last(self):
        with self._lock:
            return self.items[-1][1] if self.items else None
