"""ascc_common.params: reading parameter dataclasses from a getter."""
from dataclasses import dataclass
from typing import Optional

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
