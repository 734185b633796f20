#!/usr/bin/env python3
"""rostest (absent_devices.test): the bring-up without its devices stays up; the Create
driver warns naming its port and keeps retrying, q24_camera reports the dead URL, the
aggregator shows both as errors, and the description is still published."""
import sys
import time
import unittest

import rosnode
import rospy
import rostest
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import wait_for

PORT = "/tmp/asccbot_test_no_such_create"


class AbsentDevicesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("absent_devices_test")
        cls.rosout = RosoutWatcher()
        cls.buffer = tf2_ros.Buffer()
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    def test_bring_up_stays_up_and_says_what_is_missing(self):
        self.rosout.wait_for(60.0, "the driver's warning naming its port",
                             node="/irobot_create_2_1", level="warn",
                             contains=("cannot open", PORT))
        wanted = ("/ASCCbot/Create", "/ASCCbot/Camera")
        found = {}

        def errors_shown():
            msg = rospy.wait_for_message("/diagnostics_agg", DiagnosticArray, timeout=30.0)
            for s in msg.status:
                for w in wanted:
                    if s.name.startswith(w + "/") and s.level >= DiagnosticStatus.ERROR:
                        found[w] = s.message
            return all(w in found for w in wanted)
        wait_for(errors_shown, 90.0, "Create and Camera errors in /diagnostics_agg")
        # still retrying, still up: 10 s later the same nodes run
        time.sleep(10.0)
        nodes = set(rosnode.get_node_names())
        for node in ("/irobot_create_2_1", "/q24_camera", "/robot_state_publisher",
                     "/diagnostic_aggregator"):
            self.assertIn(node, nodes)
        self.assertNotIn("/urg_node", nodes)  # not installed: ended, named on its stderr
        wait_for(lambda: self.buffer.can_transform("base_link", "laser", rospy.Time(0)),
                 30.0, "the description's base_link -> laser")


if __name__ == "__main__":
    rostest.rosrun("asccbot_bringup", "absent_devices", AbsentDevicesTest, sys.argv)
