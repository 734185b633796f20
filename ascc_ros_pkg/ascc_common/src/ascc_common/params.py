"""Parameter dataclasses read from a getter: one way for every node (no rospy).

A field declared with ``param`` is a parameter: it carries its ROS name (by default the
field's name; the stand-ins keep gmapping's, amcl's and move_base's names such as
``maxUrange`` or ``NavfnROS/allow_unknown``, the stack's own names end in their unit, e.g.
``cmd_timeout_s``), a doc string with the unit, and optional bounds or choices. A field
declared with ``nested`` holds another parameter dataclass whose names get a prefix; a
closed one (``closed=True``, e.g. the simulator's ``~robot/*``) rejects names in its
namespace that it does not declare. Plain fields are not parameters (tuning constants the
nodes do not read).

``from_params(cls, get, prefix)`` reads every parameter through ``get(name, default)``:
``rospy.get_param`` with prefix ``"~"`` in a node, ``dict.get`` or ``tree_getter(yaml)`` in
tests and benchmarks. Values are converted to the field's type (int, float, bool, str, or a
``List`` of one, e.g. ``List[float]``, optionally of a fixed ``length``; bounds and choices
apply to each element) and checked; a bad one raises ``ParamError`` naming the parameter
and the value. A field typed ``Optional[...]`` with default None stays None unless given
("unset by default"). A ``*_rad`` parameter declared with ``degrees=True`` may be given in
degrees as ``*_deg`` instead. Then the dataclass's own ``validate()`` (rules across
fields), if it has one, runs.
``parameters(cls)`` lists (name, default, doc) for documentation and README checks.
"""
from __future__ import annotations

import dataclasses
import math
import re
import typing
from typing import Any, Callable, List, NamedTuple, Optional, Sequence, Tuple, Union

Getter = Callable[[str, Any], Any]

_PARAM = "ascc_param"  # field metadata key of a parameter (a _Spec)
_NESTED = "ascc_params_prefix"  # field metadata key of a nested dataclass (its prefix)
_CLOSED = "ascc_params_closed"  # field metadata key: the nested namespace takes no other names
_UNSET = object()  # what a getter returns for a name it does not have
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
    length: Optional[int]
    degrees: bool


class Parameter(NamedTuple):
    """One parameter as ``parameters`` lists it (``name`` with its prefix)."""

    name: str
    default: Any
    doc: str
    attr: str  # dotted attribute path in the dataclass, e.g. "rbpf.particles"
    degrees: bool = False  # a *_rad parameter that may be given as *_deg instead


def param(default: Any, doc: str = "", name: Optional[str] = None, *,
          ge: Optional[float] = None, gt: Optional[float] = None, le: Optional[float] = None,
          choices: Optional[Sequence[Any]] = None, length: Optional[int] = None,
          degrees: bool = False) -> Any:
    """A dataclass field that is a parameter: ROS ``name`` (default: the field's name),
    ``doc`` with the unit in brackets, bounds ``ge`` (>=), ``gt`` (>), ``le`` (<=) or
    allowed ``choices``; a list's fixed ``length``; ``degrees``: a ``*_rad`` parameter
    that may be given in degrees as ``*_deg`` instead. A list default is copied per
    instance."""
    metadata = {_PARAM: _Spec(name, doc, ge, gt, le, choices, length, degrees)}
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def nested(cls: type, prefix: str = "", closed: bool = False) -> Any:
    """A dataclass field holding the parameter dataclass ``cls``, its names after ``prefix``
    (e.g. "global_costmap/"; "" puts them beside the outer ones). ``closed``: a name in the
    ``prefix`` namespace that ``cls`` does not declare is a ParamError (a typo does not
    silently leave the default)."""
    if closed and not prefix.endswith("/"):
        raise TypeError("a closed nested parameter dataclass needs a prefix ending in '/'")
    return dataclasses.field(default_factory=cls, metadata={_NESTED: prefix, _CLOSED: closed})


def from_params(cls: type, get: Getter, prefix: str = "") -> Any:
    """An instance of the parameter dataclass ``cls`` with every parameter read as
    ``get(prefix + name, default)``; ParamError on a bad value or a failed ``validate()``."""
    values = {}
    for f in dataclasses.fields(cls):
        if _NESTED in f.metadata:
            inner = prefix + f.metadata[_NESTED]
            if f.metadata[_CLOSED]:
                _check_closed(f.default_factory, get, inner)
            values[f.name] = from_params(f.default_factory, get, inner)
        elif _PARAM in f.metadata:
            spec = f.metadata[_PARAM]
            full = prefix + (spec.name or f.name)
            kind, optional, is_list = _field_type(cls, f)
            value = get(full, _default(f))
            if spec.degrees:
                value = _from_degrees(full, get, value)
            if not (optional and value is None):
                value = _convert_list(full, kind, spec, value) if is_list else \
                    _convert(full, kind, value)
                if not is_list:
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
            out.append(Parameter(prefix + (spec.name or f.name), _default(f), spec.doc, f.name,
                                 spec.degrees))
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


def _field_type(cls: type, f: dataclasses.Field) -> Tuple[type, bool, bool]:
    """The field's (element) type, whether it is Optional (then its default must be None)
    and whether it is a List."""
    kind: Any = f.type
    optional = is_list = False
    if isinstance(kind, str):
        text = kind.replace(" ", "")
        match = re.fullmatch(r"Optional\[(.+)\]", text)
        optional, text = (True, match.group(1)) if match else (False, text)
        match = re.fullmatch(r"List\[(.+)\]", text)
        is_list, text = (True, match.group(1)) if match else (False, text)
        kind = _TYPES.get(text, kind)
    else:
        if typing.get_origin(kind) is Union and type(None) in typing.get_args(kind):
            args = [a for a in typing.get_args(kind) if a is not type(None)]
            optional, kind = True, args[0] if len(args) == 1 else kind
        if typing.get_origin(kind) is list and len(typing.get_args(kind)) == 1:
            is_list, kind = True, typing.get_args(kind)[0]
    if kind not in _TYPES.values() or optional != (_default(f) is None):
        raise TypeError("%s.%s: a parameter must be int, float, bool or str, or a List of one "
                        "(or Optional of these, default None), not %r"
                        % (cls.__name__, f.name, f.type))
    return kind, optional, is_list


def _default(f: dataclasses.Field) -> Any:
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return f.default


def _from_degrees(name: str, get: Getter, value: Any) -> Any:
    """The value of ``name`` (``*_rad``) or, given instead, of its ``*_deg`` twin in rad."""
    if not name.endswith("_rad"):
        raise TypeError("%s: degrees=True needs a name ending in _rad" % name)
    deg_name = name[:-4] + "_deg"
    deg = get(deg_name, _UNSET)
    if deg is _UNSET:
        return value
    if get(name, _UNSET) is not _UNSET:
        raise ParamError("parameter %s: give it or %s, not both" % (name, deg_name))
    return math.radians(_convert(deg_name, float, deg))


def _check_closed(cls: type, get: Getter, prefix: str) -> None:
    """ParamError naming the first name in the ``prefix`` namespace that ``cls`` lacks."""
    given = get(prefix.rstrip("/"), None)
    if not isinstance(given, dict):
        return  # no namespace there, or a getter of single names only (dict.get)
    known = set()
    for p in parameters(cls):
        known.add(p.name.split("/")[0])
        if p.degrees:
            known.add(p.name[:-4] + "_deg")
    unknown = sorted(set(given) - known)
    if unknown:
        raise ParamError("parameter %s%s: unknown (%s takes %s)" % (
            prefix, unknown[0], prefix + "*", ", ".join(sorted(known))))


def _convert_list(name: str, kind: type, spec: _Spec, value: Any) -> List[Any]:
    what = "list of %s" % kind.__name__
    if spec.length is not None:
        what = "list of %d %s" % (spec.length, kind.__name__)
    if not isinstance(value, (list, tuple)) or (spec.length is not None
                                                and len(value) != spec.length):
        raise ParamError("parameter %s: expected %s, got %r" % (name, what, value))
    out = [_convert("%s[%d]" % (name, i), kind, v) for i, v in enumerate(value)]
    for i, v in enumerate(out):
        _check("%s[%d]" % (name, i), spec, v)
    return out


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
