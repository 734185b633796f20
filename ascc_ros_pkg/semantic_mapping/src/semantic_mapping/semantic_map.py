"""The semantic map of thesis 5.2.2 and 5.6: where the person is, what they do there, and
the furniture labels that follow (pure Python, no rospy; the node `semantic_mapper` feeds
it).

    track(t, x, y)          the person's location L_h [m, map frame] at time t [s]
                            (`location.human_location` from the robot pose and the
                            target's bearing and range)
    observe(t, activity)    a recognized activity whose window ends at t: the person's
                            location is the median of the tracked locations over the
                            window; its semantic grid G = g([X, Y]) and location type CL
                            (occupancy map, 20 cm wall threshold) fuse into P_{G,t}(F)
                            (eq. 5.1-5.3)
    labels                  one `Label` per fused grid: MAP furniture, belief, entropy,
                            the "returned" flag of 5.6
    room_belief / activity_prior   P_t(R) of 5.5 and the activity prior it feeds back

Skipped, not fused: "unknown", activities that are not in the models' O (walking, the
transitions), and a window in which the person moved more than ``max_spread_m`` (not at
one place). Refused with `LocationError` (the node reports it): no location in the window,
a location outside the occupancy map, no map yet.

Semantic grid. Cells of ``grid_resolution_m`` anchored at the map frame's origin (the
occupancy map grows while it is built; the semantic cells do not move with it). A
location within ``associate_m`` of a labelled grid's location is fused there (the person
sitting on a cell border would otherwise split one item into two labels). A label's
position is the median of the person's locations fused at its grid (inside its cell; the
cell's centre would add up to 0.7 x ``grid_resolution_m`` of rounding; the median, as a
few windows located metres off do not move it).

Stationary episodes. The person does not move between two activities of the models
unless the recognizer sees them walk or rise (walking: 1.000 of the held-out persons'
windows, and a walk between two items lasts many windows): the fused windows of one such
stretch (an *episode*) are one stay at one place, fused at one grid, that of the
episode's median location (re-associated as the median settles; the episode's
observations move with it). A window located far from the rest of its episode is a
location error (a lying person cannot walk off), and the median outvotes it. The
located windows of a lying person jumped by 0.3-0.9 m (range and bearing of a shirt on a
body 1.7 m long) and split one stay over four grids, none with the minimum evidence; a
detection elsewhere made labels of its own. An episode ends at an activity outside the
models (walking, a transition) or after ``episode_gap_s`` without a fused window;
skipped windows (no location, moved) do not end it. The recognizer does not always see
the walk: in the apartment runs the walk from a chair to the shelf (2.6 m, 7 s) came out
"unknown" in every window, and the shelf's "standing" windows, located at the shelf
within 0.1 m, were fused at the chair's median (the episode's). So the location ends a
stay too, where it says the person is elsewhere (farther than ``leave_distance_m`` from
the episode's median): an "unknown" window located there, or a window of an activity the
episode has not had located there. A window of the episode's own activity located far
off stays a location error, outvoted by the median.

Location type on the newest map. The robot's map grows while the person is at the
furniture, and the person hides what is behind them (the bench's face is mapped only
once they get up). So CL of a grid is C(L_h) on the newest map at the mean of its fused
locations, and its belief is eq. 5.2 over all its observations with that CL:
P_{G,t}(F) ∝ P_{G,0}(F) prod_k P(O_k|F) P(CL_G|F) (log space), recomputed by `set_map`.
With one CL throughout this is exactly the sequential eq. 5.2 (tested against
`fusion.posterior`).

Minimum evidence. Every fused grid keeps its belief, but only a label with at least
``min_observations`` fused activities and a MAP belief of at least ``min_belief`` is
*published* (`published_labels`: the node's topics and markers, the saved labels, the room
belief); the others are kept as candidates (saved apart) until they have the evidence. A
person standing for a moment in the open, or a location that jumped by more than
``associate_m`` for a window or two, otherwise made a label each.

Revisits (5.6). A label is *left* once the person is tracked farther than
``leave_distance_m`` from its cell's centre; a fused observation at a left label's grid
marks it *returned* ("chair->returned").
"""

from __future__ import annotations

import math
import os
from collections import deque
from dataclasses import dataclass, field
from typing import Deque, Dict, List, Optional, Sequence, Tuple

import cv2
import numpy as np
import yaml

from ascc_common.grid import FREE, OCCUPIED, GridInfo
from ascc_common.map_io import save_map
from ascc_common.params import nested, param

from .fusion import activity_prior, entropy, map_label, observation_given_furniture, room_belief
from .location import LocationParams, grid_index, location_type_at
from .models import Models

UNKNOWN = "unknown"


class LocationError(ValueError):
    """The person's location for an activity cannot be used (none, outside the map)."""


@dataclass
class SemanticMapperParams:
    """The semantic_mapper node's private parameters."""

    models_path: str = param("", "model tables YAML (empty: the package's config/models.yaml)")
    grid_resolution_m: float = param(0.25, "[m] side of a semantic grid cell G", gt=0.0)
    window_s: float = param(3.0, "[s] the person's location for an activity is the median "
                            "of the tracked locations over this before its stamp", gt=0.0)
    max_spread_m: float = param(0.5, "[m] an activity during which the tracked location "
                                "spread more than this (the person walked) is not fused",
                                gt=0.0)
    associate_m: float = param(0.25, "[m] a location this close to a label's location "
                               "is fused at that label's grid (a person sitting on a cell "
                               "border makes one label, not two)", ge=0.0)
    min_observations: int = param(5, "a label is published (topic, markers, saved "
                                  "labels, room belief) once this many activities were "
                                  "fused at its grid (5: 2.5 s of windows every 0.5 s)",
                                  ge=1)
    min_belief: float = param(0.5, "... and once its MAP furniture's belief is at least "
                              "this (0.5: more likely than all the others together)",
                              ge=0.0, le=1.0)
    leave_distance_m: float = param(1.0, "[m] the person this far from a label has left it "
                                    "(a later visit is a return), and this far from a "
                                    "stay's median has ended the stay", gt=0.0)
    episode_gap_s: float = param(10.0, "[s] a stationary episode ends after this long "
                                 "without a fused window", gt=0.0)
    target_kind: str = param("shirt", "the detection kind that is the person")
    body_radius_m: float = param(0.15, "[m] added to the target's range: the laser's range "
                                 "is the body's near surface, the location its centre",
                                 ge=0.0)
    target_max_age_s: float = param(10.0, "[s] Target messages older than this are ignored "
                                    "(each is placed by TF at its own stamp)", gt=0.0)
    base_frame: str = param("base_link", "the robot frame of the Target messages")
    map_frame: str = param("map", "the occupancy map's frame")
    output_dir: str = param("", "where ~save and shutdown write the semantic map (empty: "
                            "no saving on shutdown; ~save needs it)")
    output_name: str = param("semantic_map", "file stem of the saved map")
    marker_height_m: float = param(0.5, "[m] label text height above the floor", gt=0.0)
    warn_period_s: float = param(10.0, "[s] each kind of warning at most once per this",
                                 gt=0.0)
    location: LocationParams = nested(LocationParams, "location/")


@dataclass
class Label:
    """The semantic label of one grid."""

    grid: Tuple[int, int]
    x: float                 # [m] map frame: the median of the fused locations
    y: float
    label: str               # MAP furniture (eq. 5.3)
    belief: np.ndarray       # P_{G,t}(F)
    entropy_bits: float
    information_bits: float  # of the last update
    location_type: int       # CL (1..5) on the newest map
    updates: int = 0
    counts: Optional[np.ndarray] = None  # observations per activity O
    left: bool = False       # the person went farther than leave_distance_m since
    returned: bool = False   # came back after leaving (5.6)
    episodes: List[Episode] = field(default_factory=list)  # the stays fused here

    @property
    def text(self) -> str:
        return self.label + ("->returned" if self.returned else "")


@dataclass
class Episode:
    """One stay of the person (no walking, no transition between its windows): its fused
    observations and locations, and the grid they are fused at."""

    counts: np.ndarray        # observations per activity O
    xs: List[float]           # [m] the located windows
    ys: List[float]
    last_t: float             # [s] the newest fused window
    grid: Optional[Tuple[int, int]] = None  # the label it is fused at

    @property
    def median(self) -> Tuple[float, float]:
        return float(np.median(self.xs)), float(np.median(self.ys))


@dataclass(frozen=True)
class Observed:
    """What `SemanticMap.observe` did: ``label`` updated, or ``skipped`` with a reason."""

    label: Optional[Label] = None
    skipped: str = ""
    x: float = math.nan      # [m] the person's location over the window, when fused
    y: float = math.nan


class SemanticMap:
    def __init__(self, models: Models, params: SemanticMapperParams):
        self.models = models
        self.p = params
        p_o_f = observation_given_furniture(models.observation, models.activity)
        with np.errstate(divide="ignore"):
            self.log_o_f = np.log(p_o_f)            # [o, f]
            self.log_cl_f = np.log(models.location)  # [cl, f]
        self.labels: Dict[Tuple[int, int], Label] = {}
        self.track_log: Deque[Tuple[float, float, float]] = deque()
        self.grid: Optional[np.ndarray] = None
        self.info: Optional[GridInfo] = None
        self._index = {a: i for i, a in enumerate(models.activities)}
        self.episode: Optional[Episode] = None

    # -- inputs ---------------------------------------------------------------------------
    def set_map(self, grid: np.ndarray, info: GridInfo) -> None:
        """The occupancy map (``grid[iy, ix]``, ascc_common.grid values)."""
        info.check_axis_aligned()
        self.grid, self.info = np.asarray(grid), info
        for lab in self.labels.values():
            try:
                self._fuse(lab)
            except ValueError:
                pass  # the label left the map (a new map of another place): kept as it was

    def track(self, t: float, x: float, y: float) -> None:
        """The person is at (x, y) [m] at time t [s]."""
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(t)):
            raise LocationError("non-finite location (%r, %r) at %r" % (x, y, t))
        self.track_log.append((t, x, y))
        keep = 2.0 * self.p.window_s + 5.0
        while self.track_log and self.track_log[0][0] < t - keep:
            self.track_log.popleft()
        for lab in self.labels.values():
            if math.hypot(x - lab.x, y - lab.y) > self.p.leave_distance_m:
                lab.left = True

    def location(self, t: float) -> Tuple[float, float, float]:
        """(x, y, spread) [m]: the median of the locations tracked in [t - window_s, t],
        and the largest distance of one of them from it. LocationError if none."""
        pts = np.array([(x, y) for s, x, y in self.track_log
                        if t - self.p.window_s <= s <= t + 1e-6]).reshape(-1, 2)
        if not len(pts):
            raise LocationError("no location of the person in the %.1f s before the "
                                "activity" % self.p.window_s)
        med = np.median(pts, axis=0)
        spread = float(np.max(np.hypot(*(pts - med).T)))
        return float(med[0]), float(med[1]), spread

    def cell(self, x: float, y: float) -> Tuple[int, int]:
        r = self.p.grid_resolution_m
        return int(math.floor(x / r)), int(math.floor(y / r))

    def cell_centre(self, g: Tuple[int, int]) -> Tuple[float, float]:
        r = self.p.grid_resolution_m
        return (g[0] + 0.5) * r, (g[1] + 0.5) * r

    def associate(self, x: float, y: float) -> Tuple[int, int]:
        """The grid of a location: the labelled grid whose location is nearest, if within
        ``associate_m``; else G = g([X, Y])."""
        best, best_d = None, self.p.associate_m
        for g, lab in self.labels.items():
            d = math.hypot(lab.x - x, lab.y - y)
            if d <= best_d and lab.updates > 0:  # (0: an episode's, taken out of it)
                best, best_d = g, d
        return best if best is not None else self.cell(x, y)

    def observe(self, t: float, activity: str) -> Observed:
        """Fuse the activity recognized over the window ending at ``t`` [s]."""
        if activity == UNKNOWN:
            self._end_stay_if_away(t)
            return Observed(skipped="unknown activity")
        o = self._index.get(activity)
        if o is None:
            self.episode = None  # walking or a transition: the stay is over
            return Observed(skipped="%s is not an activity of the models" % activity)
        if self.grid is None:
            raise LocationError("no occupancy map yet")
        x, y, spread = self.location(t)
        if spread > self.p.max_spread_m:
            return Observed(skipped="the person moved %.2f m during the window" % spread)
        try:
            grid_index(self.info, x, y)
        except ValueError as err:
            raise LocationError("the person's %s" % err) from err
        ep = self.episode
        if ep is not None and t - ep.last_t > self.p.episode_gap_s:
            ep = None
        if ep is not None and ep.counts[o] == 0 and self._away(ep, x, y):
            ep = None  # another activity elsewhere: a new stay (the walk was not seen)
        if ep is None:
            ep = self.episode = Episode(np.zeros(len(self._index), int), [], [], t)
        old = ep.grid
        before = self._detach(ep)
        ep.counts[o] += 1
        ep.xs.append(x)
        ep.ys.append(y)
        ep.last_t = t
        lab = self._attach(ep)
        if old is not None and old != ep.grid and self.labels[old].updates <= 0:
            del self.labels[old]  # the episode was all of it: no stray label left behind
        lab.information_bits = (before if before is not None else math.log2(
            len(self.models.furniture))) - lab.entropy_bits
        return Observed(label=lab, x=x, y=y)

    def _away(self, ep: Episode, x: float, y: float) -> bool:
        """The location (x, y) is farther than ``leave_distance_m`` from the stay's
        median: the person is elsewhere."""
        mx, my = ep.median
        return math.hypot(x - mx, y - my) > self.p.leave_distance_m

    def _end_stay_if_away(self, t: float) -> None:
        """An "unknown" window (the recognizer cannot say what the person does: a walk it
        did not recognize, too) ends the stay when the person's location over it lies
        farther than ``leave_distance_m`` from the stay's median."""
        ep = self.episode
        if ep is None:
            return
        try:
            x, y, _ = self.location(t)
        except LocationError:
            return
        if self._away(ep, x, y):
            self.episode = None

    def _detach(self, ep: Episode) -> Optional[float]:
        """Take the episode's observations out of its label (kept, maybe empty, until
        the episode is attached again); the label's entropy before, None if none."""
        lab = self.labels.get(ep.grid) if ep.grid is not None else None
        if lab is None:
            return None
        h = lab.entropy_bits
        lab.counts -= ep.counts
        lab.updates -= len(ep.xs)
        lab.episodes = [e for e in lab.episodes if e is not ep]
        if lab.updates > 0:
            self._place(lab)
            self._fuse(lab)
        return h

    @staticmethod
    def _place(lab: Label) -> None:
        """The label's position: the median of its episodes' located windows."""
        lab.x = float(np.median([x for e in lab.episodes for x in e.xs]))
        lab.y = float(np.median([y for e in lab.episodes for y in e.ys]))

    def _attach(self, ep: Episode) -> Label:
        """Fuse the episode at the grid of its median location."""
        mx, my = ep.median
        g = self.associate(mx, my)
        lab = self.labels.get(g)
        n = len(self.models.furniture)
        if lab is None:
            lab = self.labels[g] = Label(g, mx, my, "", np.full(n, 1.0 / n), math.log2(n),
                                         0.0, 0, counts=np.zeros(len(self._index), int))
        elif lab.left and ep.grid != g:
            lab.returned = True  # another stay at a label the person had left
        lab.left = False
        ep.grid = g
        lab.counts += ep.counts
        lab.updates += len(ep.xs)
        lab.episodes.append(ep)
        self._place(lab)
        self._fuse(lab)
        return lab

    def _fuse(self, lab: Label) -> None:
        """The grid's belief from its observations and its CL on the newest map."""
        cl = location_type_at(self.grid, self.info, self.p.location, lab.x, lab.y)
        with np.errstate(invalid="ignore"):
            log_p = lab.counts @ np.where(lab.counts[:, None] > 0, self.log_o_f, 0.0) \
                + lab.updates * self.log_cl_f[cl - 1]
        if not np.isfinite(log_p).any():
            raise LocationError("the observations at (%.2f, %.2f) are impossible under the "
                                "models at location type %d" % (lab.x, lab.y, cl))
        belief = np.exp(log_p - log_p.max())
        lab.belief = belief / belief.sum()
        lab.location_type = cl
        lab.label = self.models.furniture[map_label(lab.belief)]
        lab.entropy_bits = entropy(lab.belief)

    # -- outputs --------------------------------------------------------------------------
    def is_published(self, lab: Label) -> bool:
        """The label has the minimum evidence (``min_observations``, ``min_belief``)."""
        return lab.updates >= self.p.min_observations and \
            float(lab.belief.max()) >= self.p.min_belief

    def published_labels(self) -> List[Label]:
        """The labels with the minimum evidence, by grid."""
        return [lab for lab in sorted(self.labels.values(), key=lambda lab: lab.grid)
                if self.is_published(lab)]

    def room_belief(self) -> np.ndarray:
        """P_t(R) from the published labels."""
        return room_belief(self.models, [self.models.furniture.index(lab.label)
                                         for lab in self.published_labels()])

    def activity_prior(self) -> np.ndarray:
        """P_t(A) over the models' activities, from P_t(R) (fed back to the recognizer)."""
        return activity_prior(self.models, self.room_belief())

    def labels_doc(self) -> dict:
        """The labels as plain data (the saved YAML): ``labels`` the published ones,
        ``candidates`` those without the minimum evidence yet."""
        def doc(lab: Label) -> dict:
            return {
                "grid": [int(lab.grid[0]), int(lab.grid[1])],
                "position_m": [round(lab.x, 4), round(lab.y, 4)],
                "label": lab.label, "text": lab.text, "returned": bool(lab.returned),
                "belief": [round(float(b), 6) for b in lab.belief],
                "entropy_bits": round(lab.entropy_bits, 6),
                "location_type": int(lab.location_type), "updates": lab.updates,
            }
        everything = sorted(self.labels.values(), key=lambda lab: lab.grid)
        return {
            "frame": self.p.map_frame,
            "grid_resolution_m": self.p.grid_resolution_m,
            "furniture": list(self.models.furniture),
            "rooms": {r: round(float(p), 6) for r, p in zip(self.models.rooms,
                                                             self.room_belief())},
            "min_observations": int(self.p.min_observations),
            "min_belief": float(self.p.min_belief),
            "labels": [doc(lab) for lab in everything if self.is_published(lab)],
            "candidates": [doc(lab) for lab in everything if not self.is_published(lab)],
        }

    def save(self, directory: str, stem: str) -> Dict[str, str]:
        """map_server YAML + PGM of the occupancy map, ``<stem>_labels.yaml`` and a PNG
        with the published labels drawn; returns the paths. LocationError without a map."""
        if self.grid is None:
            raise LocationError("no occupancy map to save yet")
        os.makedirs(directory, exist_ok=True)
        base = os.path.join(directory, stem)
        pgm = save_map(base + ".yaml", self.grid, self.info,
                       comment="semantic_mapping: occupancy map of the semantic map")
        with open(base + "_labels.yaml", "w", encoding="utf-8") as f:
            yaml.safe_dump(self.labels_doc(), f, sort_keys=False)
        png = base + ".png"
        if not cv2.imwrite(png, draw_labels(self.grid, self.info, self.published_labels(),
                                            furniture=self.models.furniture,
                                            crop_margin_m=0.5)):
            raise OSError("cannot write %s" % png)
        return {"yaml": base + ".yaml", "pgm": pgm, "labels": base + "_labels.yaml",
                "png": png}


COLOURS = [(40, 40, 220), (200, 120, 0), (0, 150, 0), (180, 0, 180), (0, 140, 220),
           (120, 80, 20), (80, 80, 80)]  # BGR, one per furniture index (cycled)


def draw_labels(grid: np.ndarray, info: GridInfo, labels, scale: int = 4,
                furniture: Sequence[str] = (), crop_margin_m: Optional[float] = None
                ) -> np.ndarray:
    """A BGR image of the map (free white, occupied black, unknown grey), the map's +y up,
    with a dot and the text of every label; ``crop_margin_m``: only the known cells and
    the labels, with this margin [m]."""
    labels = list(labels)
    x0, y0, x1, y1 = 0, 0, grid.shape[1], grid.shape[0]
    if crop_margin_m is not None:
        iy, ix = np.nonzero((grid == FREE) | (grid == OCCUPIED))
        cells = [info.world_to_cell(lab.x, lab.y) for lab in labels]
        ix = np.concatenate([ix, [c[0] for c in cells]]).astype(int)
        iy = np.concatenate([iy, [c[1] for c in cells]]).astype(int)
        if ix.size:
            m = int(round(crop_margin_m / info.resolution))
            x0, x1 = max(ix.min() - m, 0), min(ix.max() + m + 1, grid.shape[1])
            y0, y1 = max(iy.min() - m, 0), min(iy.max() + m + 1, grid.shape[0])
    grid = grid[y0:y1, x0:x1]
    img = np.full(grid.shape, 205, dtype=np.uint8)
    img[grid == FREE] = 254
    img[grid == OCCUPIED] = 0
    img = cv2.resize(np.flipud(img), None, fx=scale, fy=scale,
                     interpolation=cv2.INTER_NEAREST)
    img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    names = list(furniture)
    for lab in labels:
        u = (lab.x - info.origin_x) / info.resolution * scale - x0 * scale
        v = img.shape[0] - ((lab.y - info.origin_y) / info.resolution - y0) * scale
        if lab.label not in names:
            names.append(lab.label)
        colour = COLOURS[names.index(lab.label) % len(COLOURS)]
        centre = (int(round(u)), int(round(v)))
        cv2.circle(img, centre, max(3, scale + 1), colour, -1, cv2.LINE_AA)
        cv2.putText(img, lab.text, (centre[0] + 6, centre[1] - 6), cv2.FONT_HERSHEY_SIMPLEX,
                    0.4, colour, 1, cv2.LINE_AA)
    return img


@dataclass
class ItemScore:
    """One furniture item against the labels (the end-to-end checks)."""

    name: str
    expected: str
    found: str = ""                 # the nearest label's furniture ("" if none in reach)
    distance_m: float = float("inf")  # from the nearest label to the item's footprint
    correct: bool = False


def footprint_distance(px: float, py: float, footprint: np.ndarray) -> float:
    """[m] from the point (px, py) to the polygon ``footprint`` ((N, 2) [m]; 0 inside)."""
    contour = np.asarray(footprint, dtype=np.float32).reshape(-1, 1, 2)
    return max(0.0, -float(cv2.pointPolygonTest(contour, (float(px), float(py)), True)))


def score_items(items: Sequence[Tuple[str, str, np.ndarray]], labels: Sequence[dict],
                radius_m: float = 0.5) -> List[ItemScore]:
    """Per item (name, expected furniture, footprint polygon (N, 2) [m]): the label
    nearest its footprint (dicts with ``position_m`` and ``label``, as in
    `SemanticMap.labels_doc`); correct when it lies within ``radius_m`` of the footprint
    and names the expected furniture."""
    out = []
    for name, expected, footprint in items:
        s = ItemScore(name, expected)
        for lab in labels:
            d = footprint_distance(lab["position_m"][0], lab["position_m"][1], footprint)
            if d < s.distance_m:
                s.distance_m, s.found = d, lab["label"]
        if s.distance_m > radius_m:
            s.found = ""
        s.correct = bool(s.found) and s.found == expected
        out.append(s)
    return out


def world_items(world, furniture: Sequence[str],
                frame=(0.0, 0.0, 0.0)) -> List[Tuple[str, str, np.ndarray]]:
    """The furniture of an ascc_sim world whose kind is one of ``furniture`` (the label
    it should get), as `score_items` takes them, in a map frame whose origin lies at
    ``frame`` (x, y [m], yaw [rad]) in the world (a mapper's map starts at the robot's
    start pose)."""
    x0, y0, yaw = frame
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, s], [-s, c]])  # world -> map
    return [(o.name, o.kind, (np.asarray(o.footprint) - (x0, y0)) @ rot.T)
            for o in world.objects if o.type == "furniture" and o.kind in furniture]
