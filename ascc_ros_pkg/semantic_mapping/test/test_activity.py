"""Activity recognition: window features against their definition, window labels, a
recognizer trained on a few emulated persons and tested on another, unknown activities,
the activity prior, the confusion and P(O|A) layouts, the training command."""
import re

import numpy as np
import pytest

from semantic_mapping import training
from semantic_mapping.activity import (
    ACTIVITIES,
    UNKNOWN,
    OnlineRecognizer,
    Recognizer,
    RecognizerConfig,
    confusion,
    feature_names,
    fit_regions,
    in_region,
    observation_model,
    pure_fit_mask,
    window_features,
    window_labels,
)
from semantic_mapping.body_signals import Person, render


def test_features_are_means_and_variances_of_each_window():
    rng = np.random.default_rng(0)
    waist, thigh = rng.normal(size=(200, 3)), rng.normal(5.0, 2.0, size=(200, 3))
    cfg = RecognizerConfig(window_s=2.0, hop_s=0.5, rate_hz=20.0, features="extended",
                           variance="linear")
    feats, ends = window_features(waist, thigh, cfg)
    assert ends.tolist() == list(range(40, 201, 10)) and feats.shape == (17, 18)
    for i, e in enumerate(ends):
        row = []
        for a in (waist, thigh):
            win = a[e - 40:e]
            row += [win.mean(0), win.var(0), np.diff(win, axis=0).var(0)]
        assert feats[i] == pytest.approx(np.concatenate(row), abs=1e-9)
    thesis, _ = window_features(waist, thigh, RecognizerConfig(window_s=2.0, hop_s=0.5,
                                                               variance="linear"))
    assert thesis.shape == (17, 12) and thesis == pytest.approx(feats[:, [0, 1, 2, 3, 4, 5,
                                                                         9, 10, 11, 12, 13,
                                                                         14]])
    # the default: the same means, every variance as log10(variance + floor)
    logs, _ = window_features(waist, thigh, RecognizerConfig(window_s=2.0, hop_s=0.5,
                                                             features="extended"))
    means = np.zeros(18, bool)
    means[[0, 1, 2, 9, 10, 11]] = True
    assert logs[:, means] == pytest.approx(feats[:, means], abs=1e-12)
    assert logs[:, ~means] == pytest.approx(np.log10(feats[:, ~means] + 0.01), abs=1e-9)
    held, _ = window_features(np.ones((60, 3)), np.ones((60, 3)),  # a sleeping sensor
                              RecognizerConfig(window_s=2.0, hop_s=0.5, features="extended"))
    assert held[:, ~means] == pytest.approx(-2.0)


def test_feature_names_name_the_columns():
    rng = np.random.default_rng(3)
    waist, thigh = rng.normal(0, 1, (100, 3)), rng.normal(0, 2, (100, 3))
    thigh[:, 2] *= 3.0
    for features in ("thesis", "extended"):
        cfg = RecognizerConfig(window_s=2.0, hop_s=0.5, features=features)
        f, ends = window_features(waist, thigh, cfg)
        names = feature_names(cfg)
        assert len(names) == f.shape[1] == len(set(names))
        w = thigh[ends[-1] - 40:ends[-1], 2]
        assert f[-1, names.index("thigh_var_z")] == pytest.approx(np.log10(w.var() + 0.01))
        assert f[-1, names.index("waist_mean_y")] == pytest.approx(
            waist[ends[-1] - 40:ends[-1], 1].mean())


def test_a_model_saved_before_log_variances_keeps_linear_ones():
    import pickle
    old = RecognizerConfig(window_s=3.0, variance="linear")
    state = dict(old.__dict__)
    del state["variance"], state["variance_floor"]
    loaded = RecognizerConfig.__new__(RecognizerConfig)
    loaded.__setstate__(state)
    assert loaded.variance == "linear" and loaded.window_s == 3.0
    assert pickle.loads(pickle.dumps(RecognizerConfig())).variance == "log"


def test_window_labels_centre_and_purity():
    labels = ["sitting"] * 50 + ["walking"] * 50
    cfg = RecognizerConfig(window_s=1.0, hop_s=0.5)  # 20 samples every 10
    centre, pure = window_labels(labels, np.arange(20, 101, 10), cfg)
    # windows [0, 20), [10, 30) ... [80, 100); the label changes at sample 50
    assert list(centre) == ["sitting"] * 5 + ["walking"] * 4
    assert pure.tolist() == [True, True, True, True, False, True, True, True, True]


@pytest.fixture(scope="module")
def trained():
    cfg = RecognizerConfig(window_s=3.0, features="extended", kind="nn_hmm", hidden=(32,))
    return training.train([0, 1, 2, 3], cfg), cfg


def test_a_held_out_person_is_recognized(trained):
    rec, cfg = trained
    true, pred = training.evaluate(rec, [training.record(100, cfg)], "nn_hmm")
    acc = dict(training.accuracies(true, pred, ACTIVITIES))
    assert {"lying", "sitting", "walking"} <= set(acc)
    assert acc["lying"] > 0.9 and acc["walking"] > 0.9 and acc["sitting"] > 0.8


def test_unknown_activities_are_not_forced_into_a_class(trained):
    rec, cfg = trained
    p = Person.from_seed(101)
    for activity in ("bending", "scratching"):
        data = render([(activity, 20.0)], p)
        feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
        labels, _ = rec.recognize(feats)
        assert np.mean([lab == UNKNOWN for lab in labels]) > 0.9, activity
    data = render([("walking", 20.0)], p)
    feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
    assert rec.known(feats).mean() > 0.95


def _training_windows(cfg, pure=False, seeds=(0, 1, 2, 3)):
    """Features and class indices of training persons ``seeds`` (the ranges' and
    regions' fit) and (``pure``) whether each window lies wholly inside one activity."""
    x, y, p = [], [], []
    for seed in seeds:
        f, lab, whole = training.record(seed, cfg)
        x.append(f)
        y.append([cfg.classes.index(a) for a in lab])
        p.append(whole)
    out = np.vstack(x), np.concatenate(y)
    return out + (np.concatenate(p),) if pure else out


def _refit(rec, cfg, x, y, pure=None, **changes):
    """A copy of ``rec`` with ``changes`` to its config and its ranges/regions fitted."""
    import copy
    import dataclasses
    out = copy.copy(rec)
    out.config = dataclasses.replace(cfg, **changes)
    return out.fit_ranges(x, y, pure)


def _more_unknown(rec, other, cfg):
    """activity -> per held-out person (100-102), the share of its windows ``other``
    reports unknown beyond what ``rec`` does (30 s of the activity)."""
    lost = {}
    for seed in (100, 101, 102):
        p = Person.from_seed(seed)
        for activity in ("carrying", "walking", "standing", "opening_door"):
            data = render([(activity, 30.0)], p)
            feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
            before, after = 1.0 - rec.known(feats).mean(), 1.0 - other.known(feats).mean()
            lost.setdefault(activity, []).append(after - before)
    return lost


def test_the_gait_range_reports_a_smaller_gait_unknown(trained):
    """The range feature (the thigh's swing, cv_gait.py's choice) on the fixture's
    recognizer: carrying (0.6 of the gait) is unknown in more windows than by the
    distance alone, and walking, standing and opening a door stay known."""
    rec, cfg = trained
    x, y = _training_windows(cfg)
    ranged = _refit(rec, cfg, x, y, range_features=("thigh_var_z",), range_quantile=0.005)
    lost = _more_unknown(rec, ranged, cfg)
    assert np.mean(lost["carrying"]) > 0.2
    for activity in ("walking", "standing", "opening_door"):
        assert max(lost[activity]) < 0.05, activity
    with pytest.raises(ValueError, match="range_features"):
        _refit(rec, cfg, x, y, range_features=("thigh_swing",))


def _assert_walk_then_carrying_online_as_batch(rec, cfg, seed):
    """Person ``seed`` walks, then carries: the online recognizer (the node's path) gives
    the batch's labels, which hold walking and unknown."""
    data = render([("walking", 8.0), ("carrying", 12.0)], Person.from_seed(seed))
    feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
    labels, _ = rec.recognize(feats)
    online = OnlineRecognizer(rec)
    got = [r[0] for r in (online.push(w, t) for w, t in zip(data["waist_accel"],
                                                          data["thigh_accel"])) if r]
    assert got == labels and UNKNOWN in labels and "walking" in labels


def test_the_gait_region_reports_carrying_unknown_and_the_node_path_gets_it(trained):
    """The region (the thigh's swing and the waist's lean as an ellipse per class,
    cv_gait.py --pairs' choice) on the fixture's recognizer: carrying (0.6 of the gait,
    the trunk leant back) is unknown in more windows than by the distance alone, walking,
    standing and opening a door stay known, and the online recognizer (the node's path)
    gives the same labels as the batch."""
    rec, cfg = trained
    x, y = _training_windows(cfg)
    region = _refit(rec, cfg, x, y, region_features=("thigh_dvar_z", "waist_mean_z"),
                    region_quantile=0.0025)
    assert len(region.regions) == len(cfg.classes) and not region.range_index
    lost = _more_unknown(rec, region, cfg)
    assert np.mean(lost["carrying"]) > 0.2
    for activity in ("walking", "standing", "opening_door"):
        assert max(lost[activity]) < 0.05, activity
    _assert_walk_then_carrying_online_as_batch(region, cfg, 101)
    with pytest.raises(ValueError, match="region_features"):
        _refit(rec, cfg, x, y, region_features=("thigh_swing",))


def test_region_margin_scales_the_threshold_and_pure_fit_drops_straddling_windows():
    """`fit_regions`' threshold is the margin times the quantile of the class's own
    distances; with region_fit "pure" a class's region is fitted on its windows wholly
    inside one activity (a class without any: on all of its own), so windows that
    straddle into another activity no longer widen it."""
    rng = np.random.default_rng(5)
    x = np.vstack([rng.normal(0.0, 1.0, (400, 2)), rng.normal(10.0, 1.0, (400, 2)),
                   rng.normal(5.0, 0.5, (20, 2)),    # class 0's straddling windows
                   rng.normal(-5.0, 1.0, (30, 2))])  # class 2: a transition, never pure
    y = np.repeat([0, 1, 0, 2], [400, 400, 20, 30])
    pure = np.repeat([True, True, False, False], [400, 400, 20, 30])
    one = fit_regions(x, y, 3, 0.01)
    two = fit_regions(x, y, 3, 0.01, margin=2.0)
    for a in range(3):
        assert two[a][2] == pytest.approx(2.0 * one[a][2])
        assert np.allclose(two[a][0], one[a][0]) and np.allclose(two[a][1], one[a][1])
    keep = pure_fit_mask(y, pure)
    assert keep[:820].sum() == 800 and keep[820:].all()  # class 2 keeps all of its own
    probe = np.array([[4.0, 4.0], [0.5, -0.5]])
    taken = np.array([0, 0])
    assert in_region(probe, one, taken).tolist() == [True, True]
    fitted = fit_regions(x[keep], y[keep], 3, 0.01)
    assert in_region(probe, fitted, taken).tolist() == [False, True]


def test_the_pure_fitted_region_with_a_margin_and_the_node_path():
    """The region of train_activity's defaults (swing, lean and fore-aft bounce, fitted
    on whole-activity windows, margin 2; cv_gait.py --triples' choice) on a recognizer
    trained on the twelve training persons as train_activity trains it (the fixture's,
    from four persons, takes person 102's walking for standing, and standing's region
    then rightly rejects it): carrying is unknown in more windows than with the region
    fitted on all windows, walking, standing and opening a door stay known, the online
    recognizer gives the batch's labels, and "pure" without the mask is an error."""
    cfg = RecognizerConfig(window_s=3.0, features="extended", kind="nn_hmm")
    rec = training.train(list(range(12)), cfg)
    x, y, p = _training_windows(cfg, pure=True, seeds=range(12))
    feats3 = ("thigh_dvar_z", "waist_mean_z", "waist_var_z")
    every = _refit(rec, cfg, x, y, region_features=feats3, region_quantile=0.0005)
    whole = _refit(rec, cfg, x, y, p, region_features=feats3, region_quantile=0.0005,
                   region_fit="pure", region_margin=2.0)
    lost_every, lost_whole = _more_unknown(rec, every, cfg), _more_unknown(rec, whole, cfg)
    assert np.mean(lost_whole["carrying"]) > np.mean(lost_every["carrying"]) + 0.1
    for activity in ("walking", "standing", "opening_door"):
        assert max(lost_whole[activity]) < 0.05, activity
    _assert_walk_then_carrying_online_as_batch(whole, cfg, 102)
    with pytest.raises(ValueError, match="pure"):
        _refit(rec, cfg, x, y, region_features=feats3, region_fit="pure")
    with pytest.raises(ValueError, match="region_fit"):
        _refit(rec, cfg, x, y, p, region_features=feats3, region_fit="some")
    with pytest.raises(ValueError, match="region_margin"):
        _refit(rec, cfg, x, y, p, region_features=feats3, region_margin=0.0)


def test_a_model_saved_before_the_region_loads_without_one(trained):
    """A recognizer pickled before region_features existed (no config fields, no
    region_index) loads and recognizes as before."""
    import pickle
    rec, cfg = trained
    old = pickle.loads(pickle.dumps(rec))
    for key in ("region_features", "region_quantile", "region_fit", "region_margin"):
        del old.config.__dict__[key]
    del old.region_index, old.regions
    loaded = pickle.loads(pickle.dumps(old))
    assert loaded.config.region_features == () and loaded.config.region_quantile == 0.005
    assert loaded.config.region_fit == "all" and loaded.config.region_margin == 1.0
    data = render([("walking", 10.0), ("bending", 10.0)], Person.from_seed(102))
    feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
    assert np.array_equal(loaded.known(feats), rec.known(feats))


def test_online_recognition_equals_the_batch(trained):
    rec, cfg = trained
    data = render([("walking", 8.0), ("sitting", 12.0), ("bending", 6.0)],
                  Person.from_seed(103))
    feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
    labels, probs = rec.recognize(feats)
    online = OnlineRecognizer(rec)
    got = [r for r in (online.push(w, t) for w, t in zip(data["waist_accel"],
                                                      data["thigh_accel"])) if r]
    assert [g[0] for g in got] == labels
    assert [g[1] for g in got] == pytest.approx(probs)
    assert UNKNOWN in labels and "walking" in labels


def test_the_room_prior_shifts_the_posterior(trained):
    rec, cfg = trained
    data = render([("sitting", 10.0)], Person.from_seed(102))
    feats, _ = window_features(data["waist_accel"], data["thigh_accel"], cfg)
    flat = rec.posteriors(feats, kind="nn")
    prior = rec.class_prior.copy()
    prior[ACTIVITIES.index("typing")] *= 50.0
    prior /= prior.sum()
    shifted = rec.posteriors(feats, prior=prior, kind="nn")
    t = ACTIVITIES.index("typing")
    assert np.all(shifted[:, t] >= flat[:, t]) and np.allclose(shifted.sum(1), 1.0)
    same = rec.posteriors(feats, prior=rec.class_prior, kind="nn")
    assert same == pytest.approx(flat)


def test_confusion_and_table_5_1_layout():
    classes = ("a", "b", "c")
    counts, cols = confusion(["a", "a", "b", "b", "c", "x"], ["a", "b", "b", UNKNOWN, "c",
                                                              UNKNOWN], classes)
    assert cols == ["a", "b", "c", "x"]
    assert counts.tolist() == [[1, 0, 0, 0], [1, 1, 0, 0], [0, 0, 1, 0], [0, 1, 0, 1]]
    om = observation_model(counts, 2)
    assert om["table"].tolist() == [[0.5, 0.0], [0.5, 0.5], [0.0, 0.5]]  # rows a, b, other
    assert om["windows"].tolist() == [2, 2]


def test_train_activity_command(capsys, tmp_path):
    out = tmp_path / "rec.joblib"
    table = tmp_path / "table.yaml"
    code = training.main(["--train-seeds", "0-2", "--test-seeds", "100", "--windows", "3",
                          "--features", "extended", "--kind", "nn", "--out", str(out),
                          "--table", str(table)])
    lines = capsys.readouterr().out.splitlines()
    assert code == 0 and out.is_file() and table.is_file()
    assert re.match(r"^accuracy: lying=\d\.\d{3} typing=\d\.\d{3} eating=\d\.\d{3} "
                    r"sitting=\d\.\d{3} opening_door=\d\.\d{3}$", lines[-1])
    import joblib
    import yaml
    rec = joblib.load(out)
    assert isinstance(rec, Recognizer) and rec.config.kind == "nn"
    doc = yaml.safe_load(table.read_text())
    assert np.allclose(np.sum(doc["observation_model"], axis=0), 1.0, atol=1e-3)
    assert doc["rows"][-1] == "other"
    assert any(re.match(r"^windows straddling two activities .* unknown: \d\.\d{3} of "
                        r"\d+$", line) for line in lines)
    with pytest.raises(SystemExit):
        training.main(["--train-seeds", "0-2", "--test-seeds", "2"])
