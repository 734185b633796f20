"""The semantic map (no master): fusion at the person's location, skipped and refused
activities, revisits (5.6), room feedback, saving, scoring; the recognizer's prior."""
import math
import os

import cv2
import numpy as np
import pytest
import yaml

from ascc_common.grid import FREE, OCCUPIED, GridInfo
from ascc_common.map_io import load_map
from semantic_mapping.activity import Recognizer, RecognizerConfig
from semantic_mapping.fusion import observation_given_furniture
from semantic_mapping.location import location_type_at
from semantic_mapping.models import DEFAULT_MODELS, load_models
from semantic_mapping.semantic_map import (
    LocationError,
    SemanticMap,
    SemanticMapperParams,
    footprint_distance,
    score_items,
    world_items,
)

APARTMENT = os.path.join(os.path.dirname(DEFAULT_MODELS), "apartment_models.yaml")
RES = 0.05


def room(w_m=4.0, h_m=3.0):
    """A closed room, walls one cell thick on the border, origin (-1, -1) m."""
    grid = np.full((int(round(h_m / RES)), int(round(w_m / RES))), FREE, dtype=np.int8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = OCCUPIED
    return grid, GridInfo(RES, grid.shape[1], grid.shape[0], -1.0, -1.0)


def make(models_path=DEFAULT_MODELS, **kw):
    models = load_models(models_path)
    sm = SemanticMap(models, SemanticMapperParams(**kw))
    sm.set_map(*room())
    return sm


def stay(sm, t0, t1, x, y, rate_hz=10.0):
    for t in np.arange(t0, t1, 1.0 / rate_hz):
        sm.track(float(t), x, y)


def test_fusion_at_the_person_location_by_eq_5_2():
    sm = make()
    # beside the west wall (x = -1 m): the person at 0.3 m from it
    x, y = -0.55, 0.5
    stay(sm, 0.0, 3.0, x, y)
    out = sm.observe(3.0, "sitting")
    lab = out.label
    assert lab is not None and out.skipped == ""
    cl = location_type_at(sm.grid, sm.info, sm.p.location, x, y)
    assert cl == 2  # one side beside a wall
    m = sm.models
    o = m.activities.index("sitting")
    expect = observation_given_furniture(m.observation, m.activity)[o] * m.location[cl - 1]
    expect /= expect.sum()
    np.testing.assert_allclose(lab.belief, expect)
    assert lab.label == m.furniture[int(np.argmax(expect))]
    assert lab.grid == (int(np.floor(x / 0.25)), int(np.floor(y / 0.25)))
    assert (lab.x, lab.y) == pytest.approx((x, y))
    # a second window at the same place multiplies in again
    stay(sm, 3.0, 6.0, x, y)
    lab2 = sm.observe(6.0, "sitting").label
    again = expect * expect
    np.testing.assert_allclose(lab2.belief, again / again.sum())
    assert lab2.updates == 2 and not lab2.returned


def test_location_type_from_the_newest_map():
    """A wall mapped after the observations (the person hid it) changes the grid's CL and
    its belief becomes eq. 5.2 over the same observations with the new CL."""
    sm = make()
    x, y = 1.0, 0.5
    for k in range(3):
        stay(sm, 3.0 * k, 3.0 * k + 3.0, x, y)
        lab = sm.observe(3.0 * k + 3.0, ["lying", "sitting", "lying"][k]).label
    assert lab.location_type == 1
    grid, info = room()
    ix, _ = info.world_to_cell(x + 0.4, y)
    grid[:, ix] = OCCUPIED                      # a wall 0.4 m east of the person
    sm.set_map(grid, info)
    assert lab.location_type == 2
    m = sm.models
    p_o_f = observation_given_furniture(m.observation, m.activity)
    b = np.full(len(m.furniture), 1.0 / len(m.furniture))
    for act in ("lying", "sitting", "lying"):
        b = b * p_o_f[m.activities.index(act)] * m.location[1]
        b /= b.sum()
    np.testing.assert_allclose(lab.belief, b)
    assert lab.label == m.furniture[int(np.argmax(b))]


def test_many_observations_do_not_underflow():
    sm = make()
    for k in range(400):
        sm.track(0.5 * k, 0.5, 0.5)
        lab = sm.observe(0.5 * k, "sitting" if k % 4 else "lying").label
    assert np.isfinite(lab.belief).all() and lab.belief.sum() == pytest.approx(1.0)
    assert lab.updates == 400 and lab.belief.max() > 0.999


def test_location_is_the_median_over_the_window():
    sm = make(window_s=2.0)
    stay(sm, 0.0, 5.0, 2.0, 1.0)        # earlier, elsewhere: outside the window
    stay(sm, 5.0, 8.0, 0.6, 0.6)
    sm.track(7.5, 0.9, 0.6)               # one outlier within the spread
    x, y, spread = sm.location(8.0)
    assert (x, y) == (0.6, 0.6)
    assert spread == pytest.approx(0.3)
    assert sm.observe(8.0, "lying").label.grid == (2, 2)


def test_a_location_near_a_label_is_fused_there():
    sm = make(associate_m=0.25)
    stay(sm, 0.0, 3.0, 0.49, 0.5)                # cell (1, 2)
    first = sm.observe(3.0, "sitting").label
    sm.observe(3.0, "walking")                   # two stays, not one
    stay(sm, 3.0, 6.0, 0.51, 0.5)                # cell (2, 2), 0.02 m away
    assert sm.observe(6.0, "sitting").label is first
    assert first.grid == (1, 2) and first.updates == 2 and first.x == pytest.approx(0.5)
    sm.observe(6.0, "walking")
    stay(sm, 6.0, 9.0, 0.9, 0.5)                 # 0.4 m away: a grid of its own
    other = sm.observe(9.0, "sitting").label
    assert other is not first and other.grid == (3, 2)


def jumpy_stay(sm, t0, n, points, activity):
    """``n`` windows 0.5 s apart, the person tracked at ``points[k % len(points)]``
    during window k (a location that jumps between windows, not within one)."""
    out = []
    for k in range(n):
        t = t0 + 0.5 * (k + 1)
        x, y = points[k % len(points)]
        stay(sm, t - 0.5, t, x, y)
        out.append(sm.observe(t, activity).label)
    return out


def test_one_stay_with_jumping_locations_is_one_label_at_its_median():
    """Windows of one stationary episode whose locations jump by more than associate_m
    (0.3-0.6 m here) fuse at one grid: that of the episode's median location."""
    sm = make(APARTMENT, window_s=0.5, associate_m=0.25, min_observations=5)
    pts = [(0.5, 0.5), (0.8, 0.5), (0.5, 0.8), (0.2, 0.5), (0.5, 0.2)]  # 0.3-0.6 m apart
    labs = jumpy_stay(sm, 0.0, 10, pts, "lying")
    assert len(sm.labels) == 1 and all(lab is labs[-1] for lab in labs[3:])
    (lab,) = sm.labels.values()
    xs, ys = zip(*[pts[k % 5] for k in range(10)])
    assert lab.grid == sm.cell(float(np.median(xs)), float(np.median(ys))) == (2, 2)
    assert lab.updates == 10 and lab.counts.sum() == 10
    assert (lab.x, lab.y) == (np.median(xs), np.median(ys))
    assert sm.published_labels() == [lab]
    # the same windows with a walk between each (five stays): grids of their own, none
    # with five observations
    split = make(APARTMENT, window_s=0.5, associate_m=0.25, min_observations=5)
    for k in range(10):
        split.observe(0.5 * k + 0.2, "walking")
        jumpy_stay(split, 0.5 * k, 1, [pts[k % 5]], "lying")
    assert len(split.labels) == 5 and split.published_labels() == []


def test_an_episode_moves_its_observations_with_its_median():
    """The first window of a stay located 0.5 m off: once the median settles elsewhere
    the episode's label moves there, and the first grid is gone (no stray)."""
    sm = make(window_s=0.5, associate_m=0.25)
    jumpy_stay(sm, 0.0, 1, [(1.5, 0.5)], "sitting")
    assert list(sm.labels) == [(6, 2)]
    jumpy_stay(sm, 0.5, 4, [(1.0, 0.5)], "sitting")
    (lab,) = sm.labels.values()
    assert lab.grid == (4, 2) and lab.updates == 5
    assert (lab.x, lab.y) == (1.0, 0.5)  # the median of its windows
    np.testing.assert_array_equal(lab.counts, np.bincount(
        [sm.models.activities.index("sitting")] * 5, minlength=len(sm.models.activities)))


def test_windows_located_far_off_in_a_stay_are_outvoted():
    """A lying person located 2-3 m off for a few windows (another detection, a pose
    error): the stay's median stays put, no label of their own."""
    sm = make(APARTMENT, window_s=0.5, min_observations=5)
    jumpy_stay(sm, 0.0, 12, [(-0.55, 0.5)], "lying")       # beside the west wall
    jumpy_stay(sm, 6.0, 6, [(1.8, 1.5)], "lying")          # 2.6 m off, 6 windows
    jumpy_stay(sm, 9.0, 4, [(-0.55, 0.5)], "lying")
    (lab,) = sm.labels.values()
    assert (lab.x, lab.y) == (-0.55, 0.5) and lab.updates == 22
    assert lab.label == "bench" and lab.location_type == 2


def test_episodes_end_at_walking_or_a_gap():
    sm = make(window_s=0.5, associate_m=0.25, episode_gap_s=10.0)
    jumpy_stay(sm, 0.0, 2, [(0.5, 0.5)], "sitting")
    first = sm.episode
    sm.observe(1.2, "unknown")                          # unknown: the stay goes on
    with pytest.raises(LocationError, match="no location"):
        sm.observe(5.0, "lying")                        # not fused; the stay goes on
    assert sm.episode is first
    jumpy_stay(sm, 30.0, 1, [(0.9, 0.5)], "sitting")    # after 29 s: a new stay
    assert sm.episode is not first and len(sm.labels) == 2
    second = sm.episode
    sm.observe(30.8, "walking")
    jumpy_stay(sm, 31.0, 1, [(2.2, 0.5)], "sitting")    # after a walk: a new stay
    assert sm.episode is not second and len(sm.labels) == 3
    sm.observe(31.5, "stand_to_sit")
    assert sm.episode is None


def test_a_walk_the_recognizer_missed_ends_the_stay():
    """Sitting at A, a walk to B 2.6 m away reported "unknown" (not walking), standing
    at B within episode_gap_s: two stays, B's windows fused at B, not at A's median (the
    run of issue 16: a person reading at the shelf labelled at the chair)."""
    sm = make(APARTMENT, window_s=0.5, associate_m=0.25, leave_distance_m=1.0)
    jumpy_stay(sm, 0.0, 20, [(0.2, 0.5)], "sitting")
    t = 10.0
    for k in range(12):                           # 0.4 m/s towards B: located, unknown
        stay(sm, t, t + 0.5, 0.2 + 0.2 * (k + 1), 0.5)
        t += 0.5
        sm.observe(t, "unknown")
    assert sm.episode is None
    labs = jumpy_stay(sm, t, 12, [(2.8, 0.5)], "standing")
    assert len(sm.labels) == 2
    a = sm.labels[sm.cell(0.2, 0.5)]
    assert a.updates == 20 and labs[-1] is not a and labs[-1].updates == 12
    assert (labs[-1].x, labs[-1].y) == (2.8, 0.5)


def test_another_activity_elsewhere_is_a_new_stay():
    """The walk unseen (no location, no activity of its own between): a window of an
    activity the stay has not had, located beyond leave_distance_m, starts a new stay;
    the same activity there is a location error, outvoted (test above)."""
    sm = make(APARTMENT, window_s=0.5, associate_m=0.25, leave_distance_m=1.0)
    jumpy_stay(sm, 0.0, 20, [(0.2, 0.5)], "sitting")
    first = sm.episode
    sm.observe(12.0, "unknown")                   # not located: the stay goes on
    assert sm.episode is first
    labs = jumpy_stay(sm, 14.0, 12, [(2.8, 0.5)], "standing")
    assert sm.episode is not first and len(sm.labels) == 2
    assert labs[-1].updates == 12 and (labs[-1].x, labs[-1].y) == (2.8, 0.5)
    stay(sm, 20.0, 20.5, 2.9, 0.5)
    out = sm.observe(20.5, "standing")            # the window's location and its label's
    assert (out.x, out.y) == (2.9, 0.5) and out.label is labs[-1] and out.label.x == 2.8
    # standing 0.5 m from the stay (not away): the same stay
    near = make(APARTMENT, window_s=0.5, associate_m=0.25, leave_distance_m=1.0)
    jumpy_stay(near, 0.0, 20, [(0.2, 0.5)], "sitting")
    first = near.episode
    jumpy_stay(near, 14.0, 4, [(0.7, 0.5)], "standing")
    assert near.episode is first and len(near.labels) == 1


def test_skipped_activities_update_nothing():
    sm = make()
    stay(sm, 0.0, 3.0, 0.5, 0.5)
    for activity in ("unknown", "walking", "sit_to_stand"):
        out = sm.observe(3.0, activity)
        assert out.label is None and out.skipped
    # the person walked 1.5 m during the window
    for i, t in enumerate(np.arange(3.0, 6.0, 0.1)):
        sm.track(float(t), 0.5 * i / 10.0, 0.5)
    out = sm.observe(6.0, "sitting")
    assert out.label is None and "moved" in out.skipped
    assert sm.labels == {}


def test_refused_inputs_raise_location_error():
    models = load_models(DEFAULT_MODELS)
    sm = SemanticMap(models, SemanticMapperParams())
    stay(sm, 0.0, 3.0, 0.5, 0.5)
    with pytest.raises(LocationError, match="no occupancy map"):
        sm.observe(3.0, "sitting")
    sm.set_map(*room())
    with pytest.raises(LocationError, match="no location"):
        sm.observe(30.0, "sitting")
    stay(sm, 30.0, 33.0, 7.0, 0.5)   # east of the map (x up to 3 m)
    with pytest.raises(LocationError, match="outside the map"):
        sm.observe(33.0, "sitting")
    with pytest.raises(LocationError, match="non-finite"):
        sm.track(34.0, float("nan"), 0.0)
    assert sm.labels == {}


def test_returned_after_leaving_and_coming_back():
    sm = make(leave_distance_m=1.0)
    stay(sm, 0.0, 3.0, 0.1, 0.1)
    first = sm.observe(3.0, "sitting").label
    stay(sm, 3.0, 6.0, 0.3, 0.1)         # nearby (0.2 m): not left
    sm.observe(6.0, "sitting")
    assert not first.returned and first.text == first.label
    sm.observe(6.0, "walking")
    stay(sm, 6.0, 9.0, 2.0, 1.5)         # 2.4 m away: left
    sm.observe(9.0, "lying")
    assert not first.returned
    sm.observe(9.0, "walking")
    stay(sm, 9.0, 12.0, 0.1, 0.1)
    back = sm.observe(12.0, "sitting").label
    assert back is first and back.returned
    assert back.text == back.label + "->returned"
    assert [lab.returned for lab in sm.labels.values()].count(True) == 1


def test_room_belief_and_activity_prior_follow_the_labels():
    sm = make(APARTMENT)
    uniform = sm.room_belief()
    np.testing.assert_allclose(uniform, 1.0 / 3.0)
    stay(sm, 0.0, 3.0, -0.55, 0.5)   # beside the west wall
    assert sm.observe(3.0, "lying").label.label == "bench"
    rooms = sm.room_belief()
    assert np.argmax(rooms) == sm.models.rooms.index("bedroom")
    prior = sm.activity_prior()
    np.testing.assert_allclose(prior, sm.models.room_activity @ rooms)
    assert prior.sum() == pytest.approx(1.0)


def test_labels_are_published_with_the_minimum_evidence(tmp_path):
    sm = make(APARTMENT, min_observations=3, min_belief=0.5)
    for k in range(3):
        stay(sm, 3.0 * k, 3.0 * k + 3.0, -0.55, 0.5)   # beside the west wall
        lab = sm.observe(3.0 * k + 3.0, "lying").label
        assert lab.label == "bench" and lab.updates == k + 1
        if k < 2:  # fused, but not yet published: no label, no room rule
            assert sm.published_labels() == []
            np.testing.assert_allclose(sm.room_belief(), 1.0 / 3.0)
            doc = sm.labels_doc()
            assert doc["labels"] == [] and len(doc["candidates"]) == 1
    assert sm.published_labels() == [lab]
    assert np.argmax(sm.room_belief()) == sm.models.rooms.index("bedroom")
    doc = yaml.safe_load(open(sm.save(str(tmp_path), "sm")["labels"]))
    assert [d["label"] for d in doc["labels"]] == ["bench"] and doc["candidates"] == []
    assert doc["min_observations"] == 3
    # the belief rule: one sitting in the open (CL 1) is dining table or chair, neither
    # more likely than the others together (Tables 5.1-5.3)
    sure = make(min_observations=1, min_belief=0.5)
    stay(sure, 0.0, 3.0, 1.0, 0.5)
    lab = sure.observe(3.0, "sitting").label
    assert lab.location_type == 1 and lab.belief.max() < 0.5
    assert sure.published_labels() == []
    assert make(min_observations=1, min_belief=0.0).is_published(lab)


def test_apartment_models_label_bench_chair_shelf():
    """The apartment's tables: lying, sitting and standing at a wall pick bench, chair
    and shelf."""
    sm = make(APARTMENT)
    for i, (activity, expected) in enumerate((("lying", "bench"), ("sitting", "chair"),
                                              ("standing", "shelf"))):
        x = -0.55
        y = -0.5 + 1.0 * i
        sm.observe(10.0 * i, "walking")
        stay(sm, 10.0 * i, 10.0 * i + 3.0, x, y)
        assert sm.observe(10.0 * i + 3.0, activity).label.label == expected


def test_save_writes_map_labels_and_png(tmp_path):
    sm = make(min_observations=1, min_belief=0.0)
    stay(sm, 0.0, 3.0, 0.5, 0.5)
    sm.observe(3.0, "sitting")
    paths = sm.save(str(tmp_path / "out"), "sm")
    grid, info = load_map(paths["yaml"])
    np.testing.assert_array_equal(grid == OCCUPIED, sm.grid == OCCUPIED)
    assert info.resolution == RES and (info.origin_x, info.origin_y) == (-1.0, -1.0)
    doc = yaml.safe_load(open(paths["labels"]))
    (lab,) = doc["labels"]
    assert lab["label"] == sm.models.furniture[int(np.argmax(lab["belief"]))]
    assert lab["position_m"] == [0.5, 0.5] and lab["returned"] is False
    img = cv2.imread(paths["png"])
    assert img.shape[:2] == (sm.grid.shape[0] * 4, sm.grid.shape[1] * 4)
    assert ((img[..., 0] != img[..., 1]) | (img[..., 1] != img[..., 2])).any()  # a label


def test_save_without_a_map_is_refused(tmp_path):
    sm = SemanticMap(load_models(DEFAULT_MODELS), SemanticMapperParams())
    with pytest.raises(LocationError):
        sm.save(str(tmp_path), "x")


def rect(x, y, w, h):
    return np.array([[x - w / 2, y - h / 2], [x + w / 2, y - h / 2], [x + w / 2, y + h / 2],
                     [x - w / 2, y + h / 2]])


def test_footprint_distance():
    item = rect(0.0, 0.0, 1.0, 2.0)  # 1 m along x, 2 m along y
    assert footprint_distance(0.0, 0.9, item) == 0.0
    assert footprint_distance(0.8, 0.0, item) == pytest.approx(0.3)
    assert footprint_distance(0.8, 1.4, item) == pytest.approx(0.5)


def test_score_items():
    labels = [{"position_m": [1.0, 1.0], "label": "chair"},
              {"position_m": [3.0, 1.0], "label": "bench"},
              {"position_m": [5.0, 1.2], "label": "chair"}]
    items = [("c1", "chair", rect(1.5, 1.0, 0.6, 0.6)), ("b", "bench", rect(3.0, 1.8, 1.0, 0.4)),
             ("s", "shelf", rect(5.0, 1.0, 0.2, 0.2)), ("far", "chair", rect(9.0, 9.0, 1, 1))]
    s = {i.name: i for i in score_items(items, labels, 0.5)}
    assert s["c1"].correct and s["c1"].distance_m == pytest.approx(0.2)
    assert not s["b"].correct and s["b"].found == ""         # 0.6 m away
    assert not s["s"].correct and s["s"].found == "chair"    # wrong label
    assert not s["far"].correct


def test_world_items_in_the_map_frame():
    class Obj:
        def __init__(self, name, kind, footprint, type_="furniture"):
            self.name, self.kind, self.footprint, self.type = name, kind, footprint, type_

    class World:
        objects = [Obj("c", "chair", rect(6.0, 4.0, 0.5, 0.5)),
                   Obj("d", "desk", rect(1.0, 1.0, 1.0, 1.0)),
                   Obj("p", "chair", rect(0.0, 0.0, 0.1, 0.1), "poster")]

    # the map's origin at (5, 3) in the world, its x axis along the world's +y
    (item,) = world_items(World(), ["chair", "bench"], (5.0, 3.0, math.pi / 2))
    assert item[:2] == ("c", "chair")
    np.testing.assert_allclose(item[2].mean(axis=0), (1.0, -1.0), atol=1e-12)


def test_recognizer_prior_over_classes():
    rec = Recognizer(RecognizerConfig())
    k = len(rec.config.classes)
    rec.class_prior = np.arange(1, k + 1, dtype=float) / (k * (k + 1) / 2)
    names = ["lying", "sitting"]
    out = rec.prior_over_classes(names, [3.0, 1.0])
    cls = list(rec.config.classes)
    i, j = cls.index("lying"), cls.index("sitting")
    mass = rec.class_prior[i] + rec.class_prior[j]
    assert out[i] == pytest.approx(0.75 * mass) and out[j] == pytest.approx(0.25 * mass)
    others = [n for n in range(k) if n not in (i, j)]
    np.testing.assert_allclose(out[others], rec.class_prior[others])
    assert out.sum() == pytest.approx(1.0)
    for bad_names, bad_probs in ((["flying"], [1.0]), (["lying"], [1.0, 2.0]),
                                 (["lying"], [float("nan")]), (["lying"], [0.0])):
        with pytest.raises(ValueError):
            rec.prior_over_classes(bad_names, bad_probs)
