"""Node ``velocity_mux``: twist_mux's rules and configuration (telepresence.mux).

Parameters ``~topics`` and ``~locks``: twist_mux's lists of ``{name, topic, timeout,
priority}`` (``config/velocity_mux.yaml``); the node's own: ``telepresence.mux.
VelocityMuxParams`` (package README). Subscribes every input (geometry_msgs/Twist) and
lock (std_msgs/Bool) on its relative topic; publishes ``cmd_vel_out`` (geometry_msgs/Twist,
twist_mux's output name: launch files remap it to ``cmd_vel``) and ``~active``
(std_msgs/String, latched, on change: the input that has the base, or ``idle``).

A command is forwarded from its callback when its input is the active one (the rule is a
few comparisons; forwarding at once adds no latency, as in twist_mux); a timer at
``~check_rate_hz`` hands over to the next input when the active one goes stale or is
locked, or sends one zero command when none takes over. A command with NaN/inf is
dropped with a throttled warning (its input then goes stale: the robot stops).
"""
import math
import threading

import rospy
from geometry_msgs.msg import Twist
from std_msgs.msg import Bool, String

from ascc_common.params import from_params
from ascc_common.throttle import Throttle
from telepresence.mux import IDLE, STOP, VelocityMux, VelocityMuxParams, parse_config

WARN_PERIOD_S = 5.0  # throttle period of repeated warnings [s]


def finite_twist(msg):
    values = (msg.linear.x, msg.linear.y, msg.linear.z,
              msg.angular.x, msg.angular.y, msg.angular.z)
    return all(math.isfinite(v) for v in values)


class VelocityMuxNode:
    def __init__(self):
        self.p = from_params(VelocityMuxParams, rospy.get_param, "~")
        inputs, locks = parse_config(rospy.get_param("~topics", None),
                                     rospy.get_param("~locks", None))
        self.mux = VelocityMux(inputs, locks)
        self.lock = threading.Lock()
        self.throttle = Throttle(WARN_PERIOD_S)
        self.last_t = None
        self.shown_active = None
        self.shown_locks = []
        self.cmd_pub = rospy.Publisher("cmd_vel_out", Twist, queue_size=1)
        self.active_pub = rospy.Publisher("~active", String, queue_size=1, latch=True)
        self._show_active()
        self.subs = []
        for m in inputs:
            self.subs.append(rospy.Subscriber(m.topic, Twist, self.on_twist, m.name,
                                              queue_size=1))
            rospy.loginfo("velocity_mux: input '%s' on %s, timeout %.2f s, priority %d",
                          m.name, rospy.resolve_name(m.topic), m.timeout_s, m.priority)
        for m in locks:
            self.subs.append(rospy.Subscriber(m.topic, Bool, self.on_lock, m.name,
                                              queue_size=1))
            rospy.loginfo("velocity_mux: lock '%s' on %s, timeout %.2f s, priority %d",
                          m.name, rospy.resolve_name(m.topic), m.timeout_s, m.priority)
        self.timer = rospy.Timer(rospy.Duration(1.0 / self.p.check_rate_hz), self.on_timer)
        rospy.on_shutdown(self.on_shutdown)

    def _now(self):
        """ROS time [s]; time going back (a restarted simulator, a bag loop) forgets
        every input."""
        t = rospy.get_time()
        if self.last_t is not None and t < self.last_t:
            rospy.logwarn("velocity_mux: time went back by %.2f s; forgetting every input "
                          "and lock", self.last_t - t)
            self.mux.reset()
        self.last_t = t
        return t

    def on_twist(self, msg, name):
        with self.lock:
            if rospy.core.is_shutdown_requested():
                return  # stopped by on_shutdown; rospy is closing the publishers
            t = self._now()
            if not finite_twist(msg):
                if self.throttle.ready("nan:" + name, t):
                    rospy.logwarn("velocity_mux: input '%s' sent a command with NaN/inf "
                                  "(%s); dropped", name, _brief(msg))
                return
            if self.mux.on_command(name, t, msg):
                self.cmd_pub.publish(msg)
            self._show_active()

    def on_lock(self, msg, name):
        with self.lock:
            if rospy.core.is_shutdown_requested():
                return
            self._send(self.mux.on_lock(name, self._now(), msg.data))

    def on_timer(self, _event):
        with self.lock:
            if rospy.core.is_shutdown_requested():
                return
            self._send(self.mux.tick(self._now()))

    def _send(self, out):
        if out is STOP:
            self.cmd_pub.publish(Twist())
        elif out is not None:
            self.cmd_pub.publish(out)
        self._show_active()

    def _show_active(self):
        t = self.last_t if self.last_t is not None else rospy.get_time()
        locks = self.mux.engaged_locks(t)
        if locks != self.shown_locks:
            rospy.loginfo("velocity_mux: locks engaged: %s", ", ".join(locks) or "none")
            self.shown_locks = locks
        if self.mux.active != self.shown_active:
            rospy.loginfo("velocity_mux: active input: %s", self.mux.active)
            self.active_pub.publish(String(data=self.mux.active))
            self.shown_active = self.mux.active

    def on_shutdown(self):
        # rospy runs this hook once shutdown is requested and before it closes the
        # publishers. Under the lock, a callback in progress finishes first, and every later
        # one sees the request and returns: nothing moves the robot after this stop, and
        # nothing publishes to a closed topic.
        with self.lock:
            if self.mux.active != IDLE:
                self.cmd_pub.publish(Twist())


def _brief(msg):
    return "linear %.3g, angular %.3g" % (msg.linear.x, msg.angular.z)


def main():
    rospy.init_node("velocity_mux")
    try:
        VelocityMuxNode()
    except ValueError as err:  # a bad ~topics/~locks entry or parameter: say which
        rospy.logfatal("velocity_mux: %s", err)
        raise SystemExit(1) from err
    rospy.spin()
