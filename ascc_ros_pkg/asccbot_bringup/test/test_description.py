"""The ASCCbot's URDF: it parses (ElementTree and urdfdom's check_urdf), has every frame of
the chosen layout, and its joint chain puts the sensors where ``mounts`` says."""
import math
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest

from ascc_common.params import ParamError, from_params
from asccbot_bringup import cli
from asccbot_bringup.description import DescriptionParams, base_dimensions, mounts, urdf


def _params(**given):
    return from_params(DescriptionParams, lambda name, default: given.get(name, default))


def _tree(p):
    root = ET.fromstring(urdf(p))
    links = {el.get("name") for el in root.findall("link")}
    joints = {}
    for j in root.findall("joint"):
        assert j.get("type") == "fixed"
        xyz = [float(v) for v in j.find("origin").get("xyz").split()]
        yaw = float(j.find("origin").get("rpy").split()[2])
        joints[j.find("child").get("link")] = (j.find("parent").get("link"), xyz, yaw)
    return root, links, joints


def _pose_in_base(joints, link, base="base_link"):
    """(x, y, z, yaw) of ``link`` in ``base`` through the chain of fixed joints."""
    chain = []
    while link != base:
        parent, xyz, yaw = joints[link]
        chain.append((xyz, yaw))
        link = parent
    x = y = z = th = 0.0
    for xyz, yaw in reversed(chain):
        c, s = math.cos(th), math.sin(th)
        x, y, z = x + c * xyz[0] - s * xyz[1], y + s * xyz[0] + c * xyz[1], z + xyz[2]
        th += yaw
    return x, y, z, th


@pytest.mark.parametrize("layout", ["omnivision", "webcam"])
@pytest.mark.parametrize("robot_model", ["create_1", "create_2"])
@pytest.mark.parametrize("telepresence", [False, True])
def test_frames_and_mounts(layout, robot_model, telepresence):
    p = _params(layout=layout, robot_model=robot_model, telepresence=telepresence)
    root, links, joints = _tree(p)
    assert root.tag == "robot"
    expected = {"base_link", "stand", "layer_1", "layer_2", "layer_3", "layer_4", "fitpc2",
                "laser", "camera", "left_wheel", "right_wheel"}
    expected |= {"telepresence_stand", "tablet", "kinect"} if telepresence else set()
    assert links == expected
    assert set(joints) == links - {"base_link"}  # a tree rooted at base_link
    for frame, pose in mounts(p).items():
        assert _pose_in_base(joints, frame) == pytest.approx(pose, abs=1e-6), frame
    # the layouts of 2.2: which sensor is on layer 3 and which on layer 4
    upper, lower = ("camera", "laser") if layout == "omnivision" else ("laser", "camera")
    assert joints[upper][0] == "layer_4" and joints[lower][0] == "layer_3"
    assert mounts(p)[upper][2] > mounts(p)[lower][2]
    # the base takes the selected model's size: wheels on its wheel base, body its diameter
    diameter, _, wheel_base = base_dimensions(robot_model)
    assert joints["left_wheel"][1][1] - joints["right_wheel"][1][1] == pytest.approx(wheel_base)
    body = root.find("link[@name='base_link']/visual/geometry/cylinder")
    assert float(body.get("radius")) * 2 == pytest.approx(diameter)


def test_models_differ_and_layer_heights_move_the_sensors():
    c1, c2 = base_dimensions("create_1"), base_dimensions("create_2")
    assert c1[0] == pytest.approx(0.33) and c1[2] == pytest.approx(0.258)
    assert c2[2] == pytest.approx(0.235) and c2[0] > c1[0]
    p = _params(layer_heights_m=[0.11, 0.2, 0.3, 0.6])
    assert mounts(p)["laser"][2] == pytest.approx(0.3 + p.laser_scan_height_m)
    assert mounts(p)["camera"][2] == pytest.approx(0.6 + p.q24_lens_height_m)


def test_frame_prefix_names_every_link():
    _, links, _ = _tree(_params(frame_prefix="robotA/"))
    assert links and all(n.startswith("robotA/") for n in links)


@pytest.mark.parametrize("given, word", [
    ({"layer_heights_m": [0.1, 0.3, 0.2, 0.5]}, "layer_heights_m"),
    ({"layer_heights_m": [0.05, 0.17, 0.24, 0.48]}, "layer_heights_m"),  # inside the Create
    ({"layout": "stereo"}, "layout"),
    ({"robot_model": "roomba"}, "robot_model"),
    ({"telepresence": True, "tablet_height_m": 1.2}, "tablet_height_m"),
])
def test_bad_parameters_are_named(given, word):
    with pytest.raises(ParamError, match=word):
        _params(**given)


def test_check_urdf_parses_every_variant(tmp_path):
    check = shutil.which("check_urdf")
    assert check, "check_urdf (Debian liburdfdom-tools, installed by scripts/setup.sh) missing"
    for layout in ("omnivision", "webcam"):
        path = tmp_path / ("%s.urdf" % layout)
        path.write_text(urdf(_params(layout=layout, telepresence=True)))
        out = subprocess.run([check, str(path)], capture_output=True, text=True, timeout=30)
        assert out.returncode == 0, out.stderr
        assert "root Link: base_link" in out.stdout


def test_cli_reads_roslaunch_style_arguments(capsys):
    assert cli.main(["layout:=webcam", "robot_model:=create_2", "telepresence:=true",
                     "layer_heights_m:=[0.1,0.2,0.3,0.5]", "frame_prefix:="]) == 0
    root = ET.fromstring(capsys.readouterr().out)
    assert root.find("link[@name='kinect']") is not None
    p = cli.parse(["layout:=webcam", "layer_heights_m:="])  # empty: the default
    assert p.layout == "webcam" and p.layer_heights_m == DescriptionParams().layer_heights_m
    assert cli.main(["layuot:=webcam"]) == 2
    assert "layuot" in capsys.readouterr().err
    assert cli.main(["layout:=stereo"]) == 2
    assert "layout" in capsys.readouterr().err
