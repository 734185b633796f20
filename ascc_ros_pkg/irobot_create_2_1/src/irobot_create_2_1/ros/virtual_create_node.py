"""A virtual iRobot Create (``~robot_model``: create_1 or create_2) on a pseudo-terminal,
for the driver's tests.

Prints `virtual_create: serving <path>` on stdout (and logs it, and sets ~port) so a test or
a person can point the driver at it. The emulation (irobot_create_2_1.virtual_create) steps
on a ROS-time timer, so it follows /clock; this file only wires params
(``irobot_create_2_1.virtual_create.VirtualCreateParams``), topics, services.
"""
import json
import math
import os
import sys
import threading

import rospy
from geometry_msgs.msg import Quaternion, Vector3Stamped
from nav_msgs.msg import Odometry
from std_srvs.srv import SetBool, SetBoolResponse, Trigger, TriggerResponse

from ascc_common.params import from_params
from irobot_create_2_1.models import model as robot_model
from irobot_create_2_1.pty_link import PtyLink
from irobot_create_2_1.virtual_create import VirtualCreate, VirtualCreateParams

WARN_PERIOD_S = 5.0
MAX_STEP_S = 0.5          # a longer gap (paused sim, suspended process) is not emulated
GARBAGE_BYTES = 64
LIGHT_BUMP_SIGNAL = 1000  # ~set_light_bump's signal level (0..4095)


class VirtualCreateNode:
    def __init__(self):
        p = from_params(VirtualCreateParams, rospy.get_param, "~")
        self.reopen_delay_s = p.reopen_delay_s
        self.world_frame = p.world_frame
        self.base_frame = p.base_frame
        self.create = VirtualCreate(wheel_base_m=p.wheel_base_m or None,
                                    battery_capacity_mah=p.battery_capacity_mah,
                                    max_wheel_speed_mm_s=p.max_wheel_speed_mm_s,
                                    robot=robot_model(p.robot_model))
        self.lock = threading.Lock()
        self.link = PtyLink(self.create, p.link_path or None)
        self.last_step = None
        self.announce()

        self.truth_pub = rospy.Publisher("~ground_truth", Odometry, queue_size=10)
        self.wheel_pub = rospy.Publisher("~wheel_speeds", Vector3Stamped, queue_size=10)
        rospy.Service("~set_bump", SetBool, self.srv_set_bump)
        rospy.Service("~set_light_bump", SetBool, self.srv_set_light_bump)
        rospy.Service("~set_stuck", SetBool, self.srv_set_stuck)
        rospy.Service("~inject_garbage", Trigger, self.srv_inject_garbage)
        rospy.Service("~close_link", Trigger, self.srv_close_link)
        rospy.Service("~power_cycle", Trigger, self.srv_power_cycle)
        rospy.Service("~state", Trigger, self.srv_state)
        rospy.on_shutdown(self.shutdown)
        self.timers = [rospy.Timer(rospy.Duration(1.0 / p.rate_hz), self.on_step),
                       rospy.Timer(rospy.Duration(1.0 / p.publish_rate_hz), self.on_publish)]

    def announce(self):
        port = self.link.port
        rospy.set_param("~port", port)
        # The brief asks for this exact line on stdout (tests and people read it).
        sys.stdout.write("virtual_create: serving %s\n" % port)
        sys.stdout.flush()
        rospy.loginfo("virtual_create: serving %s (pty %s)", port, self.link.tty_path)

    # --- timers -------------------------------------------------------------------------
    def on_step(self, _event):
        now = rospy.get_rostime()
        with self.lock:
            last, self.last_step = self.last_step, now
            if last is None:
                self.link.pump()
                return
            dt = (now - last).to_sec()
            if dt < 0.0 or dt > MAX_STEP_S:
                rospy.logwarn_throttle(WARN_PERIOD_S, "virtual_create: time jumped by %.3f s;"
                                       " not emulated" % dt)
                dt = 0.0
            self.link.pump()
            self.create.step(dt)
            self.link.pump()

    def on_publish(self, _event):
        with self.lock:
            # stamped while the state is read, so no step can come between the two: a
            # stamp never precedes the command that set the speeds it carries
            now = rospy.get_rostime()
            x, y, theta = self.create.pose
            v, w = self.create.body_velocity
            left, right = self.create.wheel_speed_cmd_mps
        odom = Odometry()
        odom.header.stamp = now
        odom.header.frame_id = self.world_frame
        odom.child_frame_id = self.base_frame
        odom.pose.pose.position.x, odom.pose.pose.position.y = x, y
        odom.pose.pose.orientation = Quaternion(0.0, 0.0, math.sin(0.5 * theta),
                                                math.cos(0.5 * theta))
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = v, w
        self.truth_pub.publish(odom)
        wheels = Vector3Stamped()
        wheels.header.stamp = now
        wheels.header.frame_id = self.base_frame
        wheels.vector.x, wheels.vector.y = left, right
        self.wheel_pub.publish(wheels)

    # --- test services ------------------------------------------------------------------
    def srv_set_bump(self, req):
        with self.lock:
            self.create.set_bumpers(req.data, req.data)
        return SetBoolResponse(True, "bumpers %s" % ("pressed" if req.data else "released"))

    def srv_set_light_bump(self, req):
        """Create 2: all six light bump signals at LIGHT_BUMP_SIGNAL (something close ahead)
        or 0."""
        with self.lock:
            self.create.set_light_bumps([LIGHT_BUMP_SIGNAL if req.data else 0] * 6)
        return SetBoolResponse(True, "light bump signals %d" % (
            LIGHT_BUMP_SIGNAL if req.data else 0))

    def srv_set_stuck(self, req):
        """Hold the body still while the wheels turn (the stasis sensor sees no progress)."""
        with self.lock:
            self.create.set_stuck(req.data)
        return SetBoolResponse(True, "stuck" if req.data else "free")

    def srv_inject_garbage(self, _req):
        with self.lock:
            written = self.link.inject(os.urandom(GARBAGE_BYTES))
        return TriggerResponse(True, "%d garbage bytes written" % written)

    def srv_close_link(self, _req):
        with self.lock:
            if not self.link.is_open:
                return TriggerResponse(False, "link already closed")
            self.link.close()
        rospy.logwarn("virtual_create: link closed; reopening in %.2f s", self.reopen_delay_s)
        rospy.Timer(rospy.Duration(max(self.reopen_delay_s, 1e-3)), self.on_reopen,
                    oneshot=True)
        return TriggerResponse(True, "closed; reopening in %.2f s" % self.reopen_delay_s)

    def srv_power_cycle(self, _req):
        with self.lock:
            self.create.power_cycle()
        rospy.logwarn("virtual_create: power-cycled: OI off, stream stopped, motors stopped")
        return TriggerResponse(True, "power-cycled: off until Start")

    def srv_state(self, _req):
        """The emulator's actuator state as JSON in `message` (for tests and people)."""
        with self.lock:
            c = self.create
            state = {
                "robot_model": c.robot.name,
                "mode": c.mode,
                "wheel_speeds_mps": list(c.wheel_speed_cmd_mps),
                "streaming": c.streaming, "stream_ids": list(c.stream_ids),
                "leds": c.leds._asdict(),
                "songs": {str(k): [list(n) for n in v] for k, v in sorted(c.songs.items())},
                "song_playing": c.song_playing, "song_number": c.song_number,
                "songs_played": list(c.songs_played),
                "last_demo": c.last_demo, "demo_running": c.demo_running,
                "docking_requested": c.docking_requested,
                "commands_executed": c.commands_executed,
                "commands_ignored": c.commands_ignored,
            }
        return TriggerResponse(True, json.dumps(state, sort_keys=True))

    def on_reopen(self, _event):
        with self.lock:
            if rospy.is_shutdown() or self.link.is_open:
                return
            self.link.reopen()
        self.announce()

    def shutdown(self):
        for timer in self.timers:
            timer.shutdown()
        with self.lock:
            self.link.close()


def main():
    rospy.init_node("virtual_create")
    try:
        VirtualCreateNode()
    except (ValueError, OSError) as exc:
        rospy.logfatal("virtual_create: cannot start: %s", exc)
        raise SystemExit(1) from exc
    rospy.spin()

