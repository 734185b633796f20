"""The evaluation commands forward_fusion and sequential_test (fixed interfaces)."""
import copy
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import yaml

from semantic_mapping import cli, evaluation
from semantic_mapping.models import DEFAULT_MODELS, load_models

NODES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "nodes")
ACCURACY = re.compile(r"^accuracy:( \d\.\d{4}){5}$")


def run(main, argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out.splitlines(), out.err


def accuracies(lines):
    assert ACCURACY.match(lines[-1]), lines[-1]
    return [float(v) for v in lines[-1].split()[1:]]


def test_forward_fusion_exact_is_the_enumeration(capsys):
    code, lines, _ = run(cli.forward_fusion_main, ["--exact"], capsys)
    assert code == 0
    m = load_models()
    # by hand for F = 3 (dining table): the pairs decided 3 are CL = 1 with any O, and
    # O = 3 with CL = 3..5 (the decision table); P(O, CL | F=3) = P(O|F=3) P(CL|F=3), with
    # P(O=3|F=3) = .04*.01 + .04*.01 + .84*.74 + .04*.23 + .04*.01 = 0.632 (eq. 5.1), so
    # P(correct | F=3) = 0.84 * 1 + 0.632 * (0.04 + 0.01 + 0.07) = 0.91584
    decide = evaluation.decision_table(m)
    assert decide[:, 0].tolist() == [2] * 5 and decide[2, 2:].tolist() == [2, 2, 2]
    assert (decide[[0, 1, 3, 4], 1:] != 2).all() and decide[2, 1] != 2
    assert accuracies(lines)[2] == pytest.approx(0.91584, abs=5e-5)
    assert accuracies(lines) == pytest.approx(np.diag(evaluation.forward_fusion_exact(m)),
                                              abs=5e-5)
    table = [ln for ln in lines if re.match(r"^[1-5] ", ln)]
    assert len(table) == 5  # Table 5.4's rows: decisions 1..5
    assert "| thesis Table 5.4" in lines[2]


def test_forward_fusion_sampled_agrees_with_exact_and_follows_the_seed(capsys):
    exact = np.diag(evaluation.forward_fusion_exact(load_models()))
    _, lines, _ = run(cli.forward_fusion_main, ["--trials", "20000", "--seed", "4"], capsys)
    sampled = np.array(accuracies(lines))
    sigma = np.sqrt(exact * (1 - exact) / 20000)
    assert np.all(np.abs(sampled - exact) < 4 * sigma)
    _, again, _ = run(cli.forward_fusion_main, ["--trials", "20000", "--seed", "4"], capsys)
    _, other, _ = run(cli.forward_fusion_main, ["--trials", "20000", "--seed", "5"], capsys)
    assert again == lines and other[-1] != lines[-1]
    counts = [[int(v) for v in ln.split("|")[0].split()[1:]] for ln in lines
              if re.match(r"^[1-5] ", ln)]
    assert np.array(counts).sum(axis=0).tolist() == [20000] * 5


def test_sequential_test_rows(capsys):
    code, lines, _ = run(cli.sequential_test_main, [], capsys)
    assert code == 0
    rows = {ln[:24].strip(): ln[24:].split() for ln in lines[2:]}
    entropy = [float(v) for v in rows["Entropy"]]
    info = [float(v) for v in rows["Mutual Information"]]
    assert len(entropy) == len(info) == 5
    assert rows["Furniture estimation"] == ["2", "2", "5", "2", "2"]
    # t1 and t4: the same evidence (O=2, CL=2) on a new grid -> the same numbers
    assert entropy[0] == entropy[3] and info[0] == pytest.approx(math.log2(5) - entropy[0],
                                                                   abs=2e-4)
    # t5 is t1's grid again: its information is the entropy drop since t1
    assert info[4] == pytest.approx(entropy[0] - entropy[4], abs=2e-4)
    assert rows["P_t(R=office)"][1:] == ["0.9000"] * 4  # two desks labelled after t2


def test_the_nodes_run_as_commands():
    out = subprocess.run([sys.executable, os.path.join(NODES, "forward_fusion"),
                          "--trials", "50"], capture_output=True, text=True, check=True)
    assert ACCURACY.match(out.stdout.splitlines()[-1])
    out = subprocess.run([sys.executable, os.path.join(NODES, "sequential_test")],
                         capture_output=True, text=True, check=True)
    assert out.stdout.splitlines()[-7].startswith("Entropy")


def test_a_bad_table_is_a_clear_error(tmp_path, capsys):
    with open(DEFAULT_MODELS) as f:
        doc = yaml.safe_load(f)
    bad = copy.deepcopy(doc)
    bad["location_model"][0][2] = 0.80  # column F=3 sums to 0.96
    path = tmp_path / "models.yaml"
    path.write_text(yaml.safe_dump(bad))
    code, lines, err = run(cli.forward_fusion_main, ["--models", str(path)], capsys)
    assert code == 2 and lines == []
    assert "location_model P(CL|F) (Table 5.3): column 3 (dining_table) sums to 0.96" in err
    code, _, err = run(cli.sequential_test_main, ["--thesis", str(tmp_path / "none.yaml")],
                       capsys)
    assert code == 2 and "none.yaml" in err
