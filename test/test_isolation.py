"""scripts/ros_isolation.sh (sourced by demo.sh): a run gets its own master on a free
loopback port unless the user set ROS_MASTER_URI, and binds to loopback unless ROS_IP or
ROS_HOSTNAME is set; two isolated launches side by side do not see each other."""
import os
import socket
import subprocess
import time
from urllib.parse import urlparse

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROS_VARS = ("ROS_MASTER_URI", "ROS_IP", "ROS_HOSTNAME", "ASCC_OWN_MASTER")


def _env(**given):
    env = {k: v for k, v in os.environ.items() if k not in ROS_VARS}
    env.update(given)
    return env


def _isolated(command, **given):
    return subprocess.run(["bash", "-c", "source scripts/ros_isolation.sh; " + command],
                          cwd=ROOT, env=_env(**given), capture_output=True, text=True,
                          timeout=60)


def test_own_master_on_a_free_loopback_port_by_default():
    out = [_isolated('echo "$ROS_MASTER_URI $ROS_IP $ASCC_OWN_MASTER"').stdout.split()
           for _ in range(2)]
    for uri, ip, own in out:
        assert urlparse(uri).hostname == "127.0.0.1" and urlparse(uri).port != 11311
        assert (ip, own) == ("127.0.0.1", "1")
    assert out[0][0] != out[1][0]


def test_the_users_settings_win():
    uri = "http://robot.local:11311"
    out = _isolated('echo "$ROS_MASTER_URI ${ROS_IP:-none} ${ASCC_OWN_MASTER:-0}"',
                    ROS_MASTER_URI=uri, ROS_HOSTNAME="laptop.local").stdout.split()
    assert out == [uri, "none", "0"]
    out = _isolated('echo "$ROS_IP"', ROS_IP="10.0.0.5").stdout.split()
    assert out == ["10.0.0.5"]


def _other_address():
    """A non-loopback address of this machine, or None."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.connect(("192.0.2.1", 9))  # TEST-NET-1: no packet is sent for a UDP connect
        addr = s.getsockname()[0]
    except OSError:
        return None
    finally:
        s.close()
    return None if addr.startswith("127.") else addr


def _reachable(host, port):
    try:
        socket.create_connection((host, port), timeout=2).close()
        return True
    except OSError:
        return False


def test_two_isolated_launches_side_by_side_on_loopback():
    """Two runs of the same launch file (same node names): each its own master, both
    alive, each master reachable on loopback only."""
    cmd = ('source env.sh; echo "$ROS_MASTER_URI"; exec roslaunch '
           'ascc_ros_pkg/asccbot_bringup/launch/description.launch')
    runs = [subprocess.Popen(["bash", "-c", "source scripts/ros_isolation.sh; " + cmd],
                             cwd=ROOT, env=_env(), stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True, start_new_session=True)
            for _ in range(2)]
    try:
        uris = [urlparse(r.stdout.readline().strip()) for r in runs]
        assert uris[0].port != uris[1].port
        deadline = time.time() + 90
        while not all(_reachable("127.0.0.1", u.port) for u in uris):
            assert time.time() < deadline, "the masters did not come up"
            assert all(r.poll() is None for r in runs), "a launch ended"
            time.sleep(1)
        # a master takes its nodes' registrations some time after it answers (CI saw
        # only /rosout at the first look): ask until both have theirs, or the deadline
        waiting = list(uris)
        while waiting:
            node_list = subprocess.run(
                ["bash", "-c", "source env.sh; rosnode list"], cwd=ROOT, timeout=60,
                env=_env(ROS_MASTER_URI=waiting[0].geturl(), ROS_IP="127.0.0.1"),
                capture_output=True, text=True).stdout.split()
            if "/robot_state_publisher" in node_list:
                waiting.pop(0)
                continue
            assert time.time() < deadline, (waiting[0].geturl(), node_list)
            assert all(r.poll() is None for r in runs), "a launch ended"
            time.sleep(1)
        other = _other_address()
        if other is None:
            pytest.skip("no non-loopback address to check the binding against")
        assert not any(_reachable(other, u.port) for u in uris)
        assert all(r.poll() is None for r in runs)  # neither shut the other down
    finally:
        for r in runs:
            if r.poll() is None:
                os.killpg(r.pid, 2)
        for r in runs:
            try:
                r.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(r.pid, 9)
