"""ascc_eval.drive_bag: a scripted drive's bag, read back with the real rosbag and with
replay_mapper's RunBag (no master)."""
import math
import os
import sys

import numpy as np
import pytest
import yaml

rosbag = pytest.importorskip("rosbag")
from ascc_eval.drive_bag import ROUTES, sim_share, write_drive_bag  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import replay_mapper  # noqa: E402

ROUTE = ROUTES["office"][:3]  # 3 m east and a turn, about 25 s


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("drive") / "office.bag")
    return write_drive_bag(path, "office", ROUTE, seed=3)


def test_rosbag_reads_every_topic_in_time_order(drive):
    with rosbag.Bag(drive.path) as bag:
        info = bag.get_type_and_topic_info().topics
        n = len(drive.stamps)
        assert info["/scan"].message_count == n
        assert info["/tf"].message_count == n
        assert info["/ground_truth/asccbot/pose"].message_count == n
        assert info["/tf_static"].message_count == 1
        assert info["/ground_truth/map"].message_count == 1
        latched = {c.topic: c.header.get("latching") for c in bag._get_connections()}
        assert latched["/tf_static"] == b"1" and latched["/ground_truth/map"] == b"1"
        last_tf = None
        for topic, msg, t in bag.read_messages(topics=["/tf", "/scan"]):
            if topic == "/tf":
                last_tf = msg.transforms[0].header.stamp
            else:  # each scan after the odometry at its own stamp
                assert last_tf == msg.header.stamp
                assert t.to_sec() > msg.header.stamp.to_sec()


def test_run_bag_sees_the_robot_as_written(drive):
    run = replay_mapper.RunBag(drive.path)
    assert len(run.scans) == len(drive.stamps)
    with open(os.path.join(sim_share(), "config", "asccbot.yaml")) as f:
        robot = yaml.safe_load(f)
    assert run.mount.x == pytest.approx(robot["laser_x_m"])
    assert run.mount.y == pytest.approx(robot["laser_y_m"])
    # the odometry starts at the true start: the map frame of a replay is the world frame
    np.testing.assert_allclose(drive.odom[0], drive.truth[0], atol=1e-12)
    np.testing.assert_allclose(run.odom[:, 1:], drive.odom, atol=1e-6)
    np.testing.assert_allclose(run.truth[:, 1:], drive.truth, atol=1e-6)
    # the drive: from the first waypoint along the route, and the odometry off by a little
    assert math.hypot(*(drive.truth[0, :2] - ROUTE[0])) < 1e-9
    assert math.hypot(*(drive.truth[-1, :2] - ROUTE[-1])) < 0.05
    end_err = math.hypot(*(drive.odom[-1, :2] - drive.truth[-1, :2]))
    assert 0.0 < end_err < 0.1 * drive.length_m


def test_same_seed_same_bag_other_seed_other_scans(drive, tmp_path):
    again = write_drive_bag(str(tmp_path / "again.bag"), "office", ROUTE, seed=3)
    other = write_drive_bag(str(tmp_path / "other.bag"), "office", ROUTE, seed=4)
    np.testing.assert_array_equal(again.odom, drive.odom)
    scans = [np.array([s for _, s in replay_mapper.RunBag(d.path).scans])
             for d in (drive, again, other)]
    np.testing.assert_array_equal(scans[0], scans[1])
    assert not np.array_equal(scans[0], scans[2])
    assert not np.array_equal(other.odom, drive.odom)
