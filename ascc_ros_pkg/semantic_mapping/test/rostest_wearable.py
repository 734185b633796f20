#!/usr/bin/env python3
"""rostest: wearable_emulator -> pty -> wearable_receiver on a fixed script, and a second
receiver fed bad input (garbage, unknown ids, a bad checksum, a truncated frame, a silent
sensor) through a pty this test writes."""
import os
import time
import tty
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs.msg import Imu
from std_msgs.msg import String

from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import Latest, wait_for
from semantic_mapping.wearable import Sample, encode_sample
from semantic_mapping.xbee import encode_rx16


def norms(msgs):
    return np.array([np.linalg.norm([m.linear_acceleration.x, m.linear_acceleration.y,
                                     m.linear_acceleration.z]) for m in msgs])


class WearableLinkTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("wearable_test")
        cls.rosout = RosoutWatcher()
        cls.waist = Latest("wearable/waist/imu", Imu, keep_all=True)
        cls.thigh = Latest("wearable/thigh/imu", Imu, keep_all=True)
        cls.truth = Latest("wearable_emulator/true_activity", String, keep_all=True)
        cls.bad_waist = Latest("bad/wearable/waist/imu", Imu, keep_all=True)
        cls.last_waist = [time.monotonic()]
        rospy.Subscriber("wearable/waist/imu", Imu,
                         lambda _m: cls.last_waist.__setitem__(0, time.monotonic()))

    def test_1_emulated_sensors_walk_sit_sleep_and_wake(self):
        self.waist.wait(30.0, count=20)
        streaming = time.monotonic()  # before: "cannot open" until the emulator's pty exists
        self.assertEqual(self.waist.msg.header.frame_id, "wearable_waist")
        self.assertEqual(self.truth.all[0].data, "walking")
        n0, t0 = self.waist.count, time.monotonic()
        wait_for(lambda: time.monotonic() - t0 > 2.0 or any(
            m.data != "walking" for m in self.truth.all), 5.0, "2 s of walking")
        rate = (self.waist.count - n0) / (time.monotonic() - t0)
        self.assertTrue(14.0 < rate < 26.0, "waist rate %.1f Hz while walking" % rate)
        walking = list(self.waist.all)
        self.assertGreater(np.std(norms(walking)), 0.5)   # the gait's bounce
        self.assertLess(abs(np.mean(norms(walking)) - 9.81), 0.5)
        wait_for(lambda: any(m.data == "sitting" for m in self.truth.all), 20.0, "sitting")
        n_thigh = self.thigh.count
        self.thigh.wait(10.0, count=n_thigh + 10)
        z = [m.linear_acceleration.z for m in self.thigh.all[n_thigh:]]
        self.assertGreater(np.median(z), 8.5)             # the thigh lies flat
        # still: both sensors go to sleep (the waist stops sending for a while)
        wait_for(lambda: time.monotonic() - self.last_waist[0] > 3.0, 40.0,
                 "the waist sensor asleep")
        asleep_at = self.waist.count
        # the script repeats: walking wakes them
        self.waist.wait(45.0, count=asleep_at + 20)
        self.assertEqual(self.rosout.matching(node="/wearable_receiver", level="warn",
                                              since_wall_s=streaming), [])

    def test_2_bad_input_is_warned_and_the_good_stream_goes_on(self):
        path = rospy.get_param("~bad_link")
        master, slave = os.openpty()
        tty.setraw(slave)
        os.symlink(os.ttyname(slave), path)
        self.addCleanup(os.unlink, path)
        self.addCleanup(os.close, master)
        self.addCleanup(os.close, slave)
        self.rosout.wait_for_connection()
        node = "/bad/bad_receiver"

        def good(seq):
            s = Sample(seq, (9.75, 0.0, 0.5), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
            return encode_rx16(1, encode_sample(s))

        # the receiver reads the pty once a frame written to it comes out (its "open" log
        # line may be published before this test's /rosout subscription is connected)
        probe = [0, 0.0]  # frames written, wall time of the last one

        def through():
            if time.monotonic() - probe[1] >= 0.1:
                os.write(master, good(probe[0]))
                probe[0] += 1
                probe[1] = time.monotonic()
            return self.bad_waist.count > 0

        wait_for(through, 20.0, "the receiver reading the pty")
        time.sleep(0.5)  # probe frames still on their way
        base = self.bad_waist.count

        bad_checksum = bytearray(good(1000))
        bad_checksum[-1] ^= 0xFF
        extras = {5: b"\x00\x13\x11garbage", 10: encode_rx16(7, encode_sample(Sample(
            0, (0.0,) * 3, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0)))), 15: bytes(bad_checksum)}
        sent = 0
        first = probe[0]  # sequence numbers go on after the probes
        for i in range(60):
            os.write(master, extras.get(i, b"") + good(first + i))
            sent += 1
            time.sleep(0.05)
        os.write(master, good(first + 60)[:12])   # truncated: then nothing for 1 s
        time.sleep(1.0)
        for i in range(61, 81):
            os.write(master, good(first + i))
            sent += 1
            time.sleep(0.05)
        self.bad_waist.wait(15.0, count=base + sent)
        wait_for(lambda: self.rosout.matching(node=node, contains=("thigh", "silent")),
                 10.0, "the silent-thigh warning")
        time.sleep(0.5)  # later duplicates of any warning would show up here
        for needle in ("unknown sensor id 0x0007", "bad checksum", "outside any frame",
                       "cut short", "sensor thigh (0x0002) is silent"):
            got = self.rosout.matching(node=node, level="warn", contains=(needle,))
            self.assertEqual(len(got), 1, "%r warned %d times" % (needle, len(got)))
        self.assertEqual(self.bad_waist.count, base + sent)
        self.assertEqual([round(m.linear_acceleration.x, 2)
                          for m in self.bad_waist.all[base:base + 2]], [9.75, 9.75])


if __name__ == "__main__":
    rostest.rosrun("semantic_mapping", "wearable_link", WearableLinkTest)
