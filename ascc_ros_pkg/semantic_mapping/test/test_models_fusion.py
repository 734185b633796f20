"""The model tables and the fusion equations (eq. 5.1-5.3, entropy, mutual information,
room belief) on hand-computed numbers."""
import copy
import math

import numpy as np
import pytest
import yaml

from semantic_mapping import fusion
from semantic_mapping.models import DEFAULT_MODELS, ModelError, load_models, models_from_dict


@pytest.fixture(scope="module")
def doc():
    with open(DEFAULT_MODELS) as f:
        return yaml.safe_load(f)


@pytest.fixture(scope="module")
def models():
    return load_models()


def test_default_tables_are_the_thesis_tables(models):
    assert models.observation.shape == (5, 5)  # Table 5.1 without its duplicated sixth row
    assert models.observation[1, 1] == 0.76    # P(O=2|A=2), the thesis's example
    assert models.activity[1, 1] == 0.75       # P(A=2|F=2)
    assert models.location[0, 2] == 0.84       # P(CL=1|F=3)
    for table in (models.observation, models.activity, models.location,
                  models.room_activity):
        assert np.allclose(table.sum(axis=0), 1.0)


def test_a_column_not_summing_to_one_is_an_error_naming_table_and_column(doc):
    bad = copy.deepcopy(doc)
    bad["activity_model"][3][4] = 0.20   # column F=5 now sums to 1.10
    with pytest.raises(ModelError, match=r"activity_model P\(A\|F\) \(Table 5.2\): column 5 "
                                         r"\(door\) sums to 1.1, not 1"):
        models_from_dict(bad, "m.yaml")


def test_the_printed_sixth_row_of_table_5_1_is_rejected(doc):
    bad = copy.deepcopy(doc)
    bad["observation_model"].append([0.04, 0.04, 0.04, 0.20, 0.70])
    with pytest.raises(ModelError, match="6 rows, expected 5"):
        models_from_dict(bad)


@pytest.mark.parametrize("change, message", [
    (lambda d: d["location_model"][0].__setitem__(0, -0.05), "negative entry"),
    (lambda d: d["location_model"][0].pop(), "row 1 must have 5 numbers"),
    (lambda d: d.__setitem__("rooms", ["a", "a", "b"]), "unique"),
    (lambda d: d["room_rules"][0].__setitem__("furniture", "sofa"), "unknown furniture"),
    (lambda d: d.__setitem__("room_rule_confidence", 0.2), "room_rule_confidence"),
])
def test_malformed_tables(doc, change, message):
    bad = copy.deepcopy(doc)
    change(bad)
    with pytest.raises(ModelError, match=message):
        models_from_dict(bad)


def test_eq_5_1_by_hand(models):
    p = fusion.observation_given_furniture(models.observation, models.activity)
    # P(O=2|F) = 0.20 P(A=1|F) + 0.76 P(A=2|F) + 0.04 (P(A=3|F) + P(A=4|F) + P(A=5|F))
    assert p[1] == pytest.approx([0.1504, 0.5816, 0.0488, 0.0752, 0.0840])
    assert np.allclose(p.sum(axis=0), 1.0)


def test_eq_5_2_and_5_3_by_hand(models):
    beliefs = fusion.GridBeliefs(models)
    up = beliefs.update("g", 1, 1)  # O = 2 (typing), CL = 2 (wall side)
    # P(O=2|F) * P(CL=2|F) = [.1504*.48, .5816*.42, .0488*.04, .0752*.24, .084*.75]
    unnorm = np.array([0.072192, 0.244272, 0.001952, 0.018048, 0.063])
    assert up.belief == pytest.approx(unnorm / unnorm.sum())
    assert up.label == 1 and up.first_visit
    h = -sum(p * math.log2(p) for p in unnorm / unnorm.sum())
    assert up.entropy_bits == pytest.approx(h)
    assert up.information_bits == pytest.approx(math.log2(5) - h)
    # the same evidence again: the prior is now the first posterior
    again = beliefs.update("g", 1, 1)
    sq = unnorm ** 2
    assert again.belief == pytest.approx(sq / sq.sum())
    assert again.information_bits == pytest.approx(h - again.entropy_bits)
    assert not again.first_visit
    # another grid starts from the uniform prior
    assert beliefs.update("other", 1, 1).belief == pytest.approx(up.belief)


def test_entropy_and_map_label():
    assert fusion.entropy(np.full(5, 0.2)) == pytest.approx(math.log2(5))
    assert fusion.entropy(np.array([1.0, 0.0, 0.0])) == 0.0
    assert fusion.entropy(np.array([0.5, 0.25, 0.25])) == pytest.approx(1.5)
    assert fusion.map_label(np.array([0.1, 0.45, 0.45])) == 1  # ties: the lowest index


def test_impossible_evidence_and_bad_indices(models):
    beliefs = fusion.GridBeliefs(models)
    with pytest.raises(ValueError, match="outside 0..4"):
        beliefs.update("g", 5, 0)
    with pytest.raises(ValueError, match="impossible"):
        fusion.posterior(np.array([1.0, 0, 0, 0, 0]), np.eye(5), np.eye(5), 1, 1)


def test_room_belief_case_rules(models):
    bed, desk, table = 0, 1, 2
    assert fusion.room_belief(models, []) == pytest.approx(np.full(3, 1 / 3))
    assert fusion.room_belief(models, [desk]) == pytest.approx(np.full(3, 1 / 3))
    assert fusion.room_belief(models, [desk, desk]) == pytest.approx([0.05, 0.05, 0.9])
    assert fusion.room_belief(models, [bed, 3]) == pytest.approx([0.9, 0.05, 0.05])
    # bed and dining table both fire: they share the confidence
    assert fusion.room_belief(models, [bed, table]) == pytest.approx([0.45, 0.45, 0.1])
    prior = fusion.activity_prior(models, np.array([0.05, 0.05, 0.9]))
    assert prior == pytest.approx(models.room_activity @ [0.05, 0.05, 0.9])
    assert prior.sum() == pytest.approx(1.0)
    assert np.argmax(prior[:3]) == 1  # in an office, typing is the likeliest room activity
