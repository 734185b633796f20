"""Every launch file of the stack loads, as ``roslaunch-check`` checks it, in stand-in mode
with its documented arguments: roslaunch's own loader (includes, ``$(find)``, ``command=``
params, ``rosparam`` files, ``if``/``unless``) and every node's package and executable found.

``roslaunch-check`` itself cannot do it: it takes no launch arguments (environment
variables only) and checks the dependencies of the package a file is in, which the
top-level ``launch/`` files are not. No master is needed.
A node of a package Debian 12 lacks (urg_node, gmapping, ...) is started through
``asccbot_bringup``'s ``run_if_installed``, so it does not fail the load; this test fails
on a bare ``pkg="urg_node"``.
"""
import functools
import glob
import os
import xml.etree.ElementTree as ET

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OFFICE = os.path.join(ROOT, "ascc_ros_pkg", "ascc_sim", "worlds", "office.yaml")

# Values for arguments without a default (the files' docs say what they are).
REQUIRED = {"world": OFFICE, "url": "http://127.0.0.1:9/faststream.jpg", "ns": "robotA",
            "link_dir": "/tmp/ascc_launch_check", "robots": "/", "port": "/tmp/pty_create",
            "frame_prefix": "robotA/", "cmd_timeout_s": "0.5", "robot": "robotA",
            "x": "1.0", "y": "1.0", "a": "0.0", "output_file": "/tmp/ascc_calibration.yaml"}
# Documented argument sets beyond the defaults (the header comments' examples); every set
# is checked with the stand-ins (use_stand_in(s):=true where the file has that argument).
VARIANTS = {
    "launch/robot/asccbot.launch": [
        {"sim": "true"}, {"sim": "true", "robot_model": "create_2", "sim_camera": "true"},
        {"laser_driver": "hokuyo_node", "camera_url": REQUIRED["url"], "layout": "webcam",
         "telepresence": "true", "robot_model": "create_2"}],
    "launch/robot/explore.launch": [{"sim": "true"}, {"strategy": "nearest"}],
    "launch/robot/create.launch": [{"navigation": "true", "robot_model": "create_2"}],
    "launch/robot/follow.launch": [{"laser": "false", "kind": "cone"}],
    "launch/robot/telepresence.launch": [
        {"camera_url": REQUIRED["url"], "kinect": "false", "robot_model": "create_2"},
        {"operator_host": "127.0.0.1", "operator_user": "ascc"}],
    "launch/sim/telepresence.launch": [{"gui": "false", "gestures": "false"},
                                       {"episodes": "rest,come_close", "gui_args": "--dialog"}],
    "launch/explore_demo.launch": [{"world": "lab", "strategy": "nearest"}],
    "launch/sim/office.launch": [{"rviz": "true"}, {"web_console": "true", "console_port": "0"}],
    "ascc_ros_pkg/asccbot_bringup/launch/description.launch": [
        {"layout": "webcam", "robot_model": "create_2", "telepresence": "true",
         "layer_heights_m": "[0.1,0.2,0.3,0.6]", "frame_prefix": "robotA/"}],
    "ascc_ros_pkg/asccbot_bringup/launch/descriptions.launch": [
        {"robots": "robotA robotB robotC", "layout": "webcam", "robot_model": "create_2"}],
    "launch/sim/three_robots.launch": [{"description": "true"}, {"rviz": "true"}],
    "launch/sim/colloc.launch": [{"description": "true", "setup": "distributed"}],
}


def _launch_files():
    files = sorted(glob.glob(os.path.join(ROOT, "launch", "**", "*.launch"), recursive=True)
                   + glob.glob(os.path.join(ROOT, "ascc_ros_pkg", "*", "launch", "*.launch")))
    return [os.path.relpath(f, ROOT) for f in files]


@functools.lru_cache(maxsize=None)
def _args_of(rel):
    """The top-level <arg> elements of a launch file."""
    return ET.parse(os.path.join(ROOT, rel)).getroot().findall("arg")


def _cases():
    for rel in _launch_files():
        arg_elems = _args_of(rel)
        declared = {a.get("name") for a in arg_elems}
        base = {a.get("name"): REQUIRED[a.get("name")] for a in arg_elems
                if a.get("default") is None and a.get("value") is None}
        base.update({n: "true" for n in ("use_stand_in", "use_stand_ins") if n in declared})
        for extra in [{}] + VARIANTS.get(rel, []):
            args = dict(base, **extra)
            yield pytest.param(rel, args, id="%s[%s]" % (rel, " ".join(
                "%s:=%s" % kv for kv in sorted(extra.items()))))


def _check(rel, args):
    """roslaunch's loader over the file with ``args``; the problems found, as text."""
    import roslaunch.config
    import roslib.packages
    import rospkg
    path = os.path.join(ROOT, rel)
    argv = ["%s:=%s" % kv for kv in sorted(args.items())]
    config = roslaunch.config.load_config_default([(path, argv)], None, verbose=False)
    problems, rospack = [], rospkg.RosPack()
    for node in config.nodes + config.tests:
        try:
            found = roslib.packages.find_node(node.package, node.type, rospack=rospack)
        except rospkg.ResourceNotFound:
            found = None
        if not found:
            problems.append("node %s: no executable %s/%s" % (node.name, node.package,
                                                              node.type))
    return config, problems


@functools.lru_cache(maxsize=None)
def _loaded(rel, items):
    """``_check`` once per file and argument set (``items``: sorted (name, value) pairs);
    the tests below only read the config."""
    return _check(rel, dict(items))


def test_every_launch_file_is_covered():
    files = _launch_files()
    assert "launch/robot/asccbot.launch" in files and "launch/robot/explore.launch" in files
    assert set(VARIANTS) <= set(files)
    assert len(files) >= 25


@pytest.mark.parametrize("rel, args", list(_cases()))
def test_launch_file_loads_with_its_documented_arguments(rel, args):
    config, problems = _loaded(rel, tuple(sorted(args.items())))
    assert problems == [], "%s %s" % (rel, args)
    assert config.nodes or config.params, "%s starts nothing" % rel


def test_bring_up_starts_the_robot_and_checks_the_real_navigation():
    """asccbot.launch on hardware: driver, Hokuyo (through run_if_installed), camera,
    description, aggregator; in sim the simulator instead. explore.launch without the
    stand-ins starts the required package check naming use_stand_ins:=true."""
    config, _ = _check("launch/robot/asccbot.launch", {"camera_url": REQUIRED["url"]})
    names = {n.name: n for n in config.nodes}
    assert {"irobot_create_2_1", "urg_node", "q24_camera", "robot_state_publisher",
            "diagnostic_aggregator"} <= set(names)
    assert names["urg_node"].package == "asccbot_bringup"
    assert "urg_node urg_node" in names["urg_node"].args
    assert config.params["/urg_node/serial_port"].value == "/dev/hokuyo"
    assert config.params["/irobot_create_2_1/port"].value == "/dev/create"
    assert "<robot" in config.params["/robot_description"].value
    config, _ = _check("launch/robot/asccbot.launch", {"sim": "true"})
    names = {n.name for n in config.nodes}
    assert "simulator" in names and "urg_node" not in names and "q24_camera" not in names
    config, problems = _check("launch/robot/explore.launch", {})
    check = [n for n in config.nodes if n.name == "check_navigation"]
    assert len(check) == 1 and check[0].required
    assert "use_stand_ins:=true" in check[0].args and "gmapping move_base" in check[0].args
    assert problems  # gmapping and move_base are not on Debian 12: the real ones are named


@pytest.mark.parametrize("rel", ["launch/sim/three_robots.launch", "launch/sim/colloc.launch"])
def test_three_robots_each_have_their_description(rel):
    """description:=true: robotA/B/C each with robot_description (every link prefixed by
    its namespace, as docs/DESIGN.md wants frames) and a robot_state_publisher."""
    config, problems = _check(rel, {"description": "true"})
    assert problems == []
    publishers = {n.namespace + n.name for n in config.nodes
                  if n.package == "robot_state_publisher"}
    for robot in ("robotA", "robotB", "robotC"):
        assert "/%s/robot_state_publisher" % robot in publishers
        urdf = ET.fromstring(config.params["/%s/robot_description" % robot].value)
        links = [e.get("name") for e in urdf.iter("link")]
        assert "%s/camera" % robot in links and "%s/laser" % robot in links
        assert [n for n in links if not n.startswith(robot + "/")] == []
    assert "/robot_description" not in config.params
    config, _ = _check(rel, {})  # without rviz, no description unless asked for
    assert not any(n.package == "robot_state_publisher" for n in config.nodes)


def _with_descriptions():
    """Every case of every file, and description:=true where a file has that argument
    and no case sets it."""
    cases = list(_cases())
    yield from cases
    for rel in _launch_files():
        mine = [c.values[1] for c in cases if c.values[0] == rel]
        if ("description" in {a.get("name") for a in _args_of(rel)}
                and not any(a.get("description") == "true" for a in mine)):
            base = dict(mine[0])
            yield pytest.param(rel, dict(base, description="true"),
                               id="%s[description:=true]" % rel)


@pytest.mark.parametrize("rel, args", list(_with_descriptions()))
def test_the_laser_frame_has_one_static_publisher(rel, args):
    """tf2 keeps one parent per frame, the last static transform received: a robot
    description's layer_3 -> laser and the simulator's base_link -> laser would replace
    each other, whichever latched last (system_sim.test saw both). A launch that starts
    both a simulator and a robot_state_publisher turns the simulator's mount off."""
    config, _ = _loaded(rel, tuple(sorted(args.items())))
    mounts = [k for k, v in config.params.items()
              if k.endswith("/simulator/publish_laser_mount") and v.value]
    publishers = [n.namespace + n.name for n in config.nodes
                  if n.package == "robot_state_publisher"]
    assert not (mounts and publishers), "%s %s: %s and %s" % (rel, args, mounts, publishers)


def test_explore_demo_loads_a_wheel_calibration_into_the_driver(tmp_path):
    # what ascc_sim's calibrate.launch writes (calibrate_odometry's ~output_file)
    path = tmp_path / "calibration_seed0.yaml"
    path.write_text("odom_linear_scale_correction: 0.99500  # +- 0.00020, 10 runs\n")
    config, problems = _check("launch/explore_demo.launch", {"odom_calibration": str(path)})
    assert problems == []
    assert config.params["/driver/odom_linear_scale_correction"].value == 0.995
    config, _ = _check("launch/explore_demo.launch", {})
    assert "/driver/odom_linear_scale_correction" not in config.params
