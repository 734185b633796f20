"""ascc_eval.launching.loopback_env: a benchmark's run on its own master, on loopback."""
from ascc_eval.launching import loopback_env


def test_own_master_on_loopback_by_default():
    env = loopback_env(12345, {"PATH": "/bin", "ROS_MASTER_URI": "http://localhost:11311"})
    assert env["ROS_MASTER_URI"] == "http://127.0.0.1:12345"
    assert env["ROS_IP"] == "127.0.0.1"
    assert env["PATH"] == "/bin"


def test_the_users_address_wins():
    assert loopback_env(1, {"ROS_IP": "10.0.0.5"})["ROS_IP"] == "10.0.0.5"
    env = loopback_env(1, {"ROS_HOSTNAME": "robot.local"})
    assert "ROS_IP" not in env and env["ROS_HOSTNAME"] == "robot.local"
