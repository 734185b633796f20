"""Parameter dataclasses read from a getter: one way for every node (no rospy).

A field declared with ``param`` is a parameter: it carries its ROS name (by default the
field's name; the stand-ins keep gmapping's, amcl's and move_base's names such as
``maxUrange`` or ``NavfnROS/allow_unknown``, the stack's own names end in their unit, e.g.
``cmd_timeout_s``), a doc string with the unit, and optional bounds or choices. A field
declared with ``nested`` holds another parameter dataclass whose names get a prefix.
Plain fields are not parameters (tuning constants the nodes do not read).

``from_params(cls, get, prefix)`` reads every parameter through ``get(name, default)``:
``rospy.get_param`` with prefix ``"~"`` in a node, ``dict.get`` or ``tree_getter(yaml)`` in
tests and benchmarks. Values are converted to the field's type (int, float, bool, str) and
checked; a bad one raises ``ParamError`` naming the parameter and the value. A field typed
``Optional[...]`` with default None stays None unless given ("unset by default"). Then the
dataclass's own ``validate()`` (rules across fields), if it has one, runs.
``parameters(cls)`` lists (name, default, doc) for documentation and README checks.
"""
from __future__ import annotations

import dataclasses
import re
import typing
from typing import Any, Callable, List, NamedTuple, Optional, Sequence, Tuple, Union

Getter = Callable[[str, Any], Any]

_PARAM = "ascc_param"  # field metadata key of a parameter (a _Spec)
_NESTED = "ascc_params_prefix"  # field metadata key of a nested dataclass (its prefix)
_TYPES = {"int": int, "float": float, "bool": bool, "str": str}


class ParamError(ValueError):
    """A parameter with a value of the wrong type or out of its bounds."""


class _Spec(NamedTuple):
    name: Optional[str]
    doc: str
    ge: Optional[float]
    gt: Optional[float]
    le: Optional[float]
    choices: Optional[Sequence[Any]]


class Parameter(NamedTuple):
    """One parameter as ``parameters`` lists it (``name`` with its prefix)."""

    name: str
    default: Any
    doc: str
    attr: str  # dotted attribute path in the dataclass, e.g. "rbpf.particles"


def param(default: Any, doc: str = "", name: Optional[str] = None, *,
          ge: Optional[float] = None, gt: Optional[float] = None, le: Optional[float] = None,
          choices: Optional[Sequence[Any]] = None) -> Any:
    """A dataclass field that is a parameter: ROS ``name`` (default: the field's name),
    ``doc`` with the unit in brackets, bounds ``ge`` (>=), ``gt`` (>), ``le`` (<=) or
    allowed ``choices``."""
    return dataclasses.field(default=default,
                             metadata={_PARAM: _Spec(name, doc, ge, gt, le, choices)})


def nested(cls: type, prefix: str = "") -> Any:
    """A dataclass field holding the parameter dataclass ``cls``, its names after ``prefix``
    (e.g. "global_costmap/"; "" puts them beside the outer ones)."""
    return dataclasses.field(default_factory=cls, metadata={_NESTED: prefix})


def from_params(cls: type, get: Getter, prefix: str = "") -> Any:
    """An instance of the parameter dataclass ``cls`` with every parameter read as
    ``get(prefix + name, default)``; ParamError on a bad value or a failed ``validate()``."""
    values = {}
    for f in dataclasses.fields(cls):
        if _NESTED in f.metadata:
            values[f.name] = from_params(f.default_factory, get, prefix + f.metadata[_NESTED])
        elif _PARAM in f.metadata:
            spec = f.metadata[_PARAM]
            full = prefix + (spec.name or f.name)
            kind, optional = _field_type(cls, f)
            value = get(full, f.default)
            if not (optional and value is None):
                value = _convert(full, kind, value)
                _check(full, spec, value)
            values[f.name] = value
    obj = cls(**values)
    validate = getattr(obj, "validate", None)
    if validate is not None:
        try:
            validate()
        except ValueError as err:
            raise ParamError("%s%s" % ("%s: " % prefix if prefix else "", err)) from err
    return obj


def parameters(cls: type, prefix: str = "") -> List[Parameter]:
    """Every parameter of ``cls`` (nested ones included), in declaration order."""
    out: List[Parameter] = []
    for f in dataclasses.fields(cls):
        if _NESTED in f.metadata:
            out += [p._replace(attr=f.name + "." + p.attr)
                    for p in parameters(f.default_factory, prefix + f.metadata[_NESTED])]
        elif _PARAM in f.metadata:
            spec = f.metadata[_PARAM]
            out.append(Parameter(prefix + (spec.name or f.name), f.default, spec.doc, f.name))
    return out


def tree_getter(tree: dict) -> Getter:
    """A ``get(name, default)`` over a nested dict (a YAML file), names split at '/'."""
    def get(name: str, default: Any) -> Any:
        node: Any = tree
        for part in name.split("/"):
            if not isinstance(node, dict) or part not in node:
                return default
            node = node[part]
        return node
    return get


def _field_type(cls: type, f: dataclasses.Field) -> Tuple[type, bool]:
    """The field's type and whether it is Optional (then its default must be None)."""
    kind: Any = f.type
    optional = False
    if isinstance(kind, str):
        match = re.fullmatch(r"Optional\[(\w+)\]", kind)
        optional = match is not None
        kind = _TYPES.get(match.group(1) if match else kind, kind)
    elif typing.get_origin(kind) is Union and type(None) in typing.get_args(kind):
        args = [a for a in typing.get_args(kind) if a is not type(None)]
        optional, kind = True, args[0] if len(args) == 1 else kind
    if kind not in _TYPES.values() or optional != (f.default is None):
        raise TypeError("%s.%s: a parameter must be int, float, bool or str (or Optional of "
                        "one, default None), not %r" % (cls.__name__, f.name, f.type))
    return kind, optional


def _convert(name: str, kind: type, value: Any) -> Any:
    try:
        if kind is bool:
            return _to_bool(value)
        if kind is int:
            number = float(value)
            if not number.is_integer():
                raise ValueError
            return int(number)
        return kind(value)
    except (TypeError, ValueError, OverflowError) as err:
        raise ParamError("parameter %s: expected %s, got %r" % (name, kind.__name__, value)) \
            from err


def _to_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.lower() in ("true", "false"):
        return value.lower() == "true"
    raise ValueError(value)


def _check(name: str, spec: _Spec, value: Any) -> None:
    rules = ((spec.ge, ">=", lambda v, b: v >= b), (spec.gt, ">", lambda v, b: v > b),
             (spec.le, "<=", lambda v, b: v <= b))
    for bound, text, ok in rules:
        if bound is not None and not ok(value, bound):
            raise ParamError("parameter %s: must be %s %r, got %r" % (name, text, bound, value))
    if spec.choices is not None and value not in spec.choices:
        raise ParamError("parameter %s: must be one of %s, got %r"
                         % (name, ", ".join(map(str, spec.choices)), value))
