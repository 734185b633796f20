"""ascc_common.params: reading parameter dataclasses from a getter."""
import math
from dataclasses import dataclass
from typing import List, Optional

import pytest

from ascc_common.params import ParamError, from_params, nested, param, parameters, tree_getter


@dataclass
class _Inner:
    radius_m: float = param(0.17, "[m] robot radius", "robot_radius", gt=0.0)
    allow_unknown: bool = param(True, "plan through unknown cells")
    max_rounds: int = 400  # not a parameter


@dataclass
class _Outer:
    particles: int = param(30, "number of particles", ge=1)
    strategy: str = param("utility", "frontier choice", choices=("utility", "nearest"))
    share: float = param(0.5, "[-] a fraction", ge=0.0, le=1.0)
    inner: _Inner = nested(_Inner, "costmap/")

    def validate(self):
        if self.particles > 1000 and self.strategy == "nearest":
            raise ValueError("too many particles for nearest")


def test_defaults_and_names_with_prefix():
    got = []

    def get(name, default):
        got.append(name)
        return default

    out = from_params(_Outer, get, "~")
    assert out == _Outer()
    assert got == ["~particles", "~strategy", "~share", "~costmap/robot_radius",
                   "~costmap/allow_unknown"]


def test_values_are_converted_to_the_field_type():
    out = from_params(_Outer, {"particles": 12.0, "share": "0.25", "inner": 1}.get)
    assert out.particles == 12 and isinstance(out.particles, int) and out.share == 0.25
    tree = {"costmap": {"robot_radius": 1, "allow_unknown": "false"}}
    out = from_params(_Outer, tree_getter(tree))
    assert out.inner.radius_m == 1.0 and isinstance(out.inner.radius_m, float)
    assert out.inner.allow_unknown is False and out.inner.max_rounds == 400


@pytest.mark.parametrize("values, message", [
    ({"particles": 2.5}, "parameter particles: expected int, got 2.5"),
    ({"particles": "many"}, "parameter particles: expected int"),
    ({"particles": 0}, "parameter particles: must be >= 1, got 0"),
    ({"share": 1.5}, "parameter share: must be <= 1.0, got 1.5"),
    ({"strategy": "random"}, "parameter strategy: must be one of utility, nearest, got 'random'"),
    ({"costmap/robot_radius": 0.0}, "parameter costmap/robot_radius: must be > 0.0"),
    ({"costmap/allow_unknown": "maybe"}, "parameter costmap/allow_unknown: expected bool"),
    ({"particles": 2000, "strategy": "nearest"}, "too many particles for nearest"),
])
def test_bad_values_name_the_parameter(values, message):
    with pytest.raises(ParamError) as err:
        from_params(_Outer, values.get)
    assert message in str(err.value)


def test_parameters_lists_names_defaults_and_docs():
    listed = parameters(_Outer)
    assert [p.name for p in listed] == ["particles", "strategy", "share",
                                        "costmap/robot_radius", "costmap/allow_unknown"]
    assert listed[3].default == 0.17 and listed[3].doc == "[m] robot radius"
    assert listed[3].attr == "inner.radius_m"


def test_tree_getter_walks_slashes():
    get = tree_getter({"a": {"b": 1}, "c": 2})
    assert get("a/b", 0) == 1 and get("c", 0) == 2
    assert get("a/x", 5) == 5 and get("c/d", 5) == 5


@dataclass
class _Unset:
    seed: Optional[int] = param(None, "seed (unset: random)", ge=0)
    period_s: "Optional[float]" = param(None, "[s] period (unset: another one)", gt=0.0)


def test_optional_parameters_stay_unset_unless_given():
    assert from_params(_Unset, {}.get) == _Unset(None, None)
    out = from_params(_Unset, {"seed": 3.0, "period_s": "0.5"}.get)
    assert out.seed == 3 and isinstance(out.seed, int) and out.period_s == 0.5
    with pytest.raises(ParamError, match="parameter period_s: must be > 0.0"):
        from_params(_Unset, {"period_s": 0}.get)
    with pytest.raises(ParamError, match="parameter seed: expected int"):
        from_params(_Unset, {"seed": "x"}.get)


def test_none_default_needs_an_optional_type_and_optional_needs_none():
    @dataclass
    class NoneDefault:
        seed: int = param(None, "seed")

    @dataclass
    class OptionalWithDefault:
        seed: Optional[int] = param(3, "seed")

    for cls in (NoneDefault, OptionalWithDefault):
        with pytest.raises(TypeError, match="Optional"):
            from_params(cls, {}.get)


@dataclass
class _Lists:
    topics: List[str] = param(["map", "scan"], "topics to record")
    pose: Optional[List[float]] = param(None, "[m, m, rad] a pose", length=3)
    gains: "List[float]" = param([1.0], "[-] gains", ge=0.0)


def test_list_parameters_are_converted_element_by_element():
    out = from_params(_Lists, {}.get)
    assert out == _Lists(["map", "scan"], None, [1.0])
    assert out.topics is not from_params(_Lists, {}.get).topics  # a fresh list each time
    out = from_params(_Lists, {"topics": ("odom",), "pose": [1, "2.5", 0], "gains": []}.get)
    assert out.topics == ["odom"] and out.pose == [1.0, 2.5, 0.0] and out.gains == []
    assert all(isinstance(v, float) for v in out.pose)
    listed = parameters(_Lists)
    assert [(p.name, p.default) for p in listed] == [
        ("topics", ["map", "scan"]), ("pose", None), ("gains", [1.0])]


@pytest.mark.parametrize("values, message", [
    ({"pose": [1.0, 2.0]}, "parameter pose: expected list of 3 float, got [1.0, 2.0]"),
    ({"pose": [1.0, 2.0, 3.0, 4.0]}, "parameter pose: expected list of 3 float"),
    ({"pose": 1.0}, "parameter pose: expected list of 3 float, got 1.0"),
    ({"pose": [1.0, "north", 0.0]}, "parameter pose[1]: expected float, got 'north'"),
    ({"topics": "map scan"}, "parameter topics: expected list of str, got 'map scan'"),
    ({"gains": [1.0, -0.5]}, "parameter gains[1]: must be >= 0.0, got -0.5"),
])
def test_bad_lists_name_the_parameter(values, message):
    with pytest.raises(ParamError) as err:
        from_params(_Lists, values.get)
    assert message in str(err.value)


@dataclass
class _Mount:
    x_m: float = param(0.05, "[m] mount ahead of the centre")
    yaw_rad: float = param(0.0, "[rad] mount yaw", degrees=True)
    half_angle_rad: float = param(math.radians(15.0), "[rad] half angle", degrees=True, gt=0.0)


@dataclass
class _Robot:
    name: str = param("r", "robot name")
    mount: _Mount = nested(_Mount, "mount/", closed=True)


def test_angles_in_degrees_and_closed_namespaces():
    out = from_params(_Robot, tree_getter({"mount": {"yaw_deg": 90, "half_angle_rad": 0.5}}))
    assert out.mount.yaw_rad == pytest.approx(math.pi / 2) and out.mount.half_angle_rad == 0.5
    assert from_params(_Robot, {"mount/half_angle_deg": 30.0}.get).mount.half_angle_rad \
        == pytest.approx(math.radians(30.0))
    assert parameters(_Robot)[2].degrees and not parameters(_Robot)[1].degrees
    with pytest.raises(ParamError, match="parameter mount/half_angle_rad: must be > 0.0"):
        from_params(_Robot, {"mount/half_angle_deg": 0.0}.get)
    with pytest.raises(ParamError, match="parameter mount/yaw_deg: expected float"):
        from_params(_Robot, {"mount/yaw_deg": "left"}.get)
    with pytest.raises(ParamError, match="parameter mount/yaw_rad: give it or mount/yaw_deg"):
        from_params(_Robot, {"mount/yaw_deg": 1.0, "mount/yaw_rad": 0.1}.get)
    with pytest.raises(ParamError, match=r"parameter mount/x: unknown \(mount/\* takes "
                                         r"half_angle_deg, half_angle_rad, x_m, yaw_deg"):
        from_params(_Robot, tree_getter({"mount": {"x": 0.1}}))
    with pytest.raises(TypeError, match="prefix ending in '/'"):
        nested(_Mount, "", closed=True)
