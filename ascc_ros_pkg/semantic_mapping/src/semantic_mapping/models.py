"""The fusion's model tables (thesis Tables 5.1-5.3 by default), read from YAML and checked.

``load_models(path)`` reads ``config/models.yaml`` (the format is described there) into a
`Models`: the value names of A/O, F, CL and R, and the conditional tables as numpy arrays
laid out as printed, ``table[value, condition]``:

    observation    P(O|A)   shape (n_activities, n_activities)   Table 5.1
    activity       P(A|F)   shape (n_activities, n_furniture)     Table 5.2
    location       P(CL|F)  shape (n_location_types, n_furniture) Table 5.3
    room_activity  P(A|R)   shape (n_activities, n_rooms)         ours (see the YAML)

Every column is a distribution: a negative entry or a column whose sum is not 1 (within
``SUM_TOL``) raises `ModelError` naming the file, the table and the column; nothing is
renormalised. Pure Python (numpy, PyYAML), no ROS.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Dict, List, Sequence, Tuple

import numpy as np
import yaml

SUM_TOL = 1e-6  # how far a column's sum may be from 1
DEFAULT_MODELS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), "config", "models.yaml")

# YAML key -> (what the table is, the names of its rows, of its columns)
TABLES = {
    "observation_model": ("P(O|A) (Table 5.1)", "activities", "activities"),
    "activity_model": ("P(A|F) (Table 5.2)", "activities", "furniture"),
    "location_model": ("P(CL|F) (Table 5.3)", "location_types", "furniture"),
    "room_activity_model": ("P(A|R)", "activities", "rooms"),
}
NAMES = ("activities", "furniture", "location_types", "rooms")


class ModelError(ValueError):
    """A malformed model file. ``str()`` names the file, the table and what is wrong."""


@dataclass(frozen=True)
class RoomRule:
    """Case rule of 5.5: at least ``at_least`` grids labelled ``furniture`` -> ``room``
    (indices into `Models.furniture` and `Models.rooms`)."""

    room: int
    furniture: int
    at_least: int


@dataclass(frozen=True)
class Models:
    activities: Tuple[str, ...]
    furniture: Tuple[str, ...]
    location_types: Tuple[str, ...]
    rooms: Tuple[str, ...]
    observation: np.ndarray     # P(O|A)[o, a]
    activity: np.ndarray        # P(A|F)[a, f]
    location: np.ndarray        # P(CL|F)[cl, f]
    room_activity: np.ndarray   # P(A|R)[a, r]
    room_rules: Tuple[RoomRule, ...]
    room_rule_confidence: float


def check_columns(table: np.ndarray, what: str, columns: Sequence[str],
                  where: str = "") -> None:
    """ModelError unless every column of ``table`` is a distribution (>= 0, sums to 1)."""
    prefix = "%s: " % where if where else ""
    if not np.all(np.isfinite(table)):
        raise ModelError("%s%s: entries must be finite numbers" % (prefix, what))
    for j, name in enumerate(columns):
        col = table[:, j]
        if np.any(col < 0.0):
            raise ModelError("%s%s: column %d (%s) has a negative entry %g"
                             % (prefix, what, j + 1, name, col.min()))
        s = float(col.sum())
        if abs(s - 1.0) > SUM_TOL:
            raise ModelError("%s%s: column %d (%s) sums to %.6g, not 1 (tables are not "
                             "renormalised; fix the table)" % (prefix, what, j + 1, name, s))


def _names(doc: Dict[str, Any], key: str, path: str) -> Tuple[str, ...]:
    names = doc.get(key)
    if (not isinstance(names, list) or not names
            or not all(isinstance(n, str) and n for n in names)):
        raise ModelError("%s: %s: expected a list of names" % (path, key))
    if len(set(names)) != len(names):
        raise ModelError("%s: %s: names must be unique" % (path, key))
    return tuple(names)


def _table(doc: Dict[str, Any], key: str, names: Dict[str, Tuple[str, ...]],
           path: str) -> np.ndarray:
    what, rows_key, cols_key = TABLES[key]
    rows, cols = names[rows_key], names[cols_key]
    raw = doc.get(key)
    if not isinstance(raw, list):
        raise ModelError("%s: %s %s: missing or not a list of rows" % (path, key, what))
    if len(raw) != len(rows):
        raise ModelError("%s: %s %s: %d rows, expected %d (one per %s)"
                         % (path, key, what, len(raw), len(rows), rows_key))
    for i, row in enumerate(raw):
        if not isinstance(row, list) or len(row) != len(cols):
            raise ModelError("%s: %s %s: row %d must have %d numbers (one per %s)"
                             % (path, key, what, i + 1, len(cols), cols_key))
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row):
            raise ModelError("%s: %s %s: row %d: entries must be numbers"
                             % (path, key, what, i + 1))
    table = np.array(raw, dtype=float)
    check_columns(table, "%s %s" % (key, what), cols, path)
    return table


def _rules(doc: Dict[str, Any], names: Dict[str, Tuple[str, ...]],
           path: str) -> List[RoomRule]:
    raw = doc.get("room_rules", [])
    if not isinstance(raw, list):
        raise ModelError("%s: room_rules: expected a list" % path)
    rules = []
    for i, r in enumerate(raw):
        where = "%s: room_rules[%d]" % (path, i)
        if not isinstance(r, dict) or set(r) != {"room", "furniture", "at_least"}:
            raise ModelError("%s: expected {room, furniture, at_least}" % where)
        if r["room"] not in names["rooms"]:
            raise ModelError("%s: unknown room %r" % (where, r["room"]))
        if r["furniture"] not in names["furniture"]:
            raise ModelError("%s: unknown furniture %r" % (where, r["furniture"]))
        if not isinstance(r["at_least"], int) or r["at_least"] < 1:
            raise ModelError("%s: at_least must be an integer >= 1" % where)
        rules.append(RoomRule(names["rooms"].index(r["room"]),
                              names["furniture"].index(r["furniture"]), r["at_least"]))
    return rules


def read_yaml(path: str) -> Any:
    """A YAML file's document; ModelError naming the file for a syntax error (OSError as
    usual when it cannot be opened)."""
    with open(path, encoding="utf-8") as f:
        try:
            return yaml.safe_load(f)
        except yaml.YAMLError as e:
            raise ModelError("%s: not valid YAML: %s" % (path, str(e).splitlines()[0])) \
                from None


def load_models(path: str = DEFAULT_MODELS) -> Models:
    """The tables of a models YAML file, checked (ModelError otherwise)."""
    return models_from_dict(read_yaml(path), path)


def models_from_dict(doc: Any, path: str = "(models)") -> Models:
    """A `Models` from the parsed YAML document (``path`` names it in errors)."""
    if not isinstance(doc, dict):
        raise ModelError("%s: expected a mapping of model tables" % path)
    names = {k: _names(doc, k, path) for k in NAMES}
    tables = {k: _table(doc, k, names, path) for k in TABLES}
    confidence = doc.get("room_rule_confidence", 0.9)
    if (not isinstance(confidence, (int, float)) or isinstance(confidence, bool)
            or not 1.0 / len(names["rooms"]) <= confidence <= 1.0):
        raise ModelError("%s: room_rule_confidence: must be a number within [1/%d, 1], got "
                         "%r" % (path, len(names["rooms"]), confidence))
    return Models(names["activities"], names["furniture"], names["location_types"],
                  names["rooms"], tables["observation_model"], tables["activity_model"],
                  tables["location_model"], tables["room_activity_model"],
                  tuple(_rules(doc, names, path)), float(confidence))
