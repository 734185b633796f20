"""Activity recognition from the waist and thigh accelerometers (thesis 5.4.2). Pure Python
(numpy, scikit-learn, hmmlearn); no ROS.

Features (as in 5.4.2): per window of ``window_s`` every ``hop_s``, the mean and the
variance of each axis of the 3D acceleration of each sensor (12 numbers), standardised;
``features="extended"`` adds the variance of the sample differences (18 numbers). The
variances enter as log10(variance + ``variance_floor``) (``variance="log"``, the default;
"linear": as they are): a bend's variance against a tremor's is a factor 20, which the
linear scale, spanning walking's variances too, squeezed into a few hundredths of a
standard deviation.
Three recognizers, all trained on labelled windows of several persons:

    nn       a neural network (scikit-learn MLPClassifier): P(A | x_t)
    hmm      the features clustered into discrete symbols (k-means, 5.4.2) and a discrete
             HMM over them (hmmlearn CategoricalHMM; start, transition and emission
             probabilities counted from the labelled sequences, add-one smoothed): the
             filtered P(A_t | s_1..t)
    nn_hmm   the combination: the HMM's transition model as the prior of each window and
             the network's posterior over the training prior as the likelihood (the
             hybrid NN/HMM): P(A_t | x_1..t) by the forward recursion

Unknown activity: a window whose features are far from every class (the Mahalanobis
distance to each class's mean under its covariance, plus ``unknown_ridge`` on the
diagonal, above that class's ``unknown_quantile`` of its own training windows' distances)
is ``unknown``, whatever a classifier says; an unknown window does not move the HMM's
belief (its likelihood is flat). A shrunk covariance (Ledoit-Wolf) was tried first: its
shrinkage towards the mean variance let a class with one large variance feature (eating's
bends) swallow postures far from it on the others (bending, 0 % unknown).

Gait amplitude (``range_features``): the distance above does not tell carrying from
walking (the emulator's carrying is a walk with 0.6 of the thigh's swing and bounce;
persons' gaits differ along the same direction of walking's covariance, and the ridge
widens it further). With ``range_features`` a window is known only if it also lies, on
those features, within [``range_quantile``, 1 - ``range_quantile``] of the training
windows of the class the network takes it for (a window taken for walking must swing its
thigh as much as some training person walked). With ``region_features`` the same holds
for a region instead of a box: the class's Mahalanobis distance on just those features
(its own covariance; a 1e-6 relative ridge only to invert it) within the
1 - ``region_quantile`` quantile of its windows' distances, times ``region_margin``.
``region_fit`` "pure" fits each class's region on its windows wholly inside one activity
only: the windows that straddle a walk and a door (labelled by their centre) hold a gait,
and fitted on them the door's and standing's regions held carrying's gait too.
`scripts/cv_gait.py --triples --fit both --margins ...` chose, over the training persons,
the thigh's swing, the waist's lean and its fore-aft bounce (``thigh_dvar_z``,
``waist_mean_z``, ``waist_var_z``: carrying is a smaller gait *and* the trunk leant back),
q 0.0005, "pure" and margin 2 (the whole-activity windows of a few persons span less
than a new person's lean and gait); `train_activity` trains with them by default (and
no range features). A model saved before ``region_fit`` loads as "all", margin 1.

Sensors asleep (the power scheme of 5.4.1) send nothing: the node holds a sleeping
sensor's last sample, and the training recordings are made the same way (`training`).

The activity prior fed back from the room belief (`fusion.activity_prior`) enters as
P(A | x, R) ∝ P(A | x) P_t(A) / P_train(A) (`Recognizer.posteriors(..., prior=)`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ascc_common.params import param

ACTIVITIES = ("lying", "typing", "eating", "sitting", "opening_door",    # 5.5
              "sit_to_stand", "stand_to_sit", "standing", "walking")    # fig. 5.15
UNKNOWN = "unknown"
KINDS = ("nn", "hmm", "nn_hmm")


@dataclass
class RecognizerNodeParams:
    """The activity_recognizer node's private parameters."""

    model_path: str = param("", "the recognizer saved by train_activity --out (required)")
    model_wait_s: float = param(0.0, "[s] wait this long for the model file to appear "
                                "(0: it must exist at start)", ge=0.0)
    waist_sensor: str = param("waist", "name of the waist sensor: wearable/<name>/imu")
    thigh_sensor: str = param("thigh", "name of the thigh sensor: wearable/<name>/imu")
    silent_after_s: float = param(0.25, "[s] a sensor that has sent nothing for this long "
                                  "is asleep: its last sample is held (until then the "
                                  "other's samples wait for its own)", gt=0.0)
    max_backlog_s: float = param(2.0, "[s] of samples kept per sensor when the recognizer "
                                 "falls behind (the oldest beyond are dropped, with a "
                                 "warning)", gt=0.0)
    warn_period_s: float = param(10.0, "[s] each kind of warning at most once per this",
                                 gt=0.0)

    def validate(self) -> None:
        if not self.model_path:
            raise ValueError("model_path: required (make one with train_activity --out)")


@dataclass
class RecognizerConfig:
    window_s: float = 3.0          # [s] feature window
    hop_s: float = 0.5             # [s] between windows
    rate_hz: float = 20.0          # [Hz] sample rate of the sensors
    kind: str = "nn_hmm"           # nn | hmm | nn_hmm
    features: str = "thesis"       # thesis (mean, variance) | extended (+ difference var.)
    variance: str = "log"          # log: log10(variance + variance_floor) | linear
    variance_floor: float = 0.01   # [m^2/s^4] (0.1 m/s^2)^2, above the sensors' noise
    n_symbols: int = 48            # k-means clusters (HMM observation symbols)
    hidden: Tuple[int, ...] = (64,)  # network's hidden layer sizes
    unknown_quantile: float = 0.995  # of a class's own training distances
    unknown_ridge: float = 0.01    # added to each class covariance (standardised units)
    # features (`feature_names`) a window must also lie within a class's own training
    # range on to be near it: [range_quantile, 1 - range_quantile] of its windows
    range_features: Tuple[str, ...] = ()
    range_quantile: float = 0.001
    # features a window must also lie within a class's own training region on: the
    # Mahalanobis distance (the class's covariance of just these features) within the
    # 1 - region_quantile quantile of its windows' distances (an ellipse, not a box)
    region_features: Tuple[str, ...] = ()
    region_quantile: float = 0.005
    # the regions fitted on all of a class's windows ("all") or ("pure") on those wholly
    # inside one activity (a class without such windows, a transition: all of its own);
    # each class's distance threshold times region_margin (the spread of new persons)
    region_fit: str = "all"
    region_margin: float = 1.0
    seed: int = 0
    classes: Tuple[str, ...] = field(default=ACTIVITIES)

    def __setstate__(self, state: dict) -> None:
        """A model saved before ``variance`` existed used linear variances."""
        state.setdefault("variance", "linear")
        state.setdefault("variance_floor", 0.01)
        state.setdefault("range_features", ())
        state.setdefault("range_quantile", 0.001)
        state.setdefault("region_features", ())
        state.setdefault("region_quantile", 0.005)
        state.setdefault("region_fit", "all")
        state.setdefault("region_margin", 1.0)
        self.__dict__.update(state)

    def samples(self) -> Tuple[int, int]:
        return (max(1, int(round(self.window_s * self.rate_hz))),
                max(1, int(round(self.hop_s * self.rate_hz))))


def _window_moments(a: np.ndarray, ends: np.ndarray, w: int):
    """Mean and variance of each column of ``a`` over the windows [end - w, end)."""
    c1 = np.vstack([np.zeros((1, a.shape[1])), np.cumsum(a, axis=0)])
    c2 = np.vstack([np.zeros((1, a.shape[1])), np.cumsum(a * a, axis=0)])
    mean = (c1[ends] - c1[ends - w]) / w
    return mean, np.maximum((c2[ends] - c2[ends - w]) / w - mean ** 2, 0.0)


def feature_names(config: RecognizerConfig) -> List[str]:
    """The names of `window_features`' columns: <sensor>_<mean|var|dvar>_<axis>."""
    kinds = ("mean", "var", "dvar") if config.features == "extended" else ("mean", "var")
    return ["%s_%s_%s" % (s, k, ax) for s in ("waist", "thigh") for k in kinds
            for ax in "xyz"]


def window_features(waist: np.ndarray, thigh: np.ndarray,
                    config: RecognizerConfig) -> Tuple[np.ndarray, np.ndarray]:
    """(features, end index of each window) for (n_samples, 3) accelerations [m/s^2]
    (cumulative sums, no loop). Per sensor, waist then thigh: the mean and the variance
    of each axis (``features`` "thesis": 12 numbers); "extended" adds the variance of the
    sample-to-sample differences of each axis (18 numbers), which grows with a motion's
    frequency (a tremor, against slow bends of the same variance). ``variance`` "log":
    each variance as log10(variance + ``variance_floor``), so that a ratio counts the same
    whatever the scale (a bend's 0.4 against a tremor's 0.02 m^2/s^4 as much as walking's
    10 against 0.5) and a sleeping sensor's held sample (variance 0) and sensor noise
    come out alike (below the floor)."""
    w, hop = config.samples()
    a = np.hstack([np.asarray(waist, float), np.asarray(thigh, float)])
    ends = np.arange(w, a.shape[0] + 1, hop)
    mean, var = _window_moments(a, ends, w)
    parts = [[mean[:, :3], var[:, :3]], [mean[:, 3:], var[:, 3:]]]
    if config.features == "extended":
        d = np.vstack([np.zeros((1, 6)), np.diff(a, axis=0)])  # d[i] = a[i] - a[i-1]
        _, dvar = _window_moments(d, ends, max(w - 1, 1))  # the w - 1 inside the window
        parts[0].append(dvar[:, :3])
        parts[1].append(dvar[:, 3:])
    if config.variance == "log":
        for p in parts:
            p[1:] = [np.log10(v + config.variance_floor) for v in p[1:]]
    return np.hstack(parts[0] + parts[1]), ends


def window_labels(labels: Sequence[str], ends: np.ndarray,
                  config: RecognizerConfig) -> Tuple[np.ndarray, np.ndarray]:
    """(the label at each window's centre, whether the whole window has that label)."""
    w, _ = config.samples()
    lab = np.asarray(labels, dtype=object)
    centre = lab[ends - w // 2 - 1]
    change = np.concatenate([[0], np.cumsum(lab[1:] != lab[:-1])])
    pure = change[ends - 1] == change[ends - w]
    return centre, pure


def pure_fit_mask(y: np.ndarray, pure: np.ndarray) -> np.ndarray:
    """(n,) bool: the windows a class's region is fitted on with ``region_fit`` "pure":
    those wholly inside one activity (``pure``) and all windows of a class that has no
    such window (a transition, shorter than a window)."""
    pure = np.asarray(pure, dtype=bool)
    return pure | ~np.isin(y, np.unique(y[pure]))


def fit_regions(x: np.ndarray, y: np.ndarray, n_classes: int, quantile: float,
                margin: float = 1.0):
    """Per class a of ``n_classes``: (mean, precision, threshold) of the windows
    ``x[y == a]`` (columns: the region's features): the distance threshold is
    ``margin`` times the 1 - ``quantile`` quantile of the class's own windows'
    Mahalanobis distances. A tiny ridge (1e-6 of the mean variance) keeps a flat class's
    covariance invertible."""
    out = []
    for a in range(n_classes):
        xa = x[y == a]
        mean = xa.mean(axis=0)
        cov = np.atleast_2d(np.cov(xa, rowvar=False))
        cov = cov + 1e-6 * max(float(np.trace(cov)) / cov.shape[0], 1e-12) * np.eye(
            cov.shape[0])
        precision = np.linalg.inv(cov)
        d = mahalanobis(xa, mean, precision)
        out.append((mean, precision, margin * float(np.quantile(d, 1.0 - quantile))))
    return out


def mahalanobis(x: np.ndarray, mean: np.ndarray, precision: np.ndarray) -> np.ndarray:
    """(n,) distances of the rows of ``x`` to ``mean`` under ``precision``."""
    d = x - mean
    return np.sqrt(np.einsum("ni,ij,nj->n", d, precision, d))


def in_region(x: np.ndarray, regions, taken: np.ndarray) -> np.ndarray:
    """(n,) bool: row i of ``x`` within the region (`fit_regions`) of class ``taken[i]``."""
    means = np.stack([r[0] for r in regions])[taken]
    precisions = np.stack([r[1] for r in regions])[taken]
    thresholds = np.array([r[2] for r in regions])[taken]
    d = x - means
    return np.sqrt(np.einsum("ni,nij,nj->n", d, precisions, d)) <= thresholds


def forward_step(belief: Optional[np.ndarray], log_lik: np.ndarray, start: np.ndarray,
                 trans: np.ndarray) -> np.ndarray:
    """One step of the HMM forward recursion: P(A_t | obs_1..t) from P(A_t-1 | obs_1..t-1)
    (None before the first window: the start distribution) and log P(obs_t | A_t)."""
    pred = start if belief is None else belief @ trans
    post = pred * np.exp(log_lik - log_lik.max())
    return post / post.sum()


def _forward(log_lik: np.ndarray, start: np.ndarray, trans: np.ndarray) -> np.ndarray:
    """Filtered posteriors P(A_t | obs_1..t) of an HMM with per-step log-likelihoods."""
    out = np.empty_like(log_lik)
    belief = None
    for t in range(log_lik.shape[0]):  # one step per window (a few per second)
        belief = out[t] = forward_step(belief, log_lik[t], start, trans)
    return out


class Recognizer:
    """Trained on windows of several persons; `posteriors` for a person's sequence."""

    def __init__(self, config: RecognizerConfig):
        if config.kind not in KINDS:
            raise ValueError("recognizer kind %r not in %s" % (config.kind, KINDS))
        self.config = config

    # -- training ---------------------------------------------------------------------
    def fit(self, sequences: List[Tuple[np.ndarray, np.ndarray]],
            pure: Optional[Sequence[np.ndarray]] = None) -> Recognizer:
        """``sequences``: (features (n, 12), label indices (n,)) per recording; ``pure``:
        per recording (n,) whether each window lies wholly inside one activity (needed
        by ``region_fit`` "pure")."""
        from hmmlearn.hmm import CategoricalHMM
        from sklearn.cluster import KMeans
        from sklearn.neural_network import MLPClassifier
        from sklearn.preprocessing import StandardScaler

        c = self.config
        k = len(c.classes)
        x = np.vstack([f for f, _ in sequences])
        y = np.concatenate([lab for _, lab in sequences])
        missing = sorted(set(range(k)) - set(y.tolist()))
        if missing:
            raise ValueError("no training windows of %s" % [c.classes[i] for i in missing])
        self.scaler = StandardScaler().fit(x)
        z = self.scaler.transform(x)
        self.class_prior = np.bincount(y, minlength=k) / float(y.size)
        self.nn = MLPClassifier(hidden_layer_sizes=c.hidden, max_iter=2000,
                                random_state=c.seed, early_stopping=False).fit(z, y)
        self.kmeans = KMeans(n_clusters=c.n_symbols, n_init=4, random_state=c.seed).fit(z)
        start = np.ones(k)
        trans = np.ones((k, k))
        emit = np.ones((k, c.n_symbols))
        for f, lab in sequences:
            s = self.kmeans.predict(self.scaler.transform(f))
            start[lab[0]] += 1
            np.add.at(trans, (lab[:-1], lab[1:]), 1)
            np.add.at(emit, (lab, s), 1)
        self.hmm = CategoricalHMM(n_components=k, init_params="", params="")
        self.hmm.startprob_ = start / start.sum()
        self.hmm.transmat_ = trans / trans.sum(axis=1, keepdims=True)
        self.hmm.emissionprob_ = emit / emit.sum(axis=1, keepdims=True)
        self.hmm.n_features = c.n_symbols
        # unknown detection: per-class Gaussian, distance threshold from its own windows
        self.means, self.precisions, self.thresholds = [], [], []
        for a in range(k):
            za = z[y == a]
            mean = za.mean(axis=0)
            cov = np.cov(za, rowvar=False) + c.unknown_ridge * np.eye(z.shape[1])
            precision = np.linalg.inv(cov)
            d = self._mahalanobis(za, mean, precision)
            self.means.append(mean)
            self.precisions.append(precision)
            self.thresholds.append(float(np.quantile(d, c.unknown_quantile)))
        return self.fit_ranges(x, y, None if pure is None else np.concatenate(
            [np.asarray(p, dtype=bool) for p in pure]))

    def fit_ranges(self, x: np.ndarray, y: np.ndarray,
                   pure: Optional[np.ndarray] = None) -> Recognizer:
        """Each class's [q, 1 - q] range (q = ``range_quantile``) of the
        ``range_features`` over its windows ``x[y == class]`` (features as
        `window_features` gives them), and its region (`fit_regions`) on the
        ``region_features``, from the windows ``region_fit`` names (``pure``: (n,) bool,
        the windows wholly inside one activity; ValueError if "pure" and not given)."""
        c = self.config
        names = feature_names(c)
        unknown = sorted(set(c.range_features) - set(names))
        if unknown:
            raise ValueError("range_features %s: not among %s" % (unknown, names))
        self.range_index = [names.index(n) for n in c.range_features]
        q = c.range_quantile
        self.ranges = [np.quantile(x[y == a][:, self.range_index], [q, 1.0 - q], axis=0)
                       for a in range(len(c.classes))] if self.range_index else []
        region = tuple(getattr(c, "region_features", ()))
        unknown = sorted(set(region) - set(names))
        if unknown:
            raise ValueError("region_features %s: not among %s" % (unknown, names))
        self.region_index = [names.index(n) for n in region]
        fit = getattr(c, "region_fit", "all")
        if fit not in ("all", "pure"):
            raise ValueError("region_fit %r: 'all' or 'pure'" % (fit,))
        margin = getattr(c, "region_margin", 1.0)
        if not margin > 0.0:
            raise ValueError("region_margin %r: must be > 0" % (margin,))
        keep = np.ones(len(y), dtype=bool)
        if fit == "pure" and self.region_index:
            if pure is None or len(pure) != len(y):
                raise ValueError("region_fit 'pure' needs the pure mask of the windows")
            keep = pure_fit_mask(y, pure)
        self.regions = fit_regions(x[keep][:, self.region_index], y[keep], len(c.classes),
                                   c.region_quantile, margin) if self.region_index else []
        return self

    _mahalanobis = staticmethod(mahalanobis)

    # -- recognition ------------------------------------------------------------------
    def near(self, features: np.ndarray) -> np.ndarray:
        """(n, classes) bool: the window's Mahalanobis distance to the class is within
        the class's threshold."""
        z = self.scaler.transform(features)
        return np.stack([self._mahalanobis(z, m, p) <= t for m, p, t in
                         zip(self.means, self.precisions, self.thresholds)], axis=1)

    def known(self, features: np.ndarray) -> np.ndarray:
        """(n,) bool: the window is near at least one class and, on ``range_features``
        and ``region_features``, within the training range and region of the class the
        network takes it for."""
        known = np.any(self.near(features), axis=1)
        index = getattr(self, "range_index", [])  # (a model saved before: none)
        region = getattr(self, "region_index", [])
        if index or region:
            taken = self.nn.predict_proba(self.scaler.transform(features)).argmax(axis=1)
            f = np.asarray(features)
        if index:
            lo, hi = (np.stack([r[i] for r in self.ranges])[taken] for i in (0, 1))
            known &= np.all((f[:, index] >= lo) & (f[:, index] <= hi), axis=1)
        if region:
            known &= in_region(f[:, region], self.regions, taken)
        return known

    def evidence(self, features: np.ndarray, kind: Optional[str] = None):
        """Per window: (P_nn(A | x) for ``nn``, else log P(obs | A) for the HMM forward
        recursion, flat where the window is unknown; and the known mask)."""
        kind = kind or self.config.kind
        z = self.scaler.transform(features)
        known = self.known(features)
        if kind == "hmm":
            log_lik = np.log(self.hmm.emissionprob_[:, self.kmeans.predict(z)].T)
        else:
            p_nn = self.nn.predict_proba(z)
            if kind == "nn":
                return p_nn, known
            log_lik = np.log(np.maximum(p_nn, 1e-9) / self.class_prior)
        log_lik[~known] = 0.0
        return log_lik, known

    def apply_prior(self, post: np.ndarray, prior: Optional[np.ndarray]) -> np.ndarray:
        """P(A | x, R) ∝ P(A | x) P_t(A) / P_train(A) (rows of ``post``)."""
        if prior is None:
            return post
        post = post * (np.asarray(prior) / self.class_prior)
        return post / post.sum(axis=-1, keepdims=True)

    def prior_over_classes(self, names: Sequence[str], probs: Sequence[float]) -> np.ndarray:
        """The fed-back prior (``probs`` over the activities ``names``, e.g. the fusion's
        five of 5.5) over all the recognizer's classes: the named classes share their
        training prior's mass in proportion to ``probs``; the other classes (walking, the
        transitions) keep their training prior, so the prior leaves them alone. ValueError
        on a name the recognizer does not know, a length mismatch or a bad probability."""
        classes = list(self.config.classes)
        probs = np.asarray(probs, dtype=float)
        if len(names) != probs.size:
            raise ValueError("%d activities but %d probabilities" % (len(names), probs.size))
        if not (np.all(np.isfinite(probs)) and np.all(probs >= 0.0) and probs.sum() > 0.0):
            raise ValueError("probabilities must be finite, >= 0 and not all 0: %s"
                             % np.array2string(probs, precision=3))
        idx = []
        for n in names:
            if n not in classes:
                raise ValueError("activity %r is not a class of the recognizer (%s)"
                                 % (n, ", ".join(classes)))
            idx.append(classes.index(n))
        out = self.class_prior.astype(float).copy()
        mass = out[idx].sum()
        out[idx] = mass * probs / probs.sum()
        return out

    def posteriors(self, features: np.ndarray, prior: Optional[np.ndarray] = None,
                   kind: Optional[str] = None) -> np.ndarray:
        """(n, classes) P(A_t | ...) for a sequence of windows of one person (``kind``
        overrides the configured recognizer; ``prior``: an activity prior P_t(A))."""
        kind = kind or self.config.kind
        ev, _ = self.evidence(features, kind)
        post = ev if kind == "nn" else _forward(ev, self.hmm.startprob_, self.hmm.transmat_)
        return self.apply_prior(post, prior)

    def recognize(self, features: np.ndarray, prior: Optional[np.ndarray] = None,
                  kind: Optional[str] = None) -> Tuple[List[str], np.ndarray]:
        """(label per window, its probability); ``unknown`` (probability of the best
        class kept) where the window is near no class."""
        post = self.posteriors(features, prior, kind)
        best = np.argmax(post, axis=1)
        known = self.known(features)
        labels = [self.config.classes[b] if k else UNKNOWN for b, k in zip(best, known)]
        return labels, post[np.arange(len(best)), best]


def confusion(true: Sequence[str], predicted: Sequence[str],
              classes: Sequence[str]) -> Tuple[np.ndarray, List[str]]:
    """Counts [predicted, true] over ``classes`` (+ ``unknown`` as a last predicted row
    and any true label outside ``classes`` as extra columns)."""
    extra = sorted(set(true) - set(classes))
    cols = list(classes) + extra
    rows = list(classes) + [UNKNOWN]
    out = np.zeros((len(rows), len(cols)), dtype=np.int64)
    for t, p in zip(true, predicted):
        out[rows.index(p), cols.index(t)] += 1
    return out, cols


def observation_model(counts: np.ndarray, n: int) -> Dict[str, np.ndarray]:
    """P(O|A) in Table 5.1's layout from a confusion of the first ``n`` classes: rows O
    (the ``n`` classes, then "other" = another class or unknown), columns A."""
    c = counts[:, :n].astype(float)
    table = np.vstack([c[:n], c[n:].sum(axis=0, keepdims=True)])
    total = table.sum(axis=0, keepdims=True)
    return {"table": table / np.maximum(total, 1.0), "windows": total.ravel()}


class OnlineRecognizer:
    """The recognizer fed sample by sample (the node): ``push(waist, thigh)`` at the
    sensors' rate [m/s^2, (3,) each; a sleeping sensor's last sample held]; every
    ``hop_s`` a window is complete and ``push`` returns (label, probability, posterior),
    else None. Same features and filter as `Recognizer.recognize` on a recording."""

    def __init__(self, recognizer: Recognizer):
        self.rec = recognizer
        self.w, self.hop = recognizer.config.samples()
        self.buf = np.zeros((self.w, 6))
        self.n = 0          # samples pushed
        self.belief: Optional[np.ndarray] = None

    def push(self, waist, thigh, prior: Optional[np.ndarray] = None):
        self.buf = np.roll(self.buf, -1, axis=0)
        self.buf[-1, :3], self.buf[-1, 3:] = waist, thigh
        self.n += 1
        if self.n < self.w or (self.n - self.w) % self.hop:
            return None
        feats, _ = window_features(self.buf[:, :3], self.buf[:, 3:], self.rec.config)
        kind = self.rec.config.kind
        ev, known = self.rec.evidence(feats[-1:], kind)
        if kind == "nn":
            post = ev[0]
        else:
            post = self.belief = forward_step(self.belief, ev[0], self.rec.hmm.startprob_,
                                              self.rec.hmm.transmat_)
        post = self.rec.apply_prior(post, prior)
        best = int(np.argmax(post))
        label = self.rec.config.classes[best] if known[0] else UNKNOWN
        return label, float(post[best]), post
