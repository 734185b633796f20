"""fuse_estimates and thesis_tables: the exact interfaces, rejected lines, exit status."""
import csv
import io
import math
import os
import subprocess
import sys

import pytest

from colloc_fusion.cli import TABLE_3_1, fuse_estimates_main, thesis_tables_rows

NODES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "nodes")


def run(tool, *args):
    return subprocess.run([sys.executable, os.path.join(NODES, tool)] + list(args),
                          capture_output=True, text=True, timeout=60)


def rows(text):
    return list(csv.reader(io.StringIO(text)))


@pytest.mark.parametrize("method", ["thesis", "information", "ci"])
def test_table_3_1_through_the_installed_tool(method):
    res = run("fuse_estimates", TABLE_3_1, "--method", method)
    assert res.returncode == 0 and res.stderr == ""
    out = rows(res.stdout)
    assert out[0] == ["set", "x", "y"] and [r[0] for r in out[1:]] == ["1", "2", "3"]
    for r in out[1:]:
        assert all(len(v.split(".")[1]) >= 5 for v in r[1:])
    if method != "ci":  # diagonal covariances: the information filter is eq. 3.1-3.5
        assert abs(float(out[2][1]) - 1.56716) < 1e-4  # printed set 2 x


def test_bad_rows_named_and_sets_fused_from_valid_rows(tmp_path, capsys):
    path = tmp_path / "est.csv"
    path.write_text("set,robot,x,y,ux,uy\n"
                    "b,robotA,1.0,2.0,0.01,0.04\n"      # line 2
                    "a,robotA,0.0,0.0,1.0,1.0\n"        # line 3
                    "a,robotB,nan,0.0,1.0,1.0\n"        # line 4: NaN coordinate
                    "a,robotC,3.0,0.0,0.0,1.0\n"        # line 5: zero uncertainty
                    "b,robotB,2.0,4.0,0.03,-1\n"        # line 6: negative uncertainty
                    "b,robotC,2.0,1.0,0.03,0.04\n"      # line 7
                    "a,robotD,1.0,1.0,inf,1.0\n"        # line 8: infinite uncertainty
                    "b,robotC,9.0,9.0,0.1,0.1\n"        # line 9: robot twice
                    "a,robotE,x,1.0,1.0,1.0\n")         # line 10: not a number
    status = fuse_estimates_main([str(path)])
    out, err = capsys.readouterr()
    assert status == 0
    for line in (4, 5, 6, 8, 9, 10):
        assert "est.csv:%d:" % line in err
    assert "est.csv:2:" not in err and "est.csv:7:" not in err
    got = rows(out)
    assert [r[0] for r in got] == ["set", "b", "a"]
    assert float(got[2][1]) == 0.0 and float(got[2][2]) == 0.0  # a: robotA alone
    bx = (1.0 / 0.01 + 2.0 / 0.03) / (1 / 0.01 + 1 / 0.03)
    by = (2.0 / 0.04 + 1.0 / 0.04) / (2 / 0.04)
    assert math.isclose(float(got[1][1]), bx, abs_tol=1e-6)
    assert math.isclose(float(got[1][2]), by, abs_tol=1e-6)


def test_a_set_without_valid_row_exit_2(tmp_path):
    path = tmp_path / "est.csv"
    path.write_text("set,robot,x,y,ux,uy\n1,robotA,1,2,0.1,0.1\n2,robotA,1,2,0,0.1\n"
                    "2,robotB,1,2,0.1,nan\n")
    res = run("fuse_estimates", str(path))
    assert res.returncode == 2
    assert "est.csv:3:" in res.stderr and "est.csv:4:" in res.stderr
    assert "set 2" in res.stderr
    assert rows(res.stdout) == [["set", "x", "y"], ["1", "1.000000", "2.000000"]]


def test_wrong_header_and_missing_file_exit_2(tmp_path):
    path = tmp_path / "est.csv"
    path.write_text("set,robot,x,y,vx,vy\n1,robotA,1,2,0.1,0.1\n")
    res = run("fuse_estimates", str(path))
    assert res.returncode == 2 and "est.csv:1: header" in res.stderr
    res = run("fuse_estimates", str(tmp_path / "none.csv"))
    assert res.returncode == 2 and "none.csv" in res.stderr
    res = run("fuse_estimates", str(path), "--method", "average")
    assert res.returncode == 2


def test_thesis_tables_prints_ours_printed_and_differences():
    res = run("thesis_tables")
    assert res.returncode == 0, res.stderr
    lines = [line.split() for line in res.stdout.splitlines()]
    cells = {(r[0], r[1]): r for r in lines if len(r) >= 5 and r[0] in "123"}
    assert len(cells) == 12
    for r in cells.values():
        ours, printed, diff = float(r[2]), float(r[3]), float(r[4])
        assert math.isclose(diff, ours - printed, abs_tol=2e-5)
    # the cells that do not follow from Table 3.1: set 1 y (and its difference), set 3 dy
    flagged = sorted(k for k, r in cells.items() if r[-1] == "*")
    assert flagged == [("1", "dy"), ("1", "y_fusion"), ("3", "dy")]


def test_thesis_tables_rows_recompute_differences_from_ours():
    for _, ours, _ in thesis_tables_rows():
        assert math.isclose(ours["dx"], ours["x_fusion"] - ours["x_vicon"])
        assert math.isclose(ours["dy"], ours["y_fusion"] - ours["y_vicon"])


WORLD = os.path.join(os.path.dirname(NODES), "..", "ascc_sim", "worlds", "three_robots.yaml")


def test_measure_landmarks_on_the_world_map_and_a_moved_guess(tmp_path):
    res = run("measure_landmarks", "--world-map", WORLD)
    assert res.returncode == 0, res.stderr
    out = rows(res.stdout)
    assert out[0] == ["name", "x_map", "y_map", "x_truth", "y_truth", "residual_m"]
    assert [r[0] for r in out[1:5]] == ["corner1", "corner2", "corner3", "corner4"]
    for r in out[1:5]:
        assert abs(float(r[1]) - float(r[3])) <= 0.025 and abs(float(r[2]) - float(r[4])) \
            <= 0.025
    guesses = tmp_path / "g.csv"
    guesses.write_text("name,x,y\ncorner1,2.3,6.0\ncorner2,6.5,6.0\ncorner3,7.5,2.9\n"
                       "corner4,4.0,4.0\n")  # corner4's guess is nowhere near a desk
    res = run("measure_landmarks", "--world-map", WORLD, "--guesses", str(guesses))
    assert res.returncode == 0 and "corner4 not measured" in res.stderr
    assert len(rows(res.stdout)) == 5  # header, 3 corners, the transform line
    guesses.write_text("name,x,y\ncorner1,2.3,6.0\ncorner2,4.0,4.0\n")
    res = run("measure_landmarks", "--world-map", WORLD, "--guesses", str(guesses))
    assert res.returncode == 2 and "at least 3" in res.stderr
