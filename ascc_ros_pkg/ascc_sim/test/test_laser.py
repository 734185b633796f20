"""The URG-04LX model: vectorised ray casting against an independent per-beam grid
traversal, circles against geometry, and the noise/dropout statistics."""
import dataclasses
import math
import os

import numpy as np
import pytest
import yaml

from ascc_common.grid import OCCUPIED, GridInfo
from ascc_common.params import from_params, tree_getter
from ascc_sim.grid import GridMap
from ascc_sim.laser import LaserConfig, LaserModel, RayCaster, cast_circles
from ascc_sim.runner import SimulatorParams
from ascc_sim.sim import RobotModel
from ascc_sim.world import load_world

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIG = os.path.join(PKG, "config")


def reference_range(grid, x, y, angle, max_range):
    """Amanatides-Woo grid traversal, one beam at a time: (distance to the first solid
    cell or inf if none within max_range, length of the beam inside that cell [m]).
    Independent of the code under test."""
    info = grid.info
    res = info.resolution
    u, v = (x - info.origin_x) / res, (y - info.origin_y) / res
    dx, dy = math.cos(angle), math.sin(angle)
    ix, iy = int(math.floor(u)), int(math.floor(v))
    step_x = 1 if dx > 0 else -1
    step_y = 1 if dy > 0 else -1
    t_max_x = ((ix + (dx > 0)) - u) / dx if dx != 0 else math.inf
    t_max_y = ((iy + (dy > 0)) - v) / dy if dy != 0 else math.inf
    t_dx = abs(1.0 / dx) if dx != 0 else math.inf
    t_dy = abs(1.0 / dy) if dy != 0 else math.inf
    t = 0.0
    while t * res <= max_range:
        if 0 <= ix < info.width and 0 <= iy < info.height and grid.solid[iy, ix]:
            return t * res, (min(t_max_x, t_max_y) - t) * res
        if t_max_x < t_max_y:
            t, ix = t_max_x, ix + step_x
            t_max_x += t_dx
        else:
            t, iy = t_max_y, iy + step_y
            t_max_y += t_dy
    return math.inf, 0.0


def random_grid(rng, w=120, h=90, fill=0.03):
    occ = np.where(rng.random((h, w)) < fill, OCCUPIED, 0).astype(np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = OCCUPIED
    return GridMap(occ, GridInfo(0.05, w, h, -1.0, -2.0))


def test_raycast_matches_cell_traversal():
    rng = np.random.default_rng(3)
    angles = np.linspace(-math.pi, math.pi, 721)
    total = mismatched = clipped = 0
    for _ in range(6):
        grid = random_grid(rng)
        caster = RayCaster(grid, 4.094)
        x, y = -1.0 + rng.uniform(0.5, 5.5), -2.0 + rng.uniform(0.5, 4.0)
        ix, iy = grid.info.world_to_cell(x, y)
        if grid.solid[iy, ix]:
            continue
        got, cos_inc, _ = caster.cast(x, y, angles)
        ref, chord = np.array([reference_range(grid, x, y, a, 4.094) for a in angles]).T
        hit = np.isfinite(ref)
        same = np.isfinite(got) & hit
        same[same] = np.abs(got[same] - ref[same]) < 1e-9
        assert np.array_equal(np.isfinite(got) | hit, hit)  # no hit where there is none
        total += int(hit.sum())
        missed = hit & ~same
        mismatched += int(missed.sum())
        clipped += int((hit & (chord < grid.info.resolution / 3)).sum())
        assert np.all(cos_inc >= 0) and np.all(cos_inc <= 1)
    assert total > 3000
    assert clipped > 50  # the corner cases are really exercised
    # Exact, including beams that only clip the corner of a cell (chord -> 0).
    assert mismatched == 0


def test_wall_range_and_incidence_exact():
    occ = np.zeros((100, 100), dtype=np.int8)
    occ[:, 60] = OCCUPIED  # a wall whose face is at x = 60 * 0.05 = 3.0 m
    grid = GridMap(occ, GridInfo(0.05, occ.shape[1], occ.shape[0]))
    caster = RayCaster(grid, 4.094)
    angles = np.radians([0.0, 30.0, -45.0, 90.0, 180.0])
    r, cos_inc, cell = caster.cast(1.0, 2.5, angles)
    assert r[0] == pytest.approx(2.0, abs=1e-9)
    assert r[1] == pytest.approx(2.0 / math.cos(math.radians(30)), abs=1e-9)
    assert r[2] == pytest.approx(2.0 / math.cos(math.radians(45)), abs=1e-9)
    assert math.isinf(r[3]) and math.isinf(r[4])  # along the wall / away: no return
    assert cos_inc[0] == pytest.approx(1.0)
    assert cos_inc[1] == pytest.approx(math.cos(math.radians(30)))
    assert cell[0] == 50 * 100 + 60 and cell[3] == -1


def test_beyond_max_range_is_no_return():
    occ = np.zeros((20, 200), dtype=np.int8)
    occ[:, 100] = OCCUPIED  # face at x = 5.0 m
    grid = GridMap(occ, GridInfo(0.05, occ.shape[1], occ.shape[0]))
    r, _, _ = RayCaster(grid, 4.094).cast(0.5, 0.5, np.array([0.0]))
    assert math.isinf(r[0])
    r, _, _ = RayCaster(grid, 4.094).cast(1.0, 0.5, np.array([0.0]))
    assert r[0] == pytest.approx(4.0)


def test_circles():
    circles = np.array([[2.0, 0.0, 0.5], [0.0, 3.0, 0.25], [-1.0, 0.0, 0.1]])
    angles = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2, math.atan2(0.5, 2.0)])
    r, cos_inc = cast_circles(0.0, 0.0, angles, circles)
    assert r[0] == pytest.approx(1.5)
    assert r[1] == pytest.approx(2.75)
    assert r[2] == pytest.approx(0.9)
    assert math.isinf(r[3])
    # Tangent ray: grazing incidence.
    tangent = math.asin(0.5 / 2.0)
    a = tangent - 1e-4
    r2, cos2 = cast_circles(0.0, 0.0, np.array([a]), circles)
    hit = np.array([r2[0] * math.cos(a), r2[0] * math.sin(a)])
    assert np.hypot(*(hit - circles[0, :2])) == pytest.approx(0.5)  # on the circle
    assert r2[0] < math.sqrt(2.0 ** 2 - 0.5 ** 2)  # before the tangent point
    assert cos2[0] < 0.05
    assert cos_inc[0] == pytest.approx(1.0)
    # A circle around the laser is ignored; one beyond max range is skipped.
    r3, _ = cast_circles(0.0, 0.0, np.array([0.0]), np.array([[0.0, 0.0, 1.0]]))
    assert math.isinf(r3[0])
    r4, _ = cast_circles(0.0, 0.0, np.array([0.0]), np.array([[9.0, 0.0, 1.0]]), 4.0)
    assert math.isinf(r4[0])


def test_urg04lx_geometry():
    cfg = LaserConfig()
    assert cfg.n_beams == 683
    assert math.degrees(cfg.angle_increment_rad) == pytest.approx(0.3515625)
    a = cfg.angles
    assert math.degrees(a[0]) == pytest.approx(-120.0)
    assert math.degrees(a[-1]) <= 120.0 and math.degrees(a[-1]) > 119.6
    assert (cfg.range_min_m, cfg.range_max_m, cfg.scan_period_s) == (0.02, 4.094, 0.1)
    cfg2 = from_params(LaserConfig, {"angle_min_deg": -90, "angle_max_deg": 90,
                                     "angle_increment_rad": math.radians(1.0)}.get)
    assert cfg2.n_beams == 181
    with pytest.raises(ValueError, match="parameter laser/range_max: unknown"):
        from_params(SimulatorParams, tree_getter({"laser": {"range_max": 4.0}}))
    for bad in ({"range_min_m": 5.0}, {"angle_max_deg": -130}, {"step_cells": 1.0},
                {"scan_period_s": 0.0}, {"angle_increment_rad": 0.0}):
        with pytest.raises(ValueError):
            from_params(LaserConfig, bad.get)


def test_shipped_robot_and_laser_files_are_the_defaults():
    tree = {}
    for ns, name in (("robot", "asccbot.yaml"), ("laser", "urg04lx.yaml")):
        with open(os.path.join(CONFIG, name)) as f:
            tree[ns] = yaml.safe_load(f)
    p = from_params(SimulatorParams, tree_getter(tree))
    for got, default in ((p.robot, RobotModel()), (p.laser, LaserConfig())):
        for field in dataclasses.fields(default):
            assert getattr(got, field.name) == pytest.approx(getattr(default, field.name),
                                                            rel=1e-12, abs=1e-15), field.name
    with pytest.raises(ValueError, match="parameter robot/wheel_base: unknown"):
        from_params(SimulatorParams, tree_getter({"robot": {"wheel_base": 0.3}}))
    with pytest.raises(ValueError, match="parameter robot/radius_m: must be > 0.0"):
        from_params(SimulatorParams, tree_getter({"robot": {"radius_m": 0}}))


def open_room_model(**cfg):
    occ = np.zeros((120, 120), dtype=np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = OCCUPIED
    grid = GridMap(occ, GridInfo(0.05, occ.shape[1], occ.shape[0]))
    return LaserModel(grid, LaserConfig(**cfg))


def test_noise_statistics_and_bounds():
    model = open_room_model()
    rng = np.random.default_rng(7)
    truth, cos_inc, material = model.true_ranges(3.0, 3.0, 0.3, np.zeros((0, 3)))
    rel = []
    for _ in range(200):
        r = model.apply_noise(truth, cos_inc, material, rng)
        ok = np.isfinite(r) & np.isfinite(truth)
        rel.append((r[ok] - truth[ok]) / truth[ok])
    rel = np.concatenate(rel)
    assert np.all(np.abs(rel) <= 0.03 + 0.001 / 0.5)  # +-3 % plus the 1 mm quantum
    assert abs(rel.mean()) < 0.001
    assert rel.std() == pytest.approx(0.01, rel=0.1)


def test_dropouts_far_and_grazing():
    model = open_room_model()
    rng = np.random.default_rng(11)
    n = 20000
    near = np.full(n, 1.0)
    far = np.full(n, 4.0)
    head_on = np.ones(n)
    grazing = np.full(n, math.cos(math.radians(85.0)))
    none = np.zeros(n)
    p_near = np.isnan(model.apply_noise(near, head_on, none, rng)).mean()
    p_far = np.isnan(model.apply_noise(far, head_on, none, rng)).mean()
    p_graze = np.isnan(model.apply_noise(near, grazing, none, rng)).mean()
    p_glass = np.isnan(model.apply_noise(near, head_on, np.full(n, 0.9), rng)).mean()
    assert p_near == 0.0
    # Expected from the model's parameters: far 0.3 * ((4.0-3.0)/(4.094-3.0))^2.
    assert p_far == pytest.approx(0.3 * (1.0 / 1.094) ** 2, abs=0.02)
    assert p_graze == pytest.approx(0.8 * 15.0 / 20.0, abs=0.02)
    assert p_glass == pytest.approx(0.9, abs=0.02)
    inf = model.apply_noise(np.full(5, np.inf), np.ones(5), np.zeros(5), rng)
    assert np.all(np.isposinf(inf))  # REP 117: no return -> +inf
    close = model.apply_noise(np.full(5, 0.01), np.ones(5), np.zeros(5), rng)
    assert np.all(np.isneginf(close))  # closer than range_min -> -inf


def test_scan_is_deterministic_per_seed():
    world = load_world(os.path.join(PKG, "worlds", "office.yaml"))
    model = LaserModel(world.grid, LaserConfig(), world.dropout)
    a = model.scan(2.5, 7.6, 0.2, world.circles, np.random.default_rng(5))
    b = model.scan(2.5, 7.6, 0.2, world.circles, np.random.default_rng(5))
    c = model.scan(2.5, 7.6, 0.2, world.circles, np.random.default_rng(6))
    assert np.allclose(a, b, rtol=0, atol=0, equal_nan=True)
    assert not np.allclose(a, c, rtol=0, atol=0, equal_nan=True)


def test_glass_cabinet_swallows_returns():
    world = load_world(os.path.join(PKG, "worlds", "lab.yaml"))
    model = LaserModel(world.grid, LaserConfig(), world.dropout)
    # From (7.0, 5.9) looking at the cabinet (8.0..9.2, 6.95..7.35) north-east.
    x, y, yaw = 8.6, 5.8, math.pi / 2
    truth, _, material = model.true_ranges(x, y, yaw, world.circles)
    centre = np.abs(model.angles) < math.radians(15)
    assert np.all(material[centre] == pytest.approx(0.9))
    rng = np.random.default_rng(1)
    drops = [np.isnan(model.scan(x, y, yaw, world.circles, rng)[centre]).mean()
             for _ in range(50)]
    assert np.mean(drops) > 0.8
