#!/usr/bin/env python3
"""rostest (inline_publisher.test): ``InlinePublisher``, the driver's odom/TF publisher,
writes in the caller's thread but a subscriber that stops reading never blocks it.

Two subscribers of one topic: this test node itself (live) and a second process (stalled),
which the test stops with SIGSTOP once it has received a first message. The test then
publishes 4 KiB messages from a thread, waiting every 10 messages until the live subscriber
has them all, until the stalled one's socket is full and the publisher skips it. Checked:
  * the publishing thread finishes (a plain ``queue_size=None`` rospy publisher blocks in
    ``sendall`` here, forever: a 60 s guard tells the two apart);
  * only the stalled subscriber is skipped (the skips are counted under its name and
    reported through ``on_skip``), and the live one receives every message in order;
  * after SIGCONT the stalled subscriber reads again and receives messages published
    after it resumed.
"""
import signal
import subprocess
import sys
import tempfile
import threading
import unittest

import rospy
import rostest
from std_msgs.msg import String

from ascc_testing.waits import wait_for
from irobot_create_2_1.ros.inline_publisher import InlinePublisher

TOPIC = "inline_chatter"
STALLED = "/stalled_listener"
SIZE = 4096          # bytes per message: the stopped socket fills within a few thousand;
                     # under a third of TCP's initial 16 KiB send buffer, so room is room
BATCH = 10           # the live subscriber is waited for every this many messages
MAX_MESSAGES = 20000  # 80 MB: far more than the stalled socket's buffers can hold
LISTENER = """import rospy, sys
from std_msgs.msg import String
rospy.init_node(sys.argv[1].lstrip('/'))
def cb(m):
    print(m.data[:9], flush=True)
rospy.Subscriber(sys.argv[2], String, cb)
rospy.spin()
"""


def message(i):
    head = "%08d " % i
    return String(data=head + "x" * (SIZE - len(head)))


class InlinePublisherTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("inline_publisher_test")
        cls.lock = threading.Lock()
        cls.live = []   # numbers of the messages the live subscriber received, in order
        cls.skips = []  # (subscriber, count) as on_skip reported them
        rospy.Subscriber(TOPIC, String, cls.on_live)
        cls.pub = InlinePublisher(TOPIC, String, on_skip=lambda who, n: cls.skips.append(
            (who, n)))
        cls.out = tempfile.NamedTemporaryFile("w+", prefix="stalled_", suffix=".txt")
        cls.proc = subprocess.Popen(
            [sys.executable, "-c", LISTENER, STALLED, rospy.resolve_name(TOPIC)],
            stdout=cls.out, stderr=subprocess.DEVNULL)

    @classmethod
    def tearDownClass(cls):
        if cls.proc.poll() is None:
            cls.proc.send_signal(signal.SIGCONT)
            cls.proc.kill()
            cls.proc.wait()
        cls.out.close()

    @classmethod
    def on_live(cls, msg):
        with cls.lock:
            cls.live.append(int(msg.data[:8]))

    def received_by_stalled(self):
        with open(self.out.name) as f:
            return [int(line) for line in f.read().split() if line.isdigit()]

    def live_count(self):
        with self.lock:
            return len(self.live)

    def test_a_stopped_subscriber_is_skipped_not_waited_for(self):
        wait_for(lambda: self.pub.get_num_connections() == 2, 30.0, "both subscribers")
        sent = []

        def publish(i):
            self.pub.publish(message(i))
            sent.append(i)

        # a first message reaches the second process before it is stopped
        i = 0
        while not self.received_by_stalled():
            publish(i)
            i += 1
            wait_for(lambda: self.live_count() == len(sent), 10.0, "the live subscriber")
            rospy.sleep(0.05)
        self.proc.send_signal(signal.SIGSTOP)

        done = threading.Event()
        errors = []

        def flood(start):
            try:
                for k in range(start, start + MAX_MESSAGES):
                    publish(k)
                    if (k + 1) % BATCH == 0:
                        wait_for(lambda: self.live_count() == len(sent), 10.0,
                                 "the live subscriber")
                    if self.pub.skipped.get(STALLED, 0) >= 3 * BATCH:
                        break
            except Exception as e:  # noqa: BLE001 (reported below)
                errors.append(e)
            done.set()

        thread = threading.Thread(target=flood, args=(i,), daemon=True)
        thread.start()
        finished = done.wait(60.0)
        self.assertTrue(finished, "publishing blocked on the stopped subscriber after %d "
                        "messages (%s skipped)" % (len(sent), self.pub.skipped))
        self.assertEqual(errors, [])
        stalled_skips = self.pub.skipped.get(STALLED, 0)
        rospy.loginfo("inline publisher: the stopped subscriber was skipped after %d "
                      "messages of %d bytes", len(sent) - stalled_skips, SIZE)
        self.assertGreaterEqual(stalled_skips, 3 * BATCH, self.pub.skipped)
        self.assertEqual(set(self.pub.skipped), {STALLED}, "only the stopped subscriber")
        self.assertEqual([who for who, _ in self.skips], [STALLED] * stalled_skips)
        self.assertEqual([n for _, n in self.skips], list(range(1, stalled_skips + 1)))
        wait_for(lambda: self.live_count() == len(sent), 10.0, "the live subscriber")
        with self.lock:
            self.assertEqual(self.live, sent, "the live subscriber gets every message in order")

        # resumed, the stopped subscriber reads its backlog, then gets new messages again
        self.proc.send_signal(signal.SIGCONT)
        resumed_from = len(sent) + 1000000  # numbers above any sent before the resume
        k = resumed_from

        def got_new():
            nonlocal k
            publish(k)
            k += 1
            rospy.sleep(0.05)
            return any(n >= resumed_from for n in self.received_by_stalled())

        wait_for(got_new, 60.0, "a message published after SIGCONT at the resumed "
                 "subscriber")
        self.assertIsNone(self.proc.poll(), "the resumed subscriber still runs")


if __name__ == "__main__":
    rostest.rosrun("irobot_create_2_1", "inline_publisher", InlinePublisherTest, sys.argv)
