"""Node `wearable_receiver`: the PC's XBee (thesis 5.4.1, 5.4.2). Reads API-mode frames from
a serial port (pyserial; the emulator's pty in the simulator) and publishes each known
sensor's samples as sensor_msgs/Imu on ``wearable/<name>/imu``. The decoding, the streams
and the warnings are `semantic_mapping.wearable.ReceiverCore`; this file wires them to ROS.
Parameters: `semantic_mapping.wearable.ReceiverParams`.
"""
import threading
import time

import rospy
from sensor_msgs.msg import Imu

from ascc_common.paced_timer import PacedTimer
from ascc_common.params import from_params
from irobot_create_2_1.link import SerialLink
from semantic_mapping.ros import run
from semantic_mapping.wearable import ReceiverCore, ReceiverParams, SampleOut

CHECK_PERIOD_S = 0.1


class WearableReceiverNode:
    def __init__(self):
        p = from_params(ReceiverParams, rospy.get_param, "~")
        self.p = p
        self.core = ReceiverCore(dict(zip(p.sensor_ids, p.sensor_names)),
                                 p.silence_timeout_s, p.frame_timeout_s, p.warn_period_s)
        self.lock = threading.Lock()
        self.pubs = {name: rospy.Publisher("wearable/%s/imu" % name, Imu, queue_size=50)
                     for name in p.sensor_names}
        self.link = SerialLink(p.port, p.baud)
        self.stopping = False
        rospy.on_shutdown(self.shutdown)
        self.reader = threading.Thread(target=self.read_loop, name="xbee_reader",
                                       daemon=True)
        self.reader.start()
        # PacedTimer: wakes once per period, not on every /clock message of a simulator,
        # and stops when the shutdown starts (ascc_common.paced_timer)
        self.timer = PacedTimer(CHECK_PERIOD_S, self.on_check, rospy.get_time,
                                rospy.core.is_shutdown_requested, name="check")
        rospy.loginfo("wearable receiver: %s at %d baud, sensors %s", p.port, p.baud,
                      ", ".join("0x%04X=%s" % kv for kv in zip(p.sensor_ids, p.sensor_names)))

    def read_loop(self):
        was_open = False
        while not rospy.is_shutdown() and not self.stopping:
            opened = self.link.ensure_open()
            if opened != was_open:
                if opened:
                    rospy.loginfo("wearable receiver: %s open", self.p.port)
                else:
                    rospy.logwarn("wearable receiver: lost %s (%s); reopening with back-off",
                                  self.p.port, self.link.last_error)
                was_open = opened
            if not opened:
                rospy.logwarn_throttle(self.p.warn_period_s, "wearable receiver: cannot open "
                                       "%s: %s" % (self.p.port, self.link.last_error))
                time.sleep(0.05)
                continue
            data = self.link.read()
            if not data:
                continue
            try:
                now = rospy.Time.now()
            except rospy.ROSException:
                return  # shutting down
            with self.lock:
                out = self.core.feed(data, now.to_sec())
            self.emit(out, now)

    def on_check(self):
        now = rospy.Time.now()
        with self.lock:
            out = self.core.check(now.to_sec())
        self.emit(out, now)

    def emit(self, out, stamp):
        for o in out:
            if isinstance(o, SampleOut):
                self.pubs[o.sensor].publish(self.imu(o, stamp))
            else:
                rospy.logwarn("wearable receiver: %s", o.text)

    def imu(self, o, stamp):
        """Orientation, angular rate [rad/s] and acceleration [m/s^2] of one sample;
        covariances unknown (all zero, as sensor_msgs/Imu defines)."""
        msg = Imu()
        msg.header.stamp = stamp
        msg.header.frame_id = self.p.frame_prefix + o.sensor
        s = o.sample
        q = msg.orientation
        q.x, q.y, q.z, q.w = s.quat
        w = msg.angular_velocity
        w.x, w.y, w.z = s.gyro
        a = msg.linear_acceleration
        a.x, a.y, a.z = s.accel
        return msg

    def shutdown(self):
        self.stopping = True
        if self.reader is not threading.current_thread():
            self.reader.join(timeout=1.0)
        self.link.close()


def main():
    run("wearable_receiver", WearableReceiverNode, "wearable receiver")
