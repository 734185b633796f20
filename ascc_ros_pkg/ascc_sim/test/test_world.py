"""World and map loading: map_server conventions, the shipped worlds, and one clear error
(file + field) for every kind of malformed input."""
import math
import os

import cv2
import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_sim.grid import GridMap
from ascc_sim.world import WorldError, circle_overlaps, load_map, load_world

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WORLDS = os.path.join(PKG, "worlds")
SHIPPED = ["office", "office_follow", "apartment_follow", "corridor", "lab", "apartment", "annex",
           "three_robots"]


def write_map(tmp_path, pixels, name="m", **fields):
    """A map_server map from an image array (row 0 = top); returns the YAML path."""
    cv2.imwrite(str(tmp_path / (name + ".pgm")), np.asarray(pixels, dtype=np.uint8))
    doc = {"image": name + ".pgm", "resolution": 0.1, "origin": [-1.0, -2.0, 0.0],
           "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}
    doc.update(fields)
    lines = ["%s: %s" % (k, v) for k, v in doc.items() if v is not None]
    path = tmp_path / (name + ".yaml")
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def room_map(tmp_path, size=40):
    """A size x size cell room (0.1 m cells) with one-cell walls, origin (-1, -2)."""
    img = np.full((size, size), 254, dtype=np.uint8)
    img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = 0
    return write_map(tmp_path, img)


def write_world(tmp_path, text, name="w.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_map_server_conventions(tmp_path):
    # Row 0 of the image is the top (highest y); 254 free, 0 occupied, 205 unknown.
    img = np.array([[0, 254, 205],
                    [254, 254, 254]], dtype=np.uint8)
    g = load_map(write_map(tmp_path, img))
    assert (g.info.width, g.info.height) == (3, 2)
    assert g.info.resolution == pytest.approx(0.1)
    assert (g.info.origin_x, g.info.origin_y) == (-1.0, -2.0)
    # Bottom row (iy = 0) is the image's last row.
    assert g.occupancy[0].tolist() == [FREE, FREE, FREE]
    assert g.occupancy[1].tolist() == [OCCUPIED, FREE, UNKNOWN]
    # Cell (0, 1) spans x in [-1.0, -0.9), y in [-1.9, -1.8).
    assert g.value_at(-0.95, -1.85) == OCCUPIED
    assert g.value_at(-0.75, -1.85) == UNKNOWN
    assert g.value_at(5.0, 5.0) == OCCUPIED  # outside the grid counts as solid


def test_map_negate_and_thresholds(tmp_path):
    img = np.array([[0, 255, 100]], dtype=np.uint8)
    g = load_map(write_map(tmp_path, img, negate=1))
    # negate: p = value / 255 -> 0 free, 255 occupied, 100 (p = 0.39) unknown
    assert g.occupancy[0].tolist() == [FREE, OCCUPIED, UNKNOWN]


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_worlds_load(name):
    w = load_world(os.path.join(WORLDS, name + ".yaml"))
    assert w.robots, "every shipped world has a robot"
    assert w.map.info.resolution == pytest.approx(0.05)
    for r in w.robots:
        assert w.grid.disc_contact(r.pose.x, r.pose.y, 0.165) is None
        assert w.grid.value_at(r.pose.x, r.pose.y) == FREE


def test_shipped_world_contents():
    corridor = load_world(os.path.join(WORLDS, "corridor.yaml"))
    sx, sy = corridor.map.info.size_m
    assert (corridor.map.info.width, corridor.map.info.height) == (2000, 500)
    assert (sx, sy) == pytest.approx((100.0, 25.0))
    assert sum(o.kind == "bench" for o in corridor.objects) >= 4

    apartment = load_world(os.path.join(WORLDS, "apartment.yaml"))
    kinds = sorted(o.kind for o in apartment.objects if o.type == "furniture")
    assert kinds.count("bench") == 1 and kinds.count("chair") == 2
    assert kinds.count("shelf") == 1
    assert len(apartment.people) == 1
    assert {wp.activity for wp in apartment.people[0].route} >= {"lie", "sit", "read"}

    # the held-out loop: its north side runs 3.6 degrees off the others (centre line from
    # (52, 27) to (4, 24), wall faces 1.2 m either side of it)
    annex = load_world(os.path.join(WORLDS, "annex.yaml"))
    slope = math.atan2(3.0, 48.0)
    for x in (10.0, 28.0, 46.0):
        y = 24.0 + (x - 4.0) * 3.0 / 48.0
        nx, ny = -math.sin(slope), math.cos(slope)  # the side's normal
        assert annex.map.value_at(x, y) == FREE
        assert annex.map.value_at(x + 1.1 * nx, y + 1.1 * ny) == FREE
        assert annex.map.value_at(x + 1.3 * nx, y + 1.3 * ny) == OCCUPIED
        assert annex.map.value_at(x - 1.3 * nx, y - 1.3 * ny) == OCCUPIED

    lab = load_world(os.path.join(WORLDS, "lab.yaml"))
    assert sum(o.kind == "tripod" for o in lab.objects) == 2
    assert len(lab.circles) == 6 + 1  # two tripods x three legs + the cone

    three = load_world(os.path.join(WORLDS, "three_robots.yaml"))
    assert [r.namespace for r in three.robots] == ["robotA", "robotB", "robotC"]
    assert sum(o.type == "landmark" for o in three.objects) == 4
    assert sum(o.type == "cone" for o in three.objects) == 1

    office = load_world(os.path.join(WORLDS, "office.yaml"))
    assert len(office.robots) == 1 and office.robots[0].namespace == ""
    assert sum(o.type == "furniture" for o in office.objects) >= 10


def test_furniture_is_rasterised_into_the_grid_not_the_map(tmp_path):
    room_map(tmp_path)
    w = load_world(write_world(tmp_path, """
map: m.yaml
objects:
  - {name: desk, type: furniture, kind: desk, pose: [1.0, 0.0, 0.0], size_m: [1.0, 0.4]}
  - {name: t, type: furniture, kind: table, pose: [-0.2, 0.0, 0.0], size_m: [0.6, 0.6],
     solid: legs, leg_radius_m: 0.03}
  - {name: p, type: poster, logo: osu_pete, pose: [0.0, 1.85, -1.5708]}
"""))
    assert w.map.value_at(1.0, 0.0) == FREE
    assert w.grid.value_at(1.0, 0.0) == OCCUPIED
    assert w.grid.value_at(1.45, 0.15) == OCCUPIED  # inside the desk
    assert w.grid.value_at(1.0, 0.25) == FREE  # the next cell beyond its edge
    assert w.grid.value_at(1.0, -0.25) == FREE
    assert w.grid.value_at(0.45, 0.0) == FREE and w.grid.value_at(1.55, 0.0) == FREE
    assert np.count_nonzero(w.grid.solid) - np.count_nonzero(w.map.solid) == 10 * 4
    # A table with legs: four circles inset at the corners, the grid stays free.
    assert w.grid.value_at(-0.2, 0.0) == FREE
    assert len(w.circles) == 4
    corners = np.array([[0.1, 0.3], [-0.5, 0.3], [-0.5, -0.3], [0.1, -0.3]])
    d = np.hypot(*(w.circles[:, :2] - corners).T)
    assert np.all(d == pytest.approx(0.03))
    # The ground-truth map has the legs rasterised.
    assert w.truth_map.value_at(0.1 - 0.02, 0.3 - 0.02) == OCCUPIED
    # A poster is not solid.
    assert w.grid.value_at(0.0, 1.8) == FREE


def test_object_footprint_follows_pose(tmp_path):
    room_map(tmp_path)
    w = load_world(write_world(tmp_path, """
map: m.yaml
objects:
  - {name: shelf, type: furniture, kind: shelf, pose: [0.5, 0.5, 1.5707963], size_m: [1.0, 0.2]}
"""))
    fp = w.objects[0].footprint
    assert fp[:, 0].min() == pytest.approx(0.4) and fp[:, 0].max() == pytest.approx(0.6)
    assert fp[:, 1].min() == pytest.approx(0.0, abs=1e-6)
    assert fp[:, 1].max() == pytest.approx(1.0)


def bad(tmp_path, text, field, words=()):
    path = write_world(tmp_path, text)
    with pytest.raises(WorldError) as info:
        load_world(path)
    err = info.value
    msg = str(err)
    assert "\n" not in msg
    assert err.path == path and msg.startswith(path + ": ")
    assert err.field == field, msg
    for w in words:
        assert w in msg, msg
    return err


def test_errors_name_file_and_field(tmp_path):
    room_map(tmp_path)
    head = "map: m.yaml\n"
    bad(tmp_path, head + "robots:\n  - {name: r, pose: [1.0, 1.0]}\n", "robots[0].pose",
        ["3 numbers"])
    bad(tmp_path, head + "robots:\n  - {name: r, pose: [0.0, 0.0, 0.0], colour: red}\n",
        "robots[0].colour", ["unknown field"])
    bad(tmp_path, head + "robots:\n  - {name: r, pose: [0.0, 0.0, 0.0], model: roomba}\n",
        "robots[0].model", ["create_1", "create_2"])
    bad(tmp_path, head + "objects:\n  - {name: c, type: cone, pose: [0, 0], radius_m: -1}\n",
        "objects[0].radius_m", ["> 0"])
    bad(tmp_path, head + "objects:\n  - {name: c, type: rock, pose: [0, 0]}\n",
        "objects[0].type", ["cone"])
    bad(tmp_path, head + "objects:\n  - {name: c, type: furniture, pose: [0, 0]}\n",
        "objects[0].kind", ["missing"])
    bad(tmp_path, head + "objects:\n  - {name: d, type: furniture, kind: desk, "
        "pose: [0, 0]}\n", "objects[0].size_m", ["exactly one"])
    bad(tmp_path, head + "objects:\n  - {name: c, type: cone, pose: [0, 0], color: mauve}\n",
        "objects[0].color", ["unknown colour"])
    bad(tmp_path, head + "objects:\n  - {name: a, type: cone, pose: [0, 0]}\n"
        "  - {name: a, type: cone, pose: [0.5, 0.5]}\n", "objects[1].name", ["already used"])
    bad(tmp_path, head + "robots:\n  - {name: a, pose: [0, 0, 0]}\n"
        "  - {name: b, pose: [1, 1, 0]}\n", "robots[1].namespace", ["already used"])
    bad(tmp_path, head + "robots:\n  - {name: a, namespace: 9x, pose: [0, 0, 0]}\n",
        "robots[0].namespace", ["relative ROS name"])
    bad(tmp_path, head + "people:\n  - {name: p, route: []}\n", "people[0].route",
        ["non-empty"])
    bad(tmp_path, head + "people:\n  - {name: p, route: [{at: [0, 0], wait_s: -3}]}\n",
        "people[0].route[0].wait_s", [">= 0"])
    bad(tmp_path, "robots: []\n", "map", ["missing"])
    bad(tmp_path, "map: nowhere.yaml\n", "map", ["does not exist"])
    bad(tmp_path, head + "robots: {name: r}\n", "robots", ["list"])
    bad(tmp_path, head + "objects:\n  - [1, 2]\n", "objects[0]", ["mapping"])


def test_yaml_syntax_error_names_line(tmp_path):
    room_map(tmp_path)
    err = bad(tmp_path, "map: m.yaml\nrobots:\n  - {name: r, pose: [1, 2, 0]\n", "(yaml)",
              ["syntax error", "line"])
    assert "Traceback" not in str(err)


def test_robot_inside_wall_or_outside_is_refused(tmp_path):
    room_map(tmp_path)  # walls: x in [-1.0, -0.9] ... [1.9, 2.0], y in [-2.0, -1.9] ...
    bad(tmp_path, "map: m.yaml\nrobots:\n  - {name: r, pose: [-0.95, 0.0, 0.0]}\n",
        "robots[0].pose", ["overlaps a wall"])
    bad(tmp_path, "map: m.yaml\nrobots:\n  - {name: r, pose: [-0.8, 0.0, 0.0]}\n",
        "robots[0].pose", ["overlaps a wall"])  # centre free, footprint in the wall
    bad(tmp_path, "map: m.yaml\nrobots:\n  - {name: r, pose: [30.0, 0.0, 0.0]}\n",
        "robots[0].pose", ["outside the map"])
    bad(tmp_path, "map: m.yaml\nobjects:\n  - {name: c, type: cone, pose: [0.5, 0.0]}\n"
        "robots:\n  - {name: r, pose: [0.3, 0.0, 0.0]}\n", "robots[0].pose", ["cone"])
    bad(tmp_path, "map: m.yaml\nobjects:\n  - {name: d, type: furniture, kind: desk, "
        "pose: [0.5, 0.0, 0.0], size_m: [1, 1]}\nrobots:\n  - {name: r, pose: [0.5, 0.0, 0]}\n",
        "robots[0].pose", ["furniture"])
    bad(tmp_path, "map: m.yaml\nrobots:\n  - {name: a, namespace: a, pose: [0, 0, 0]}\n"
        "  - {name: b, namespace: b, pose: [0.2, 0, 0]}\n", "robots[1].pose", ["robot 'a'"])
    # Just clear of the wall's inner face (x = -0.9) is fine.
    path = write_world(tmp_path, "map: m.yaml\nrobots:\n  - {name: r, pose: [-0.73, 0, 0]}\n")
    assert load_world(path).robots[0].pose.x == pytest.approx(-0.73)


def test_person_route_through_wall_is_refused(tmp_path):
    img = np.full((40, 40), 254, dtype=np.uint8)
    img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = 0
    img[:, 20] = 0  # a wall across the room at x = 1.0 .. 1.1
    write_map(tmp_path, img)
    bad(tmp_path, "map: m.yaml\npeople:\n  - {name: p, route: [[0, 0], [2.0, 0.0]]}\n",
        "people[0].route[0]", ["crosses a wall"])
    bad(tmp_path, "map: m.yaml\npeople:\n  - {name: p, route: [[1.05, 0]]}\n",
        "people[0].route[0]", ["inside"])


def test_map_errors(tmp_path):
    img = np.full((4, 4), 254, dtype=np.uint8)
    for fields, field in (({"resolution": 0}, "resolution"),
                          ({"origin": "[0, 0, 0.5]"}, "origin"),
                          ({"image": "missing.pgm"}, "image"),
                          ({"free_thresh": 0.9}, "free_thresh"),
                          ({"mode": "raw"}, "mode")):
        path = write_map(tmp_path, img, **fields)
        with pytest.raises(WorldError) as info:
            load_map(path)
        assert info.value.field == field
        assert str(info.value).startswith(path)


def test_angles_in_degrees_not_confused():
    # Sanity of the shipped data: every yaw is given in radians (|yaw| <= pi).
    for name in SHIPPED:
        w = load_world(os.path.join(WORLDS, name + ".yaml"))
        for r in w.robots:
            assert abs(r.pose.yaw) <= math.pi + 1e-6
        for o in w.objects:
            assert abs(o.pose.yaw) <= math.pi + 1e-3


def test_grid_map_takes_a_matching_axis_aligned_geometry():
    occ = np.zeros((2, 3), np.int8)
    assert GridMap(occ, GridInfo(0.1, 3, 2, 1.0, 2.0)).info.origin_x == 1.0
    with pytest.raises(ValueError, match="rotated"):
        GridMap(occ, GridInfo(0.1, 3, 2, origin_yaw=0.5))
    with pytest.raises(ValueError, match="does not match"):
        GridMap(occ, GridInfo(0.1, 2, 3))


def _distance_to_polygon(x, y, poly):
    a = np.asarray(poly, dtype=float)
    b = np.roll(a, -1, axis=0)
    ab = b - a
    t = np.clip(((x - a[:, 0]) * ab[:, 0] + (y - a[:, 1]) * ab[:, 1])
                / np.maximum((ab ** 2).sum(axis=1), 1e-12), 0.0, 1.0)
    return float(np.hypot(a[:, 0] + t * ab[:, 0] - x, a[:, 1] + t * ab[:, 1] - y).min())


@pytest.mark.parametrize("name, base", [("office_follow", "office"),
                                        ("apartment_follow", "apartment")])
def test_follow_route(name, base):
    """The person to follow (thesis 5.3): orange, 0.3 m/s, >= 30 m with corners and
    straight legs of several metres, starting about 1.5 m in front of the robot, and
    keeping >= 0.5 m from walls and every piece of furniture (legs tables included);
    office_follow is where the follower was tuned, apartment_follow is held out."""
    w = load_world(os.path.join(WORLDS, name + ".yaml"))
    assert w.map_path == load_world(os.path.join(WORLDS, base + ".yaml")).map_path
    (p,) = w.people
    assert p.speed_mps == pytest.approx(0.3) and p.color == (1.0, 0.45, 0.0)
    pts = np.array([[wp.x, wp.y] for wp in p.route])
    legs = np.diff(pts, axis=0)
    lengths = np.hypot(legs[:, 0], legs[:, 1])
    assert lengths.sum() >= 30.0
    headings = np.arctan2(legs[:, 1], legs[:, 0])
    turns = np.abs(np.remainder(np.diff(headings) + math.pi, 2 * math.pi) - math.pi)
    assert np.count_nonzero(turns > math.radians(60)) >= 2
    assert np.count_nonzero(lengths >= 3.0) >= 4
    r = w.robots[0].pose
    ahead = (pts[0, 0] - r.x) * math.cos(r.yaw) + (pts[0, 1] - r.y) * math.sin(r.yaw)
    side = -(pts[0, 0] - r.x) * math.sin(r.yaw) + (pts[0, 1] - r.y) * math.cos(r.yaw)
    assert 1.2 <= ahead <= 1.8 and abs(side) < 0.2
    furniture = [o.footprint for o in w.objects if len(o.footprint) >= 3]
    for a, b, n in zip(pts[:-1], pts[1:], lengths):
        for t in np.linspace(0.0, 1.0, int(n / 0.05) + 2):
            x, y = a + t * (b - a)
            assert w.grid.disc_contact(x, y, 0.5 - 1e-6) is None, (x, y)
            assert not circle_overlaps(x, y, 0.5 - 1e-6, w.circles), (x, y)
            assert min(_distance_to_polygon(x, y, f) for f in furniture) >= 0.5 - 1e-6


def test_poster_center_height(tmp_path):
    room_map(tmp_path)
    w = load_world(write_world(tmp_path, """
map: m.yaml
objects:
  - {name: p, type: poster, logo: ascc_logo, pose: [0.0, 1.85, -1.5708]}
  - {name: q, type: poster, logo: ascc_logo, pose: [0.5, 1.85, -1.5708], height_m: 0.4,
     center_height_m: 1.5}
"""))
    assert [o.center_height_m for o in w.objects] == [0.9, 1.5]  # 0.8 m default: 0.5-1.3 m
    with pytest.raises(WorldError) as info:
        load_world(write_world(tmp_path, """
map: m.yaml
objects:
  - {name: p, type: poster, logo: x, pose: [0.0, 1.85, -1.5708], center_height_m: 0.3}
""", name="bad.yaml"))
    assert info.value.field == "objects[0].center_height_m"
