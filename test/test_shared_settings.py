"""Settings that must agree across packages (docs/DESIGN.md, "Shared settings").

cmd_timeout_s is one launch argument in the launch files that start both driver and
navigator; these checks cover the package defaults behind it and the copies that live in
two YAML files because two programs read them.
"""
import math
import os
import re

import pytest
import yaml

from ascc_common.params import from_params, tree_getter
from ascc_navigation.navigation import MoveBaseParams, NavParams
from irobot_create_2_1.models import model

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PKG = os.path.join(ROOT, "ascc_ros_pkg")


def _yaml(*path):
    with open(os.path.join(PKG, *path)) as f:
        return yaml.safe_load(f)


def _arg_default(path, name):
    with open(os.path.join(ROOT, path)) as f:
        text = f.read()
    found = re.search(r'<arg name="%s" default="([^"]*)"' % name, text)
    assert found, "%s has no arg %s" % (path, name)
    return float(found.group(1))


def test_cmd_timeout_defaults_agree():
    driver = _yaml("irobot_create_2_1", "config", "create.yaml")["cmd_timeout_s"]
    assert NavParams().base_cmd_timeout == driver
    for path in ("launch/explore_demo.launch", "launch/robot/create.launch",
                 "ascc_ros_pkg/irobot_create_2_1/launch/create.launch",
                 "ascc_ros_pkg/ascc_sim/launch/sim.launch",
                 "ascc_ros_pkg/ascc_navigation/launch/move_base.launch",
                 "ascc_ros_pkg/ascc_navigation/test/navigation_office.test",
                 "ascc_ros_pkg/ascc_eval/test/explore_office_sim.test"):
        assert _arg_default(path, "cmd_timeout_s") == driver, path


def test_wheel_base_of_driver_and_simulated_create_agree():
    # the driver's 0 means its robot model's wheel base (the simulated ASCCbot's default
    # model is the Create 1; a create_2 robot in a world file takes the Create 2's)
    driver = _yaml("irobot_create_2_1", "config", "create.yaml")
    wheel_base_m = driver["wheel_base_m"] or model(driver["robot_model"]).wheel_base_m
    assert wheel_base_m == _yaml("ascc_sim", "config", "asccbot.yaml")["wheel_base_m"]


def test_move_base_costmaps_agree_and_the_stand_in_reads_them():
    config = _yaml("ascc_navigation", "config", "move_base.yaml")
    glob, local = config["global_costmap"], config["local_costmap"]
    assert glob["robot_radius"] == local["robot_radius"]
    for key in ("obstacle_range", "raytrace_range"):
        assert glob["obstacle_layer"][key] == local["obstacle_layer"][key]
    for key in ("inflation_radius", "cost_scaling_factor"):
        assert glob["inflation_layer"][key] == local["inflation_layer"][key]
    p = from_params(MoveBaseParams, tree_getter(config))
    assert p.planner.robot_radius == p.controller.robot_radius == glob["robot_radius"]


def test_laser_range_used_by_mapper_and_explorer_is_the_urg04lx_range():
    urg = _yaml("ascc_sim", "config", "urg04lx.yaml")["range_max_m"]
    usable = _yaml("ascc_navigation", "config", "gmapping.yaml")["maxUrange"]
    assert usable == _yaml("frontier_detector", "config", "explorer.yaml")["sensor_range_m"]
    assert usable <= urg


def test_follow_distance_defaults_agree():
    """The follower's set point and the one follow_monitor measures against: one launch
    argument in the follow launch files, the same default in both dataclasses."""
    from ascc_eval.follow_eval import FollowMonitorParams
    from target_follower.follower import FollowerParams
    d = FollowerParams().distance_m
    assert FollowMonitorParams().distance_m == d
    for path in ("launch/sim/follow.launch", "launch/robot/follow.launch",
                 "ascc_ros_pkg/target_follower/launch/follow.launch"):
        assert _arg_default(path, "distance_m") == d, path


def test_camera_mount_defaults_agree():
    """The camera model's mount (the detector's and the simulated camera's default) and
    the launch arguments that set the detector's model and the robot's camera TF."""
    from ascc_common.camera_model import PanoramicCamera
    cam = PanoramicCamera()
    mount = {"camera_x_m": cam.mount_x_m, "camera_y_m": cam.mount_y_m,
             "camera_z_m": cam.mount_z_m, "camera_yaw_rad": cam.mount_yaw_rad}
    for path in ("launch/robot/follow.launch",
                 "ascc_ros_pkg/target_follower/launch/follow.launch"):
        for name, value in mount.items():
            assert _arg_default(path, name) == value, (path, name)


def test_robot_description_agrees_with_the_simulated_robot():
    """The URDF's sensor mounts (omnivision layout, the simulated ASCCbot's) and base:
    the simulator's laser mount (asccbot.yaml), the camera model's mount (the simulated
    Q24's and the detector's default), the simulator's footprint and wheel base."""
    from ascc_common.camera_model import PanoramicCamera
    from asccbot_bringup.description import DescriptionParams, base_dimensions, mounts
    p = DescriptionParams()
    assert p.layout == "omnivision" and p.robot_model == "create_1"
    m = mounts(p)
    sim = _yaml("ascc_sim", "config", "asccbot.yaml")
    sim_laser = (sim["laser_x_m"], sim["laser_y_m"], sim["laser_z_m"],
                 math.radians(sim["laser_yaw_deg"]))
    assert m["laser"] == pytest.approx(sim_laser, abs=1e-9)
    cam = PanoramicCamera()
    assert m["camera"] == pytest.approx(
        (cam.mount_x_m, cam.mount_y_m, cam.mount_z_m, cam.mount_yaw_rad), abs=1e-9)
    diameter, _, wheel_base = base_dimensions("create_1")
    assert 2 * sim["radius_m"] == pytest.approx(diameter)
    assert sim["wheel_base_m"] == wheel_base
