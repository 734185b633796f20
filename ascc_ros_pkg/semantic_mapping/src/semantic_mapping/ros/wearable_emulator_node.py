"""Node `wearable_emulator`: the two wearable sensor nodes and their XBee link, emulated
(thesis 5.4.1). Every 1/rate_hz s (ROS time: simulated time in the simulator) it renders a
sample of the person's activity for each sensor, at the sample's own time on the sensors'
clock (a late tick renders the samples it missed: `semantic_mapping.emulator.SampleClock`),
and writes the XBee frames to a pseudo-terminal, which `wearable_receiver` opens like the
USB port of a real XBee. The activity comes from ``ground_truth/people`` (the simulator's
scripted person, by name) or from a fixed script (``~script_activities``,
``~script_durations_s``). The signal model, the sleep/wake scheme and the frames are
`semantic_mapping.emulator.Emulator`.
Parameters: `semantic_mapping.emulator.EmulatorParams`.
"""
import threading

import rospy
from std_msgs.msg import String

from ascc_common.params import from_params
from ascc_common.pose2d import yaw_of
from ascc_sim.msg import SimObjectArray
from irobot_create_2_1.pty_link import PtyLink
from semantic_mapping.body_signals import Person
from semantic_mapping.emulator import Emulator, EmulatorParams, SampleClock, script_activity
from semantic_mapping.ros import run


class _Sink:
    """The PtyLink's device: the receiving XBee's host writes nothing we act on."""

    def feed(self, data):
        pass

    def read_output(self):
        return b""


class WearableEmulatorNode:
    def __init__(self):
        p = from_params(EmulatorParams, rospy.get_param, "~")
        self.p = p
        self.emu = Emulator(Person.from_seed(p.seed), dict(zip(p.sensor_positions,
                                                               p.sensor_ids)),
                            p.rate_hz, p.power, p.power_aware)
        self.link = PtyLink(_Sink(), p.link_path or None)
        self.lock = threading.Lock()
        self.latest = None  # (activity, heading) of the person, newest ground truth
        self.start = None
        self.clock = SampleClock(p.rate_hz)
        self.true_pub = rospy.Publisher("~true_activity", String, queue_size=10, latch=True)
        self.last_label = None
        if not p.script_activities:
            rospy.Subscriber("ground_truth/people", SimObjectArray, self.on_people,
                             queue_size=1)
        rospy.on_shutdown(self.link.close)
        rospy.Timer(rospy.Duration(1.0 / p.rate_hz), self.on_tick)
        rospy.loginfo("wearable emulator: person %r (seed %d), sensors %s on %s",
                      p.person, p.seed, ", ".join("%s=0x%04X" % kv for kv in zip(
                          p.sensor_positions, p.sensor_ids)), self.link.port)

    def on_people(self, msg):
        """Store the newest activity of our person (the work is on the timer)."""
        for obj in msg.objects:
            if obj.name == self.p.person:
                with self.lock:
                    self.latest = (obj.activity or "standing", yaw_of(obj.pose.orientation))
                return
        rospy.logwarn_throttle(10.0, "wearable emulator: no person %r in ground_truth/people "
                               "(%d objects); the sensors send nothing"
                               % (self.p.person, len(msg.objects)))

    def on_tick(self, event):
        now = event.current_real if event.current_real else rospy.Time.now()
        if self.start is None or now < self.start:
            self.start = now  # first tick, or simulated time went back
            self.clock.reset()
        skipped = self.clock.skipped
        times = self.clock.due((now - self.start).to_sec())
        if self.clock.skipped > skipped:
            rospy.logwarn_throttle(10.0, "wearable emulator: %d samples skipped (more than "
                                   "1 s behind: a jump of time or a stalled node)"
                                   % (self.clock.skipped - skipped))
        if not self.p.script_activities:
            with self.lock:
                latest = self.latest
            if latest is None:
                return
        data = bytearray()
        for t in times:
            if self.p.script_activities:
                activity, heading = script_activity(self.p.script_activities,
                                                    self.p.script_durations_s, t), 0.0
            else:
                activity, heading = latest
            data += self.emu.step(t, activity, heading)
        self.link.pump()
        if data:
            self.link.inject(bytes(data))
        if self.emu.segment != self.last_label:
            self.last_label = self.emu.segment
            self.true_pub.publish(String(self.emu.segment))


def main():
    run("wearable_emulator", WearableEmulatorNode, "wearable emulator")
