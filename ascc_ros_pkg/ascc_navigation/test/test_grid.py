"""Tests of the grid algorithms (no ROS master needed); the grid type itself is tested in
ascc_common."""

import math

import numpy as np
import pytest

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN, GridInfo
from ascc_navigation import grid as G


def test_occupancy_from_counts_follows_gmapping_rule():
    hits = np.array([0, 0, 1, 1, 3], dtype=np.uint8)
    visits = np.array([0, 5, 4, 3, 4], dtype=np.uint8)
    occ = G.occupancy_from_counts(hits, visits, 0.25)
    # unknown, free (0/5), 1/4 = 0.25 is not above the threshold, 1/3 is, 3/4 is
    assert occ.tolist() == [UNKNOWN, FREE, FREE, OCCUPIED, OCCUPIED]


@pytest.mark.parametrize("occ_thresh", [0.25, 0.3, 0.65])
def test_occupancy_table_is_the_rule_for_every_uint8_pair(occ_thresh):
    """The uint8 lookup gives what the rule gives on wider counts, for all 65536 pairs (0.3:
    a threshold float32 cannot hold exactly)."""
    visits, hits = np.divmod(np.arange(1 << 16), 1 << 8)
    wide = G.occupancy_from_counts(hits.astype(np.int32), visits.astype(np.int32), occ_thresh)
    fast = G.occupancy_from_counts(hits.astype(np.uint8), visits.astype(np.uint8), occ_thresh)
    assert fast.dtype == np.int8 and np.array_equal(fast, wide)
    assert (fast == UNKNOWN).sum() == 256 and (fast == OCCUPIED).any() and (fast == FREE).any()
    grid = fast.reshape(256, 256)  # and on a 2-D grid, as the mapper calls it
    assert np.array_equal(G.occupancy_from_counts(
        (hits % 256).astype(np.uint8).reshape(256, 256),
        visits.astype(np.uint8).reshape(256, 256), occ_thresh), grid)


def test_sample_segments_spacing_and_cells():
    info = GridInfo(0.1, 50, 50, 0.0, 0.0)
    rng = np.random.default_rng(3)
    x1, y1 = rng.uniform(0.1, 4.9, 40), rng.uniform(0.1, 4.9, 40)
    xs, ys, seg = G.sample_segments(2.51, 2.47, x1, y1, 0.01, include_end=True)
    assert seg.min() == 0 and seg.max() == 39
    # samples lie on their segment, one step apart except the last gap (to the end point)
    for k in range(40):
        gaps = np.hypot(np.diff(xs[seg == k]), np.diff(ys[seg == k]))
        assert np.allclose(gaps[:-1], 0.01) and 0.0 < gaps[-1] <= 0.01 + 1e-12
    last = np.r_[np.nonzero(np.diff(seg))[0], seg.size - 1]
    cross = (xs - 2.51) * (y1[seg] - 2.47) - (ys - 2.47) * (x1[seg] - 2.51)
    assert np.abs(cross).max() < 1e-9
    ix, iy = info.world_to_cell(xs, ys)
    for k in (0, 17, 39):  # compare with a dense reference trace for a few segments
        t = np.linspace(0.0, 1.0, 5000)
        rx, ry = info.world_to_cell(2.51 + t * (x1[k] - 2.51), 2.47 + t * (y1[k] - 2.47))
        ref = set(zip(rx.tolist(), ry.tolist()))
        got = set(zip(ix[seg == k].tolist(), iy[seg == k].tolist()))
        # with step = resolution/10 only cells clipped at a corner may be missed
        assert got <= ref and len(ref - got) <= 0.1 * len(ref)
    # the last sample of every segment is its end point; without include_end it is not
    assert np.allclose(xs[last], x1) and np.allclose(ys[last], y1)
    xo, yo, so = G.sample_segments(0.0, 0.0, [0.3, 0.0], [0.0, 0.0], 0.1)
    assert so.tolist() == [0, 0, 0] and np.allclose(xo, [0.0, 0.1, 0.2])


def test_raycast_matches_analytic_wall_distance():
    info = GridInfo(0.05, 100, 100, 0.0, 0.0)
    occ = np.zeros(info.shape, dtype=bool)
    occ[:, 80] = True  # wall whose near face is at x = 4.0
    angles = np.array([0.0, 0.3, -0.5, math.pi])
    r = G.raycast(occ, info, 1.0, 2.5, angles, max_range=5.0)
    expected = 3.0 / np.cos(angles[:3])
    assert np.allclose(r[:3], expected, atol=0.002)
    assert np.isinf(r[3])  # nothing behind within range
    # a ray that starts inside an obstacle reports 0
    assert G.raycast(occ, info, 4.02, 2.5, [0.0], 5.0)[0] == 0.0


def test_map_agreement_counts_and_offsets():
    truth = np.zeros((10, 10), dtype=np.int8)
    truth[:, 0] = OCCUPIED
    tinfo = GridInfo(0.1, 10, 10, 0.0, 0.0)
    est = np.full((10, 10), UNKNOWN, dtype=np.int8)
    est[2:8, 0] = OCCUPIED
    est[2:8, 1:5] = FREE
    est[2, 4] = OCCUPIED  # one wrong cell
    res = G.map_agreement(est, tinfo, truth, tinfo)
    assert res["known"] == 30 and res["agree"] == 29
    assert res["accuracy"] == pytest.approx(29 / 30)
    assert res["occupied_accuracy"] == pytest.approx(6 / 7)
    assert res["free_accuracy"] == 1.0 and res["unmatched"] == 0
    # shifted by one cell the wall no longer lines up
    shifted = G.map_agreement(est, tinfo, truth, tinfo, offset=(0.1, 0.0, 0.0))
    assert shifted["accuracy"] < 0.85
    # a map built in a frame turned by 90 degrees agrees once the offset says so
    # truth = R(90 deg) * estimate, i.e. estimate (x, y) = truth (y, -x): truth cell (ix, iy)
    # is estimate cell (iy, 9 - ix) on a grid whose origin is (0, -1)
    iy, ix = np.indices(est.shape)
    turned = np.empty_like(est)
    turned[9 - ix, iy] = est[iy, ix]
    res_t = G.map_agreement(turned, GridInfo(0.1, 10, 10, 0.0, -1.0), truth, tinfo,
                            offset=(0.0, 0.0, math.pi / 2))
    assert res_t["known"] == 30 and res_t["agree"] == 29
    # cells off the truth grid are reported, not compared
    far = G.map_agreement(est, GridInfo(0.1, 10, 10, 5.0, 0.0), truth, tinfo)
    assert far["unmatched"] == 30 and far["known"] == 0
