"""The simulation evaluations of thesis 5.5 on the model tables: the forward fusion test
(5.5.1, Table 5.4) and the sequential test (5.5.2, Table 5.5). Pure numpy.

Forward fusion (no feedback): for each true furniture type F, ``trials`` times draw the
true activity A ~ P(A|F), the observed activity O ~ P(O|A) and the location type
CL ~ P(CL|F); the decision is eq. 5.3 on eq. 5.2 from the uniform prior. The exact version
enumerates every (O, CL) pair: P(F_hat = D | F) = sum over the pairs decided D of
P(O|F) P(CL|F), with P(O|F) from eq. 5.1 (O and CL are independent given F).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Sequence

import numpy as np

from .fusion import GridBeliefs, Update, activity_prior, observation_given_furniture, room_belief
from .models import Models


def decision_table(models: Models) -> np.ndarray:
    """D[o, cl]: the eq. 5.3 decision (0-based) for every (O, CL) pair, uniform prior
    (ties: the lowest furniture index)."""
    p_o_f = observation_given_furniture(models.observation, models.activity)
    joint = p_o_f[:, None, :] * models.location[None, :, :]  # [o, cl, f]
    return np.argmax(joint, axis=2)


def tied_pairs(models: Models, rel_tol: float = 1e-12) -> List[tuple]:
    """The (O, CL) pairs (0-based) whose largest posterior is shared by two types."""
    p_o_f = observation_given_furniture(models.observation, models.activity)
    joint = p_o_f[:, None, :] * models.location[None, :, :]
    top = joint.max(axis=2, keepdims=True)
    n_top = (np.abs(joint - top) <= rel_tol * top).sum(axis=2)
    return [tuple(int(v) for v in p) for p in np.argwhere(n_top > 1)]


def forward_fusion_exact(models: Models) -> np.ndarray:
    """P(F_hat = d | F = f) as a matrix [d, f] (each column sums to 1)."""
    p_o_f = observation_given_furniture(models.observation, models.activity)
    n_f = len(models.furniture)
    decide = decision_table(models)
    out = np.zeros((n_f, n_f))
    for f in range(n_f):
        p_pair = np.outer(p_o_f[:, f], models.location[:, f])  # P(O, CL | F = f)
        out[:, f] = np.bincount(decide.ravel(), weights=p_pair.ravel(), minlength=n_f)
    return out


def _draw(rng: np.random.Generator, columns: np.ndarray) -> np.ndarray:
    """One draw per column of ``columns`` [value, sample] (each a distribution), by
    inverse CDF: the number of cumulative sums below a uniform variate."""
    cdf = np.cumsum(columns, axis=0)
    u = rng.random(columns.shape[1]) * cdf[-1]
    return (u[None, :] >= cdf).sum(axis=0).clip(max=columns.shape[0] - 1)


def forward_fusion_sampled(models: Models, trials: int,
                           rng: np.random.Generator) -> np.ndarray:
    """Counts [d, f] of decisions d over ``trials`` sampled trials per true type f."""
    n_f = len(models.furniture)
    decide = decision_table(models)
    counts = np.zeros((n_f, n_f), dtype=np.int64)
    for f in range(n_f):
        a = _draw(rng, np.repeat(models.activity[:, f:f + 1], trials, axis=1))
        o = _draw(rng, models.observation[:, a])
        cl = _draw(rng, np.repeat(models.location[:, f:f + 1], trials, axis=1))
        counts[:, f] = np.bincount(decide[o, cl], minlength=n_f)
    return counts


@dataclass(frozen=True)
class SequentialStep:
    update: Update
    room: np.ndarray            # P_t(R) after the step
    activity_prior: np.ndarray  # sum_R P(A|R) P_t(R), sent to the recognizer


def sequential(models: Models, grids: Sequence, observations: Sequence[int],
               location_types: Sequence[int]) -> List[SequentialStep]:
    """Eq. 5.2 at each time point (0-based O and CL), with the room belief of 5.5 after
    each step and the activity prior it feeds back."""
    beliefs = GridBeliefs(models)
    steps = []
    for g, o, cl in zip(grids, observations, location_types):
        up = beliefs.update(g, o, cl)
        p_room = room_belief(models, beliefs.labels().values())
        steps.append(SequentialStep(up, p_room, activity_prior(models, p_room)))
    return steps
