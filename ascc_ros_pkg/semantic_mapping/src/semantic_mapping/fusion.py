"""Bayes fusion of the activity and location channels (thesis 5.2.2, eq. 5.1-5.3, 5.5).

Variables are 0-based indices here (the thesis's value v is index v - 1):

    eq. 5.1   P(O|F)  = sum_A P(O|A) P(A|F)                      `observation_given_furniture`
    eq. 5.2   P_{G,t}(F) ∝ P(O_t|F) P(CL_t|F) P_{G,t-1}(F)       `posterior`
    eq. 5.3   F_{G,t} = argmax_F P_{G,t}(F)                       `map_label`
    5.5       H_{G,t}(F) = -sum_F P_{G,t}(F) log2 P_{G,t}(F)      `entropy` [bits]
              I_{G,t}(F) = H_{G,t-1}(F) - H_{G,t}(F)              (`GridBeliefs.update`)

Entropies are in bits: the thesis's Table 5.5 is (its mutual information at t1..t4 is
log2(5) - H, the entropy of the uniform prior over five furniture types in bits).

`GridBeliefs` keeps P_{G,t}(F) per grid G (uniform P_{G,0}(F) = 1/M for a grid seen the
first time), and `room_belief` is the case-based P_t(R) of 5.5 over the MAP labels, which
`activity_prior` turns into the activity prior fed back to the recognizer. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Hashable, Iterable, Optional

import numpy as np

from .models import Models


def observation_given_furniture(observation: np.ndarray, activity: np.ndarray) -> np.ndarray:
    """Eq. 5.1: P(O|F)[o, f] = sum_a P(O|A)[o, a] P(A|F)[a, f] (a matrix product)."""
    return observation @ activity


def posterior(prior: np.ndarray, p_o_given_f: np.ndarray, p_cl_given_f: np.ndarray,
              o: int, cl: int) -> np.ndarray:
    """Eq. 5.2: the normalised P_{G,t}(F) after observing activity ``o`` at location type
    ``cl`` (0-based), from the prior P_{G,t-1}(F). ValueError if the evidence has zero
    probability under every furniture type the prior allows."""
    unnorm = p_o_given_f[o] * p_cl_given_f[cl] * prior
    total = float(unnorm.sum())
    if not total > 0.0:
        raise ValueError("observation O=%d at location type CL=%d is impossible under the "
                         "prior and the models" % (o + 1, cl + 1))
    return unnorm / total


def map_label(belief: np.ndarray) -> int:
    """Eq. 5.3: the MAP furniture index (ties: the lowest index, numpy's argmax)."""
    return int(np.argmax(belief))


def entropy(belief: np.ndarray) -> float:
    """H(F) = -sum p log2 p [bits], with 0 log 0 = 0."""
    p = np.asarray(belief, dtype=float)
    p = p[p > 0.0]
    return float(-(p * np.log2(p)).sum())


@dataclass(frozen=True)
class Update:
    """What one observation did to a grid's belief."""

    grid: Hashable
    belief: np.ndarray      # P_{G,t}(F)
    label: int              # F_{G,t} (0-based), eq. 5.3
    entropy_bits: float     # H_{G,t}(F)
    information_bits: float  # I_{G,t}(F) = H_{G,t-1}(F) - H_{G,t}(F)
    first_visit: bool


class GridBeliefs:
    """P_{G,t}(F) for every grid G seen so far (eq. 5.2); a new grid starts uniform."""

    def __init__(self, models: Models):
        self.models = models
        self.p_o_given_f = observation_given_furniture(models.observation, models.activity)
        self.p_cl_given_f = models.location
        self.beliefs: Dict[Hashable, np.ndarray] = {}

    @property
    def n_furniture(self) -> int:
        return len(self.models.furniture)

    def uniform(self) -> np.ndarray:
        return np.full(self.n_furniture, 1.0 / self.n_furniture)

    def belief(self, grid: Hashable) -> np.ndarray:
        """P_{G,t}(F) of ``grid`` (uniform if never observed)."""
        b = self.beliefs.get(grid)
        return self.uniform() if b is None else b.copy()

    def update(self, grid: Hashable, o: int, cl: int) -> Update:
        """Fuse activity ``o`` and location type ``cl`` (0-based) observed at ``grid``."""
        n_o, n_cl = self.p_o_given_f.shape[0], self.p_cl_given_f.shape[0]
        if not 0 <= o < n_o:
            raise ValueError("activity index %r outside 0..%d" % (o, n_o - 1))
        if not 0 <= cl < n_cl:
            raise ValueError("location type index %r outside 0..%d" % (cl, n_cl - 1))
        first = grid not in self.beliefs
        prior = self.belief(grid)
        new = posterior(prior, self.p_o_given_f, self.p_cl_given_f, o, cl)
        self.beliefs[grid] = new
        h = entropy(new)
        return Update(grid, new.copy(), map_label(new), h, entropy(prior) - h, first)

    def labels(self) -> Dict[Hashable, int]:
        """The MAP label of every observed grid."""
        return {g: map_label(b) for g, b in self.beliefs.items()}


def room_belief(models: Models, labels: Iterable[int]) -> np.ndarray:
    """P_t(R) by the case rules of 5.5 over the grids' MAP labels (0-based furniture
    indices): the rooms whose rules fire share ``room_rule_confidence``, the others the
    rest; uniform when no rule fires (or every room's does)."""
    n_rooms = len(models.rooms)
    counts = np.bincount(np.asarray(list(labels), dtype=int),
                         minlength=len(models.furniture))
    fired = np.zeros(n_rooms, dtype=bool)
    for rule in models.room_rules:
        if counts[rule.furniture] >= rule.at_least:
            fired[rule.room] = True
    k = int(fired.sum())
    if k in (0, n_rooms):
        return np.full(n_rooms, 1.0 / n_rooms)
    c = models.room_rule_confidence
    return np.where(fired, c / k, (1.0 - c) / (n_rooms - k))


def activity_prior(models: Models, p_room: Optional[np.ndarray]) -> np.ndarray:
    """The activity prior sent to the recognizer: P_t(A) = sum_R P(A|R) P_t(R) (uniform
    P_t(R) when ``p_room`` is None)."""
    if p_room is None:
        p_room = np.full(len(models.rooms), 1.0 / len(models.rooms))
    return models.room_activity @ p_room
