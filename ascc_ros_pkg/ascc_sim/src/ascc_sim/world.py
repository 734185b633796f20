"""World files: a ROS map_server map (YAML + image) plus a world YAML for everything else.

A world YAML (see ``worlds/*.yaml`` and the package README for the full schema)::

    name: office
    map: maps/office.yaml              # map_server YAML, relative to this file
    robots:                            # start poses [x_m, y_m, yaw_rad] in the map frame
      - {name: asccbot, namespace: "", pose: [1.0, 2.0, 0.0]}
    objects:
      - {name: cone1, type: cone, pose: [3.0, 1.5]}
      - {name: logo1, type: poster, logo: ascc_logo, pose: [5.0, 4.9, -1.5708]}
      - {name: desk1, type: furniture, kind: desk, pose: [2, 3, 0], size_m: [1.2, 0.6]}
      - {name: corner1, type: landmark, pose: [1.4, 3.3]}
    people:
      - name: alice
        speed_mps: 0.5
        route: [[1, 1], {at: [4, 1], wait_s: 10, activity: sit}]

Every problem raises :class:`WorldError` naming the file and the field, e.g.
``worlds/x.yaml: robots[1].pose: robot 'robotB' overlaps a wall ...``.
"""
from __future__ import annotations

import math
import os
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Tuple

import numpy as np
import yaml

from ascc_common import map_io
from ascc_common.grid import FREE, OCCUPIED

from .grid import GridMap, rasterize_disc, rasterize_polygon


class WorldError(map_io.MapError):
    """A world or map file is malformed. ``str()`` is one line: ``file: field: message``
    (attributes ``path``, ``field``, ``message``)."""


class Pose2D(NamedTuple):
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad]


class RobotSpec(NamedTuple):
    name: str  # ground-truth topics use it: ground_truth/<name>/...
    namespace: str  # '' = no namespace (topics scan, odom; frames odom, base_link)
    pose: Pose2D  # start pose in the map frame (the robot's odom frame starts here)
    model: str = "create_1"  # the base its virtual Create emulates (create_1 | create_2)

    @property
    def frame_prefix(self) -> str:
        return self.namespace + "/" if self.namespace else ""


class WorldObject(NamedTuple):
    name: str
    type: str  # cone | poster | furniture | landmark
    kind: str  # furniture kind (bench, chair, ...), poster logo, or ''
    pose: Pose2D  # map frame
    footprint: np.ndarray  # (N, 2) outline in the map frame [m]; (0, 2) for points
    radius_m: float  # circular objects (cones); 0 otherwise
    height_m: float
    color: Tuple[float, float, float]  # RGB 0..1
    solid: str  # outline | legs | none: what the laser and the bumper meet
    circles: np.ndarray  # (M, 3) solid circles (x, y, r) [m] ray-cast analytically
    laser_dropout_prob: float  # extra dropout probability of returns from this object
    center_height_m: float = 0.0  # posters: height of the sheet's centre above the floor


class Waypoint(NamedTuple):
    x: float  # [m]
    y: float  # [m]
    wait_s: float  # dwell time on arrival [s]
    activity: str  # what the person does while waiting ('' = nothing scripted)


class PersonSpec(NamedTuple):
    name: str
    route: Tuple[Waypoint, ...]
    speed_mps: float
    radius_m: float  # body at laser height
    height_m: float
    loop: bool  # walk back to the first waypoint and repeat
    start_delay_s: float  # stand at the first waypoint this long first
    color: Tuple[float, float, float]  # shirt colour


COLORS = {
    "orange": (1.0, 0.45, 0.0), "white": (0.95, 0.95, 0.95), "black": (0.1, 0.1, 0.1),
    "grey": (0.5, 0.5, 0.5), "gray": (0.5, 0.5, 0.5), "brown": (0.55, 0.35, 0.2),
    "red": (0.85, 0.1, 0.1), "green": (0.1, 0.7, 0.2), "blue": (0.15, 0.3, 0.85),
    "yellow": (0.95, 0.85, 0.1), "beige": (0.85, 0.78, 0.6),
}

OBJECT_TYPES = ("cone", "poster", "furniture", "landmark")
SOLID_MODES = ("outline", "legs", "none")
# Defaults per object type: radius_m (cone only), height_m, color, solid.
_TYPE_DEFAULTS = {
    "cone": {"radius_m": 0.12, "height_m": 0.45, "color": "orange", "solid": "outline"},
    "poster": {"width_m": 0.6, "height_m": 0.8, "color": "white", "solid": "none"},
    "furniture": {"height_m": 0.75, "color": "brown", "solid": "outline"},
    "landmark": {"height_m": 0.0, "color": "red", "solid": "none"},
}
_OBJECT_KEYS = {
    "cone": {"name", "type", "pose", "radius_m", "height_m", "color", "solid",
             "laser_dropout_prob"},
    "poster": {"name", "type", "pose", "logo", "width_m", "height_m", "color", "solid",
               "laser_dropout_prob", "center_height_m"},
    "furniture": {"name", "type", "kind", "pose", "size_m", "footprint_m", "height_m",
                  "color", "solid", "leg_radius_m", "laser_dropout_prob"},
    "landmark": {"name", "type", "kind", "pose", "height_m", "color", "solid",
                 "laser_dropout_prob"},
}
_WORLD_KEYS = {"name", "description", "map", "robots", "objects", "people"}
_ROBOT_KEYS = {"name", "namespace", "pose", "model"}
ROBOT_MODELS = ("create_1", "create_2")  # irobot_create_2_1.models.MODELS
_PERSON_KEYS = {"name", "route", "speed_mps", "radius_m", "height_m", "loop",
                "start_delay_s", "color"}


class World:
    """Everything static about a simulated world, validated.

    Attributes:
        path: the world YAML; map_path: its map_server YAML.
        map: the building as loaded from the image (walls, static obstacles).
        grid: ``map`` plus the outlines of solid furniture: what stops robots and
            reflects the laser (analytic circles excluded).
        truth_map: ``grid`` plus every solid circle rasterised: the ground-truth map.
        dropout: float32 (height, width) extra laser dropout probability per cell.
        circles: (K, 3) static solid circles (x, y, r) [m] (cones, furniture legs).
    """

    def __init__(self, path: str, name: str, map_path: str, base_map: GridMap,
                 robots: List[RobotSpec], objects: List[WorldObject],
                 people: List[PersonSpec], description: str = ""):
        self.path = path
        self.name = name
        self.description = description
        self.map_path = map_path
        self.map = base_map
        self.robots = robots
        self.objects = objects
        self.people = people
        occ = base_map.occupancy.copy()
        self.dropout = np.zeros(occ.shape, dtype=np.float32)
        for obj in objects:
            if obj.solid == "outline" and len(obj.footprint) >= 3 and obj.radius_m == 0.0:
                rasterize_polygon(occ, base_map.info, obj.footprint, OCCUPIED)
            if obj.laser_dropout_prob > 0.0 and len(obj.footprint) >= 3:
                layer = np.zeros(occ.shape, dtype=np.uint8)
                rasterize_polygon(layer, base_map.info, obj.footprint, 1)
                self.dropout[layer > 0] = np.maximum(self.dropout[layer > 0],
                                                     obj.laser_dropout_prob)
        self.grid = GridMap(occ, base_map.info)
        circles = [obj.circles for obj in objects if len(obj.circles)]
        self.circles = (np.concatenate(circles, axis=0) if circles
                        else np.zeros((0, 3), dtype=np.float64))
        truth = occ.copy()
        for cx, cy, r in self.circles:
            rasterize_disc(truth, base_map.info, cx, cy, r, OCCUPIED)
        self.truth_map = GridMap(truth, base_map.info)

    def robot(self, name: str) -> RobotSpec:
        for r in self.robots:
            if r.name == name:
                return r
        raise KeyError(name)


# ---------------------------------------------------------------------------- parsing


class _Ctx:
    """Reads typed fields from a YAML mapping and raises WorldError naming the field."""

    def __init__(self, path: str):
        self.path = path

    def fail(self, field: str, message: str) -> WorldError:
        return WorldError(self.path, field, message)

    def mapping(self, value: Any, field: str, allowed: Optional[set] = None
                ) -> Dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(field, "expected a mapping (key: value), got %s"
                            % type(value).__name__)
        if allowed is not None:
            unknown = sorted(str(k) for k in value if k not in allowed)
            if unknown:
                raise self.fail(field + "." + unknown[0] if field else unknown[0],
                                "unknown field (known: %s)" % ", ".join(sorted(allowed)))
        return value

    def number(self, d: Dict[str, Any], key: str, field: str, default: Any = None,
               lo: Optional[float] = None, hi: Optional[float] = None,
               lo_open: bool = False) -> float:
        f = "%s.%s" % (field, key) if field else key
        if key not in d:
            if default is None:
                raise self.fail(f, "missing required field")
            return float(default)
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.fail(f, "expected a finite number, got %r" % (v,))
        v = float(v)
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise self.fail(f, "must be %s %g, got %g" % (">" if lo_open else ">=", lo, v))
        if hi is not None and v > hi:
            raise self.fail(f, "must be <= %g, got %g" % (hi, v))
        return v

    def string(self, d: Dict[str, Any], key: str, field: str, default: Optional[str] = None,
               choices: Optional[Sequence[str]] = None) -> str:
        f = "%s.%s" % (field, key) if field else key
        if key not in d:
            if default is None:
                raise self.fail(f, "missing required field")
            return default
        v = d[key]
        if not isinstance(v, str):
            raise self.fail(f, "expected a string, got %r" % (v,))
        if choices is not None and v not in choices:
            raise self.fail(f, "must be one of %s, got %r" % (", ".join(choices), v))
        return v

    def boolean(self, d: Dict[str, Any], key: str, field: str, default: bool) -> bool:
        v = d.get(key, default)
        if not isinstance(v, bool):
            raise self.fail("%s.%s" % (field, key), "expected true or false, got %r" % (v,))
        return v

    def vector(self, value: Any, field: str, lengths: Sequence[int]) -> List[float]:
        if (not isinstance(value, (list, tuple)) or len(value) not in lengths
                or any(isinstance(v, bool) or not isinstance(v, (int, float))
                       or not math.isfinite(v) for v in value)):
            raise self.fail(field, "expected a list of %s numbers, got %r"
                            % (" or ".join(str(n) for n in lengths), value))
        return [float(v) for v in value]

    def pose(self, d: Dict[str, Any], field: str, need_yaw: bool = False) -> Pose2D:
        if "pose" not in d:
            raise self.fail(field + ".pose", "missing required field")
        v = self.vector(d["pose"], field + ".pose", (3,) if need_yaw else (2, 3))
        return Pose2D(v[0], v[1], v[2] if len(v) == 3 else 0.0)

    def color(self, d: Dict[str, Any], field: str, default: str) -> Tuple[float, float, float]:
        v = d.get("color", default)
        if isinstance(v, str):
            if v not in COLORS:
                raise self.fail(field + ".color", "unknown colour %r (known: %s)"
                                % (v, ", ".join(sorted(COLORS))))
            return COLORS[v]
        rgb = self.vector(v, field + ".color", (3,))
        if any(c < 0.0 or c > 1.0 for c in rgb):
            raise self.fail(field + ".color", "RGB components must be within 0..1")
        return (rgb[0], rgb[1], rgb[2])


def _load_yaml(path: str, field: str = "(file)") -> Any:
    try:
        with open(path, encoding="utf-8") as f:
            return yaml.safe_load(f)
    except OSError as e:
        raise WorldError(path, field, "cannot read: %s" % (e.strerror or e)) from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = " at line %d column %d" % (mark.line + 1, mark.column + 1) if mark else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise WorldError(path, "(yaml)", "syntax error%s: %s" % (where, problem)) from None


def load_map(path: str) -> GridMap:
    """Load a ROS map_server map (``ascc_common.map_io``; modes trinary and scale, an
    axis-aligned origin) into a GridMap; every problem is a WorldError naming the field."""
    try:
        occ, info = map_io.load_map(path, modes=("trinary", "scale"))
    except map_io.MapError as e:
        raise WorldError(e.path, e.field, e.message) from None
    except OSError as e:
        raise WorldError(path, "(file)", "cannot read: %s" % (e.strerror or e)) from None
    try:
        info.check_axis_aligned()
    except ValueError as e:
        raise WorldError(path, "origin", str(e)) from None
    return GridMap(occ, info)


def _rotate(points: np.ndarray, pose: Pose2D) -> np.ndarray:
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.column_stack((pose.x + c * pts[:, 0] - s * pts[:, 1],
                            pose.y + s * pts[:, 0] + c * pts[:, 1]))


def _rect(length: float, width: float) -> np.ndarray:
    hl, hw = length / 2.0, width / 2.0
    return np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])


def _parse_furniture(ctx: _Ctx, d: Dict[str, Any], f: str, pose: Pose2D, solid: str
                     ) -> Tuple[str, np.ndarray, np.ndarray]:
    kind = ctx.string(d, "kind", f)
    if ("size_m" in d) == ("footprint_m" in d):
        raise ctx.fail(f + ".size_m", "give exactly one of size_m [length, width] or "
                       "footprint_m [[x, y], ...] (object frame)")
    if "size_m" in d:
        size = ctx.vector(d["size_m"], f + ".size_m", (2,))
        if min(size) <= 0.0:
            raise ctx.fail(f + ".size_m", "sizes must be > 0")
        local = _rect(size[0], size[1])
    else:
        pts = d["footprint_m"]
        if not isinstance(pts, list) or len(pts) < 3:
            raise ctx.fail(f + ".footprint_m", "expected a list of at least 3 [x, y] points")
        local = np.array([ctx.vector(p, "%s.footprint_m[%d]" % (f, i), (2,))
                          for i, p in enumerate(pts)])
    footprint = _rotate(local, pose)
    circles = np.zeros((0, 3))
    if solid == "legs":
        leg_r = ctx.number(d, "leg_radius_m", f, default=0.02, lo=0.0, lo_open=True)
        centre = footprint.mean(axis=0)
        inward = centre - footprint
        norm = np.maximum(np.linalg.norm(inward, axis=1, keepdims=True), 1e-9)
        legs = footprint + inward / norm * leg_r
        circles = np.column_stack((legs, np.full(len(legs), leg_r)))
    return kind, footprint, circles


def _parse_object(ctx: _Ctx, d: Any, f: str) -> WorldObject:
    d = ctx.mapping(d, f)
    otype = ctx.string(d, "type", f, choices=OBJECT_TYPES)
    ctx.mapping(d, f, _OBJECT_KEYS[otype])
    name = ctx.string(d, "name", f)
    defaults = _TYPE_DEFAULTS[otype]
    pose = ctx.pose(d, f, need_yaw=(otype == "poster"))
    solid = ctx.string(d, "solid", f, default=defaults["solid"], choices=SOLID_MODES)
    height = ctx.number(d, "height_m", f, default=defaults["height_m"], lo=0.0)
    color = ctx.color(d, f, defaults["color"])
    dropout = ctx.number(d, "laser_dropout_prob", f, default=0.0, lo=0.0, hi=1.0)
    kind, radius, center = "", 0.0, 0.0
    footprint = np.zeros((0, 2))
    circles = np.zeros((0, 3))
    if otype == "cone":
        radius = ctx.number(d, "radius_m", f, default=defaults["radius_m"], lo=0.0,
                            lo_open=True)
        if solid == "legs":
            raise ctx.fail(f + ".solid", "a cone cannot have legs")
        if solid == "outline":
            circles = np.array([[pose.x, pose.y, radius]])
    elif otype == "poster":
        kind = ctx.string(d, "logo", f)
        width = ctx.number(d, "width_m", f, default=defaults["width_m"], lo=0.0, lo_open=True)
        # A thin plate whose local +x axis (the pose yaw) points out of the wall.
        footprint = _rotate(np.array([[0.0, width / 2], [-0.02, width / 2],
                                      [-0.02, -width / 2], [0.0, -width / 2]]), pose)
        if solid == "legs":
            raise ctx.fail(f + ".solid", "a poster cannot have legs")
        center = ctx.number(d, "center_height_m", f, default=0.9, lo=height / 2.0)
    elif otype == "furniture":
        kind, footprint, circles = _parse_furniture(ctx, d, f, pose, solid)
    else:
        kind = ctx.string(d, "kind", f, default="")
        if solid != "none":
            raise ctx.fail(f + ".solid", "a landmark is a point; it can only be 'none'")
    return WorldObject(name, otype, kind, pose, footprint, radius, height, color, solid,
                       circles, dropout, center)


def _parse_route(ctx: _Ctx, route: Any, f: str) -> Tuple[Waypoint, ...]:
    if not isinstance(route, list) or not route:
        raise ctx.fail(f, "expected a non-empty list of waypoints")
    out = []
    for i, wp in enumerate(route):
        g = "%s[%d]" % (f, i)
        if isinstance(wp, dict):
            ctx.mapping(wp, g, {"at", "wait_s", "activity"})
            if "at" not in wp:
                raise ctx.fail(g + ".at", "missing required field")
            at = ctx.vector(wp["at"], g + ".at", (2,))
            wait = ctx.number(wp, "wait_s", g, default=0.0, lo=0.0)
            activity = ctx.string(wp, "activity", g, default="")
        else:
            at = ctx.vector(wp, g, (2,))
            wait, activity = 0.0, ""
        out.append(Waypoint(at[0], at[1], wait, activity))
    return tuple(out)


def _parse_person(ctx: _Ctx, d: Any, f: str) -> PersonSpec:
    d = ctx.mapping(d, f, _PERSON_KEYS)
    name = ctx.string(d, "name", f)
    if "route" not in d:
        raise ctx.fail(f + ".route", "missing required field")
    route = _parse_route(ctx, d["route"], f + ".route")
    return PersonSpec(
        name=name, route=route,
        speed_mps=ctx.number(d, "speed_mps", f, default=0.5, lo=0.0, lo_open=True),
        radius_m=ctx.number(d, "radius_m", f, default=0.2, lo=0.0, lo_open=True),
        height_m=ctx.number(d, "height_m", f, default=1.75, lo=0.0, lo_open=True),
        loop=ctx.boolean(d, "loop", f, False),
        start_delay_s=ctx.number(d, "start_delay_s", f, default=0.0, lo=0.0),
        color=ctx.color(d, f, "orange"))


def _parse_robot(ctx: _Ctx, d: Any, f: str) -> RobotSpec:
    d = ctx.mapping(d, f, _ROBOT_KEYS)
    name = ctx.string(d, "name", f)
    ns = ctx.string(d, "namespace", f, default="")
    valid = all(part and (part[0].isalpha()) and all(c.isalnum() or c == "_" for c in part)
                for part in ns.split("/")) if ns else True
    if not valid:
        raise ctx.fail(f + ".namespace", "%r is not a relative ROS name (e.g. robotA)" % ns)
    return RobotSpec(name, ns, ctx.pose(d, f, need_yaw=True),
                     ctx.string(d, "model", f, default="create_1", choices=ROBOT_MODELS))


def _list(ctx: _Ctx, doc: Dict[str, Any], key: str) -> List[Any]:
    v = doc.get(key, [])
    if v is None:
        return []
    if not isinstance(v, list):
        raise ctx.fail(key, "expected a list")
    return v


def load_world(path: str, robot_radius_m: float = 0.165) -> World:
    """Load and validate a world YAML and its map. Raises WorldError on any problem,
    including a robot placed inside a wall, an object, another robot or outside the map."""
    path = os.path.abspath(path)
    ctx = _Ctx(path)
    doc = _load_yaml(path)
    if doc is None:
        raise ctx.fail("(file)", "the file is empty")
    doc = ctx.mapping(doc, "", _WORLD_KEYS)
    name = ctx.string(doc, "name", "", default=os.path.splitext(os.path.basename(path))[0])
    map_rel = ctx.string(doc, "map", "")
    map_path = map_rel if os.path.isabs(map_rel) else os.path.join(os.path.dirname(path),
                                                                    map_rel)
    if not os.path.isfile(map_path):
        raise ctx.fail("map", "map file %s does not exist" % map_path)
    base = load_map(map_path)
    robots = [_parse_robot(ctx, r, "robots[%d]" % i)
              for i, r in enumerate(_list(ctx, doc, "robots"))]
    objects = [_parse_object(ctx, o, "objects[%d]" % i)
               for i, o in enumerate(_list(ctx, doc, "objects"))]
    people = [_parse_person(ctx, p, "people[%d]" % i)
              for i, p in enumerate(_list(ctx, doc, "people"))]
    _check_unique(ctx, robots, objects, people)
    world = World(path, name, map_path, base, robots, objects, people,
                  description=str(doc.get("description", "")))
    _check_placement(ctx, world, robot_radius_m)
    return world


def _check_unique(ctx: _Ctx, robots: List[RobotSpec], objects: List[WorldObject],
                  people: List[PersonSpec]) -> None:
    seen: Dict[str, str] = {}
    named = ([("robots[%d].name" % i, r.name) for i, r in enumerate(robots)]
             + [("objects[%d].name" % i, o.name) for i, o in enumerate(objects)]
             + [("people[%d].name" % i, p.name) for i, p in enumerate(people)])
    for field, name in named:
        if not name or not all(c.isalnum() or c == "_" for c in name) or not name[0].isalpha():
            raise ctx.fail(field, "%r is not a valid name (letters, digits, _)" % name)
        if name in seen:
            raise ctx.fail(field, "name %r is already used by %s" % (name, seen[name]))
        seen[name] = field
    namespaces: Dict[str, str] = {}
    for i, r in enumerate(robots):
        if r.namespace in namespaces:
            raise ctx.fail("robots[%d].namespace" % i, "namespace %r is already used by %s"
                           % (r.namespace, namespaces[r.namespace]))
        namespaces[r.namespace] = "robots[%d]" % i


def circle_overlaps(x: float, y: float, r: float, circles: np.ndarray) -> bool:
    """True when the disc (x, y, r) overlaps any of the circles (K, 3)."""
    if len(circles) == 0:
        return False
    return bool(np.any(np.hypot(circles[:, 0] - x, circles[:, 1] - y) < circles[:, 2] + r))


def _check_placement(ctx: _Ctx, world: World, radius: float) -> None:
    grid = world.grid
    for i, r in enumerate(world.robots):
        f = "robots[%d].pose" % i
        x, y = r.pose.x, r.pose.y
        if not grid.info.contains(*grid.info.world_to_cell(x, y)):
            raise ctx.fail(f, "robot %r at (%.2f, %.2f) is outside the map" % (r.name, x, y))
        hit = grid.disc_contact(x, y, radius)
        if hit is not None:
            raise ctx.fail(f, "robot %r at (%.2f, %.2f) overlaps a wall or furniture "
                           "(solid point at (%.2f, %.2f)); move it into free space"
                           % (r.name, x, y, hit[0], hit[1]))
        if grid.value_at(x, y) != FREE:
            raise ctx.fail(f, "robot %r at (%.2f, %.2f) stands on an unknown cell, outside "
                           "the building" % (r.name, x, y))
        if circle_overlaps(x, y, radius, world.circles):
            raise ctx.fail(f, "robot %r at (%.2f, %.2f) overlaps a cone or a furniture leg"
                           % (r.name, x, y))
        for j, other in enumerate(world.robots[:i]):
            if math.hypot(other.pose.x - x, other.pose.y - y) < 2.0 * radius:
                raise ctx.fail(f, "robot %r overlaps robot %r (robots[%d])"
                               % (r.name, other.name, j))
    for i, o in enumerate(world.objects):
        if not grid.info.contains(*grid.info.world_to_cell(o.pose.x, o.pose.y)):
            raise ctx.fail("objects[%d].pose" % i, "object %r at (%.2f, %.2f) is outside the "
                           "map" % (o.name, o.pose.x, o.pose.y))
    for i, p in enumerate(world.people):
        _check_route(ctx, world, p, "people[%d].route" % i)


def _check_route(ctx: _Ctx, world: World, person: PersonSpec, f: str) -> None:
    """Waypoints must leave room for the body; the straight legs between them must not
    cross a solid cell (their centre line is checked every half cell)."""
    grid = world.grid
    pts = list(person.route) + ([person.route[0]] if person.loop else [])
    for k, wp in enumerate(person.route):
        if grid.disc_contact(wp.x, wp.y, person.radius_m) is not None:
            raise ctx.fail("%s[%d]" % (f, k), "waypoint (%.2f, %.2f) of %r is inside or too "
                           "close to a wall or furniture" % (wp.x, wp.y, person.name))
    for k in range(len(pts) - 1):
        a, b = pts[k], pts[k + 1]
        n = max(2, int(math.hypot(b.x - a.x, b.y - a.y) / (grid.info.resolution / 2)) + 1)
        for t in np.linspace(0.0, 1.0, n):
            x, y = a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)
            if grid.value_at(x, y) == OCCUPIED:
                raise ctx.fail("%s[%d]" % (f, k), "the walk from (%.2f, %.2f) to (%.2f, %.2f) "
                               "of %r crosses a wall at (%.2f, %.2f)"
                               % (a.x, a.y, b.x, b.y, person.name, x, y))
