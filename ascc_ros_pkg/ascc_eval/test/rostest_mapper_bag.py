#!/usr/bin/env python3
"""rostest (mapper_corridor_bag.test): the slam_gmapping stand-in closes the corridor loop
from a bag that the real ``rosbag play`` plays.

The test writes the bag first (``ascc_eval.drive_bag``: ascc_sim's laser and wheel models
along the corridor's 242 m loop, thesis fig. 2.11), waits until the mapper has subscribed to
``scan``, plays it with ``rosbag play --clock`` at ``~rate`` and waits until the mapper has
had no update for a few seconds. Then the loop's end, 7 m past the start, back in known
space: the mapper's pose there (TF map -> odom composed with the recorded odometry at the
last scan) is off the truth by less than the mapper's own bound on a loop closure's
correction (``loop_max_correction_m``, read from its parameters), so the loop closes within
it, and its map (``dynamic_map``) agrees with the world's on more than ``~min_accuracy`` of
its known cells. Scans the mapper's queue let go (a loaded machine) are counted in the log,
as the node drops them online. Waits are on conditions with wall-clock guards."""
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np
import rosgraph
import rospy
import rostest
import tf2_ros
from nav_msgs.srv import GetMap
from std_msgs.msg import Float64

from ascc_common.grid import map_from_msg
from ascc_common.pose2d import compose, yaw_from_quaternion
from ascc_eval.drive_bag import ROUTES, sim_share, write_drive_bag
from ascc_navigation.grid import map_agreement
from ascc_navigation.posegraph import LoopClosureConfig
from ascc_sim.world import load_world
from ascc_testing.rosout import RosoutWatcher
from ascc_testing.waits import wait_for

MAPPER = "/slam_gmapping"


def mapper_subscribed(topic):
    _, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    return any(name == topic and MAPPER in nodes for name, nodes in subscribers)


class MapperBagTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("mapper_bag_test")
        cls.rate = float(rospy.get_param("~rate", 20.0))
        cls.seed = int(rospy.get_param("~seed", 1))
        cls.min_accuracy = float(rospy.get_param("~min_accuracy", 0.90))
        cls.bound_m = float(rospy.get_param(MAPPER + "/loop_max_correction_m",
                                            LoopClosureConfig().max_correction_m))
        cls.tmp = tempfile.mkdtemp(prefix="mapper_bag_")
        cls.updates = []    # wall time of each entropy message (one per filter update)
        rospy.Subscriber("slam_gmapping/entropy", Float64,
                         lambda _m: cls.updates.append(time.monotonic()))
        cls.log = RosoutWatcher()
        cls.tf = tf2_ros.Buffer(rospy.Duration(3600.0))
        cls.listener = tf2_ros.TransformListener(cls.tf)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_corridor_loop_from_a_bag(self):
        path = os.path.join(self.tmp, "corridor.bag")
        t0 = time.monotonic()
        drive = write_drive_bag(path, "corridor", ROUTES["corridor"], seed=self.seed)
        rospy.loginfo("mapper_bag: wrote %d scans (%.0f m, %.0f s) in %.1f s", len(drive.stamps),
                      drive.length_m, drive.stamps[-1] - drive.stamps[0], time.monotonic() - t0)
        wait_for(lambda: mapper_subscribed("/scan"), 60.0, "the mapper subscribed to /scan")
        t0 = time.monotonic()
        play = subprocess.run(["rosbag", "play", "--clock", "-q", "-r", str(self.rate), path],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                              timeout=600)
        self.assertEqual(play.returncode, 0, play.stderr)
        # the mapper's queue drains: no update for 3 s (its last one is the loop's end)
        wait_for(lambda: self.updates and time.monotonic() - self.updates[-1] > 3.0, 60.0,
                 "the mapper's last update")
        rospy.loginfo("mapper_bag: played in %.1f s; %d updates", time.monotonic() - t0,
                      len(self.updates))
        self.assertGreater(len(self.updates), 500, "too few filter updates for a 242 m loop")
        dropped = self.log.matching(node=MAPPER, contains=("dropped",))
        if dropped:
            rospy.loginfo("mapper_bag: the mapper dropped scans: %s", dropped[-1].text)

        # (no lookup timeout: under the bag's clock, stopped now, it would not run out)
        wait_for(lambda: self.tf.can_transform("map", "odom", rospy.Time(0)), 10.0,
                 "TF map -> odom")
        tr = self.tf.lookup_transform("map", "odom", rospy.Time(0))
        q = tr.transform.rotation
        map_odom = (tr.transform.translation.x, tr.transform.translation.y,
                    yaw_from_quaternion(q.x, q.y, q.z, q.w))
        end = compose(map_odom, drive.odom[-1])
        truth = drive.truth[-1]
        err = math.hypot(end[0] - truth[0], end[1] - truth[1])
        odom_err = math.hypot(drive.odom[-1][0] - truth[0], drive.odom[-1][1] - truth[1])
        rospy.loginfo("mapper_bag: end error %.3f m (the odometry's: %.2f m; the bound %.2f m)",
                      err, odom_err, self.bound_m)
        self.assertLess(err, self.bound_m,
                        "the loop's end is %.3f m off the truth, beyond the loop bound %.2f m "
                        "(odometry %.2f m)" % (err, self.bound_m, odom_err))

        rospy.wait_for_service("dynamic_map", 10.0)  # (wall time)
        grid, info = map_from_msg(rospy.ServiceProxy("dynamic_map", GetMap)().map)
        world = load_world(os.path.join(sim_share(), "worlds", "corridor.yaml"))
        acc = map_agreement(grid, info, world.truth_map.occupancy, world.truth_map.info)
        rospy.loginfo("mapper_bag: map agreement %.2f %% of %d known cells",
                      100.0 * acc["accuracy"], acc["known"])
        self.assertGreater(acc["accuracy"], self.min_accuracy, acc)
        self.assertTrue(np.isin(grid, (-1, 0, 100)).all())


if __name__ == "__main__":
    rostest.rosrun("ascc_eval", "mapper_corridor_bag", MapperBagTest, sys.argv)
