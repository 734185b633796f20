"""The compiled kernels (climb.py) against the numpy code they replace: the hill climb's
scores (within the score table's bound) and, step by step, the same search as rbpf's
numpy search before it; the score table against the exponential; the distance
transform's input image."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ascc_common.grid import OCCUPIED
from ascc_navigation import climb as C
from ascc_navigation import posegraph as P
from ascc_navigation import rbpf as R
from ascc_navigation import synthetic as S
from ascc_navigation.laser import LaserMount, prepare_scan

SPEC = S.LaserSpec()
MOUNT = LaserMount(0.05, 0.0, 0.0)
WORLD = S.office_world()


def _scan(pose):
    truth, info = WORLD
    ranges = S.simulate_scan(truth == OCCUPIED, info, pose, MOUNT, SPEC,
                             np.random.default_rng(0), noise_std=0.01)
    return prepare_scan(ranges, SPEC.angle_min, SPEC.angle_increment, SPEC.range_min,
                        SPEC.range_max, MOUNT, 3.9, free_pullback=0.05, hit_offset=0.025)


@pytest.fixture(scope="module")
def filled():
    """A three-particle filter whose maps differ (each registered the scans a few cm and
    a degree apart; particle 0 at the true poses), its likelihood fields around the next
    pose, and the end points of the scan there that an update would match."""
    info = WORLD[1]
    cfg = R.RbpfConfig(particles=3, xmin=0, ymin=0, xmax=info.width * info.resolution,
                       ymax=info.height * info.resolution)
    slam = R.RbpfSlam(cfg, seed=0)
    path = [np.array([4.0, 1.8, 0.1]), np.array([4.4, 1.9, 0.15]), np.array([4.8, 2.0, 0.3])]
    slam.start(path[0], _scan(path[0]))
    skew = np.array([[0.0, 0.0, 0.0], [0.04, -0.03, 0.02], [-0.05, 0.02, -0.015]])
    for p in path[1:]:
        slam.poses[:] = p + skew
        slam._register(_scan(p))
    pose = np.array([5.1, 2.05, 0.35])
    slam.poses[:] = pose
    scan = _scan(pose)
    # the end points an update would match: those within what the map can hold
    moved = math.hypot(*(pose - path[-1])[:2])
    pts = scan.match[scan.match_range <= scan.max_urange - moved - cfg.new_area_margin]
    return cfg, slam._fields(pts), pts, pose


def _table_bound(sigma, radius):
    """The score table's error bound per beam: h^2 / 8 times the largest |f''| of
    f(d) = exp(-d^2 / (2 sigma^2)), which is 1 / sigma^2 (at d = 0)."""
    h = radius / C.TABLE_SIZE
    return h * h / (8.0 * sigma * sigma)


@pytest.mark.parametrize("sigma, radius", [(0.05, 0.15), (0.02, 0.1), (0.1, 0.3)])
def test_the_score_table_is_the_exponential_within_its_bound(sigma, radius):
    """Every distance the fields can hold, [0, radius] and float rounding past it: the
    table's value within its bound of exp(-d^2 / (2 sigma^2)), exact at its entries."""
    table, inv_h = C.score_table(radius, sigma)
    d = np.concatenate([np.linspace(0.0, radius, 100003), [radius * (1 + 1e-7), -1e-12]])
    got = np.array([C._kernel(table, inv_h, C.TABLE_SIZE, x) for x in d])
    want = np.exp(d * d * np.float32(-0.5 / sigma ** 2))
    err = np.abs(got - want)
    bound = _table_bound(sigma, radius)
    assert err.max() <= bound * (1 + 1e-6) + 1e-15
    assert err.max() > 0.5 * bound  # the bound is what the table does, not far above
    at = np.arange(C.TABLE_SIZE + 1) * (radius / C.TABLE_SIZE)
    np.testing.assert_allclose([C._kernel(table, inv_h, C.TABLE_SIZE, x) for x in at[::97]],
                               np.exp(at[::97] ** 2 * np.float32(-0.5 / sigma ** 2)),
                               rtol=1e-12)


def _starts(pose, n, seed):
    rng = np.random.default_rng(seed)
    return pose + rng.uniform([-0.1, -0.1, -0.06], [0.1, 0.1, 0.06], (n, 3))


def test_compiled_score_is_the_numpy_lookups_score(filled):
    cfg, fields, pts, pose = filled
    starts = _starts(pose, 12, 1)
    particles = np.arange(12) % 3
    want = fields.match_score(fields.distances(starts[:, None, :], particles, pts),
                              cfg.sigma)[:, 0]
    g = C.geometry(fields, cfg.sigma)
    mx, my = C.end_points(pts, fields.res)
    got = np.array([C._score(g, int(p) * fields.band * fields.w, x, y, t, mx, my)
                    for (x, y, t), p in zip(starts, particles)])
    assert want.min() > 0.2 * pts.shape[0]  # the poses are near: most beams count
    atol = pts.shape[0] * _table_bound(cfg.sigma, fields.radius)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=atol)
    assert np.abs(got - want).max() > 1e-9  # the table, not the C library's exp
    # a pose far outside the window clamps to its border, as numpy's clip
    far = np.array([[pose[0] + 30.0, pose[1] - 20.0, 1.0]])
    want_far = fields.match_score(fields.distances(far[:, None, :], np.array([2]), pts),
                                  cfg.sigma)[0, 0]
    got_far = C._score(g, 2 * fields.band * fields.w, *far[0], mx, my)
    np.testing.assert_allclose(got_far, want_far, rtol=1e-12, atol=atol)


def test_six_moves_in_one_pass_score_as_six_poses(filled):
    cfg, fields, pts, pose = filled
    g = C.geometry(fields, cfg.sigma)
    mx, my = C.end_points(pts, fields.res)
    base = fields.band * fields.w  # particle 1
    dl, da = 0.025, 0.0125
    out = np.empty(6)
    C._six_scores(g, base, pose[0], pose[1], pose[2], dl, da, mx, my, out)
    for m in range(6):
        q = pose + C.MOVES[m] * np.array([dl, dl, da])
        assert out[m] == C._score(g, base, q[0], q[1], q[2], mx, my)
    assert len(set(out.tolist())) == 6


def _numpy_climb(fields, pts, prior, start, particles, cfg, along):
    """rbpf's search before the kernel, all poses at once on the numpy lookups."""
    n = start.shape[0]
    pose = start.copy()
    score = fields.match_score(fields.distances(pose[:, None, :], particles, pts),
                               cfg.sigma)[:, 0]
    best = score.copy()
    step = np.ones(n)
    halvings = np.zeros(n, dtype=int)
    unit = np.array([cfg.lstep, cfg.lstep, cfg.astep])
    heading = np.stack([np.cos(start[:, 2]), np.sin(start[:, 2])], axis=-1)
    for _ in range(R.MAX_CLIMB_STEPS):
        active = np.nonzero(halvings < cfg.iterations)[0]
        if active.size == 0:
            break
        cand = pose[active, None, :] + C.MOVES[None] * (step[active, None, None] * unit)
        sc = fields.match_score(fields.distances(cand, particles[active], pts), cfg.sigma)
        off = cand - start[active, None, :]
        obj = sc - (off ** 2 * prior).sum(axis=-1)
        if along:
            obj -= along * np.einsum("mkj,mj->mk", off[..., :2], heading[active]) ** 2
        j = np.argmax(obj, axis=1)
        rows = np.arange(active.size)
        better = obj[rows, j] > best[active]
        moved = active[better]
        pose[moved] = cand[better, j[better]]
        best[moved] = obj[rows, j][better]
        score[moved] = sc[rows, j][better]
        stuck = active[~better]
        step[stuck] *= 0.5
        halvings[stuck] += 1
    return pose, score


@pytest.mark.parametrize("prior, along", [((0.0, 0.0, 0.0), 0.0), ((400.0, 400.0, 900.0), 0.0),
                                          ((100.0, 100.0, 900.0), 2000.0)])
def test_compiled_climb_takes_the_numpy_searchs_steps(filled, prior, along):
    cfg, fields, pts, pose = filled
    starts = _starts(pose, 15, 2)
    particles = np.arange(15) % 3
    prior = np.array(prior)
    want_pose, want_score = _numpy_climb(fields, pts, prior, starts, particles, cfg, along)
    got_pose, got_score = C.hill_climb(fields, pts, prior, starts, particles, cfg.lstep,
                                       cfg.astep, cfg.iterations, cfg.sigma,
                                       R.MAX_CLIMB_STEPS, along)
    moved = np.abs(want_pose - starts).max(axis=1)
    assert (moved > 0.02).sum() >= 10  # the searches went somewhere
    np.testing.assert_allclose(got_pose, want_pose, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got_score, want_score, rtol=1e-12,
                               atol=pts.shape[0] * _table_bound(cfg.sigma, fields.radius))


def test_a_pose_that_is_not_a_number_stays_inside_the_fields(filled):
    """numba does not check indices: a NaN pose (or end point) must not read outside the
    patch image. Its end points clamp to the window's corner cell, like far-off ones."""
    cfg, fields, pts, pose = filled
    g = C.geometry(fields, cfg.sigma)
    mx, my = C.end_points(pts, fields.res)
    corner = C._score(g, 0, fields.origin_x - 50.0, fields.origin_y - 50.0, 0.0, mx, my)
    assert C._score(g, 0, math.nan, pose[1], pose[2], mx, my) >= 0.0
    assert C._score(g, 0, math.nan, math.nan, 0.0, mx, my) == corner
    got, score = C.hill_climb(fields, pts, np.zeros(3), np.array([[math.nan, 1.0, 0.0]]),
                              np.array([2]), cfg.lstep, cfg.astep, cfg.iterations, cfg.sigma,
                              R.MAX_CLIMB_STEPS)
    assert np.isnan(got[0, 0]) and np.isfinite(score[0])


@pytest.mark.parametrize("window", [(3, 5, 40, 29), (0, 0, 50, 30), (49, 29, 50, 30)])
def test_field_image_is_the_table_of_each_cells_counts(window):
    """As numpy had it: table[visits << 8 | hits] over the window, 255 in the pad rows."""
    rng = np.random.default_rng(4)
    visits = rng.integers(0, 256, (3, 30, 50), dtype=np.uint8)
    hits = rng.integers(0, 256, (3, 30, 50), dtype=np.uint8)
    table = R._field_table(0.25)
    x0, y0, x1, y1 = window
    band = y1 - y0 + 4
    key = visits[:, y0:y1, x0:x1].astype(np.uint16) << 8
    key |= hits[:, y0:y1, x0:x1]
    want = np.full((3, band, x1 - x0), 255, dtype=np.uint8)
    want[:, :y1 - y0] = table[key]
    got = C.field_image(visits, hits, window, band, table)
    assert got.dtype == np.uint8 and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    assert (want[:, :y1 - y0] == 0).any() and (want[:, :y1 - y0] == 255).any()


def _bilinear_distances(field, x, y):
    """The numpy lookups the refinement used before ``pose_scores``: bilinear distance [m]
    at world points (cell centres; off-field points clamp)."""
    u = np.clip((x - field.x0) / field.res - 0.5, 0.0, field.w - 1.001)
    v = np.clip((y - field.y0) / field.res - 0.5, 0.0, field.h - 1.001)
    iu, iv = u.astype(np.int64), v.astype(np.int64)
    fu, fv = u - iu, v - iv
    d = field.dist
    top = d[iv, iu] + fu * (d[iv, iu + 1] - d[iv, iu])
    bottom = d[iv + 1, iu] + fu * (d[iv + 1, iu + 1] - d[iv + 1, iu])
    return top + fv * (bottom - top)


@pytest.fixture(scope="module")
def loop_field():
    """The loop closure's likelihood field of the office scans at two poses, and the end
    points of a scan 0.4 m on (posegraph's correlative matcher)."""
    a, b = np.array([4.0, 1.8, 0.1]), np.array([4.4, 1.9, 0.15])
    cloud = np.vstack([P._transform(p, _scan(p).hits) for p in (a, b)])
    field = P.LikelihoodField(cloud, 0.02, 1.0, 0.15)
    return field, _scan(np.array([4.8, 2.0, 0.3])).match


def test_pose_scores_are_the_bilinear_lookups_scores(loop_field):
    """posegraph's refinement scores, compiled, against the numpy lookups they replace
    (``_bilinear_distances``), also for poses off the field (clamped) and NaN."""
    field, pts = loop_field
    rng = np.random.default_rng(2)
    cand = np.array([4.8, 2.0, 0.3]) + rng.uniform([-0.3, -0.3, -0.1], [0.3, 0.3, 0.1],
                                                   (40, 3))
    cand[0] = [-20.0, 30.0, 1.0]  # every end point off the field
    c, s = np.cos(cand[:, 2])[:, None], np.sin(cand[:, 2])[:, None]
    d = _bilinear_distances(field, cand[:, 0:1] + c * pts[:, 0] - s * pts[:, 1],
                        cand[:, 1:2] + s * pts[:, 0] + c * pts[:, 1])
    want = np.exp(-0.5 * (d / 0.05) ** 2).mean(axis=1)
    got = C.pose_scores(field.dist, field.x0, field.y0, field.res, cand, pts, 0.05)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    assert want.max() > 0.5 and want.min() < 0.1  # the poses span good and poor matches
    nan = C.pose_scores(field.dist, field.x0, field.y0, field.res,
                        np.array([[math.nan, 2.0, 0.3]]), pts, 0.05)
    assert np.isfinite(nan).all()


def test_grid_scores_are_the_gathered_means():
    """posegraph's coarse correlative search, compiled, against numpy's gather per heading
    (float32 means; the sums are float64 now, so they agree to float32's precision)."""
    rng = np.random.default_rng(3)
    lut = rng.random(40 * 50).astype(np.float32)
    shift = (np.arange(-3, 4)[:, None] * 50 + np.arange(-3, 4)[None, :]).ravel()
    base = rng.integers(3 * 50 + 3, 36 * 50 - 3, (5, 200))
    want = np.stack([lut.take(base[t][None, :] + shift[:, None]).mean(axis=1)
                     for t in range(5)])
    got = C.grid_scores(lut, base, shift)
    assert got.dtype == np.float32 and got.shape == (5, shift.size)
    np.testing.assert_allclose(got, want, rtol=2e-6)


def test_grid_scores_with_seen_space_are_the_means_over_it():
    """With a seen mask: the mean of the lookups over the points that land in it, over at
    least ``min_share`` of the points (numpy's gathers)."""
    rng = np.random.default_rng(4)
    seen = (rng.random(40 * 50) < 0.6).astype(np.float32)
    lut = rng.random(40 * 50).astype(np.float32) * seen
    shift = (np.arange(-3, 4)[:, None] * 50 + np.arange(-3, 4)[None, :]).ravel()
    base = rng.integers(3 * 50 + 3, 36 * 50 - 3, (5, 200))
    for share in (0.1, 0.9):  # the floor unused, then used (~60 % land in seen space)
        want = np.stack([lut.take(base[t][None, :] + shift[:, None]).sum(axis=1)
                         / np.maximum(seen.take(base[t][None, :] + shift[:, None]).sum(axis=1),
                                      share * 200) for t in range(5)])
        got = C.grid_scores(lut, base, shift, seen, share)
        np.testing.assert_allclose(got, want, rtol=2e-6)


def test_pose_scores_with_seen_space_weigh_each_point_by_it(loop_field):
    """With a seen mask: each point's score weighted by the mask interpolated as the
    distance is, over the sum of the weights (at least ``min_share`` of the points); a
    mask of ones scores as none."""
    field, pts = loop_field
    rng = np.random.default_rng(5)
    cand = np.array([4.8, 2.0, 0.3]) + rng.uniform([-0.3, -0.3, -0.1], [0.3, 0.3, 0.1],
                                                   (20, 3))
    seen = np.zeros_like(field.dist)
    seen[:, : field.w // 2] = 1.0  # the west half seen
    c, s = np.cos(cand[:, 2])[:, None], np.sin(cand[:, 2])[:, None]
    x = cand[:, 0:1] + c * pts[:, 0] - s * pts[:, 1]
    y = cand[:, 1:2] + s * pts[:, 0] + c * pts[:, 1]
    score = np.exp(-0.5 * (_bilinear_distances(field, x, y) / 0.05) ** 2)
    weight = _bilinear_distances(SimpleNamespace(dist=seen, x0=field.x0, y0=field.y0,
                                                 res=field.res, w=field.w, h=field.h), x, y)
    assert 0.0 < weight.mean() < 1.0
    want = (weight * score).sum(axis=1) / np.maximum(weight.sum(axis=1), 0.1 * pts.shape[0])
    got = C.pose_scores(field.dist, field.x0, field.y0, field.res, cand, pts, 0.05, seen, 0.1)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    ones = C.pose_scores(field.dist, field.x0, field.y0, field.res, cand, pts, 0.05,
                         np.ones_like(seen))
    np.testing.assert_allclose(ones, score.mean(axis=1), rtol=1e-12)


def test_warm_up_runs_the_kernels():
    assert C.warm_up() >= 0.0
