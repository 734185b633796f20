"""The packages' README parameter tables against the parameter dataclasses.

Every parameter a dataclass declares must be in its table, with the dataclass's default in
the "default" column (cells list several names and defaults in the same order, separated
by " / ", ";" or ","; one default in a cell of several names is theirs, e.g. a launch
argument and its node parameter; a leading "~" is dropped). Defaults written as formulas ("π/6",
"range_max − 0.01", "= period") and those of parameters unset by default (None: "random")
are not compared. Names the dataclass does not declare (launch-only arguments) are
skipped.
"""
import math
import os
import re

import pytest

from ascc_common.params import parameters
from ascc_eval.follow_eval import FollowMonitorParams
from ascc_navigation.mapper import SlamNodeParams
from ascc_navigation.mcl import MclNodeParams
from ascc_navigation.navigation import MoveBaseParams
from ascc_sim.camera_render import SimCameraParams
from ascc_sim.runner import SimulatorParams
from asccbot_bringup.description import DescriptionParams
from colloc_fusion.node_params import EstimatorParams, FusionParams
from frontier_detector.explorer import ExplorerNodeParams
from irobot_create_2_1.calibration import CalibrationParams
from irobot_create_2_1.driver_core import DriverParams
from irobot_create_2_1.square import DriveSquareParams
from irobot_create_2_1.virtual_create import VirtualCreateParams
from semantic_mapping.activity import RecognizerNodeParams
from semantic_mapping.emulator import EmulatorParams
from semantic_mapping.location import LocationParams
from semantic_mapping.semantic_map import SemanticMapperParams
from semantic_mapping.wearable import ReceiverParams
from target_follower.camera_driver import Q24CameraParams
from target_follower.color_detector import ColorParams
from target_follower.following import TargetFollowerParams
from target_follower.logo_detector import LogoParams
from target_follower.ros.target_detector_node import DetectorNodeParams
from telepresence.mux import VelocityMuxParams
from telepresence.ros.gesture_control_node import GestureControlNodeParams
from telepresence.ros.gesture_recognizer_node import GestureNodeParams
from telepresence.skeleton_sim import SkeletonSimParams
from telepresence.teleop import OperatorGuiParams
from web_console.params import WebConsoleParams

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# README -> the dataclass of each of its parameter tables, in order
TABLES = {
    "ascc_ros_pkg/ascc_navigation/README.md": [SlamNodeParams, MclNodeParams, MoveBaseParams],
    "ascc_ros_pkg/frontier_detector/README.md": [ExplorerNodeParams],
    "ascc_ros_pkg/ascc_sim/README.md": [SimulatorParams, SimCameraParams],
    "ascc_ros_pkg/ascc_eval/README.md": [FollowMonitorParams],
    "ascc_ros_pkg/colloc_fusion/README.md": [EstimatorParams, FusionParams],
    "ascc_ros_pkg/asccbot_bringup/README.md": [DescriptionParams],
    "ascc_ros_pkg/irobot_create_2_1/README.md": [DriverParams, VirtualCreateParams,
                                                 DriveSquareParams, CalibrationParams],
    "ascc_ros_pkg/target_follower/README.md": [Q24CameraParams, DetectorNodeParams, ColorParams,
                                                LogoParams, TargetFollowerParams],
    "ascc_ros_pkg/telepresence/README.md": [VelocityMuxParams, SkeletonSimParams,
                                             GestureNodeParams, GestureControlNodeParams,
                                             OperatorGuiParams],
    "ascc_ros_pkg/semantic_mapping/README.md": [LocationParams, ReceiverParams,
                                                 EmulatorParams, RecognizerNodeParams,
                                                 SemanticMapperParams],
    "ascc_ros_pkg/web_console/README.md": [WebConsoleParams],
}


def _tables(text):
    """[(header cells, rows of cells)] of the markdown tables with a "default" column."""
    out, lines = [], text.splitlines()
    for i, line in enumerate(lines):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and "default" in cells and "param" in cells[0]:
            rows = []
            for row in lines[i + 2:]:
                if not row.startswith("|"):
                    break
                rows.append([c.strip() for c in row.strip().strip("|").split("|")])
            out.append((cells, rows))
    return out


def _names(cell, known):
    """The cell's parameter names resolved against ``known`` (None where unknown); a name
    with a '/' (or a bare prefix ending in '/') sets the prefix of the names after it. A
    leading '~' (private name) is dropped."""
    names, prefix = [], ""
    for token in re.findall(r"`([^`]+)`", cell):
        token = token[1:] if token.startswith("~") else token
        if token.endswith("/"):
            prefix = token
            continue
        full = next((n for n in (prefix + token, token) if n in known), None)
        if "/" in token:
            prefix = (full or prefix + token).rsplit("/", 1)[0] + "/"
        names.append(full)
    return names


def _value(text):
    text = re.sub(r"\(.*?\)", "", text).strip()
    if text in ("true", "false"):
        return text == "true"
    try:
        return float(text)
    except ValueError:
        return text if re.fullmatch(r"[A-Za-z_]+", text) else None  # formulas: None


def _cases():
    for readme, classes in TABLES.items():
        with open(os.path.join(ROOT, readme)) as f:
            tables = _tables(f.read())
        assert len(tables) == len(classes), readme
        for cls, (header, rows) in zip(classes, tables):
            yield pytest.param(cls, header, rows, id="%s-%s" % (readme.split("/")[1],
                                                                cls.__name__))


@pytest.mark.parametrize("cls, header, rows", list(_cases()))
def test_readme_defaults_match_the_dataclass(cls, header, rows):
    known = {p.name: p.default for p in parameters(cls)}
    column = header.index("default")
    checked = set()
    for row in rows:
        names = _names(row[0], known)
        values = re.split(r"\s+/\s+|;\s*|,\s*", row[column])
        if len(values) == 1:
            values = values * len(names)  # one default for every name of the cell
        if len(values) != len(names):
            values = row[column].split()
        if not any(names):
            continue
        assert len(values) == len(names), "cannot pair %r with %r" % (row[0], row[column])
        for name, text in zip(names, values):
            checked.add(name)
            value = _value(text)
            if name is not None and isinstance(known[name], list):  # `0.1 0.2 0.3`, [1 2], []
                value = [_value(v) for v in text.strip().strip("`").strip("[]").split()]
            if name is None or value is None or known[name] is None:
                continue  # unknown name, a formula, or unset by default (said in words)
            default = known[name]
            if isinstance(default, (int, float)) and not isinstance(default, bool):
                assert isinstance(value, float) and math.isclose(value, default, rel_tol=1e-3), \
                    "%s: README says %r, the dataclass %r" % (name, text, default)
            else:
                assert value == default, "%s: README says %r, the dataclass %r" \
                    % (name, text, default)
    assert checked >= set(known), "parameters missing from the README: %s" \
        % sorted(set(known) - checked)
