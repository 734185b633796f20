"""The test runner itself: a failing, crashing, missing or overtime rostest must fail it.

Plants a throw-away catkin package with one rostest file per way of failing (and one that
passes) in a temporary folder, puts it on ROS_PACKAGE_PATH, and runs
scripts/run_rostests.py on it with the real rostest. Needs the ROS environment
(`source env.sh`), as `make test` provides.
"""
import importlib.util
import json
import os
import re
import shutil
import stat
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNNER = os.path.join(ROOT, "scripts", "run_rostests.py")

pytestmark = pytest.mark.skipif(shutil.which("rostest") is None,
                                reason="rostest not on PATH (source env.sh first)")

PACKAGE_XML = """<?xml version="1.0"?>
<package format="2"><name>runner_probe</name><version>0.0.0</version>
<description>planted rostests for the runner's own test</description>
<maintainer email="ascc-ros-pkg@example.org">ascc</maintainer><license>BSD</license>
<buildtool_depend>catkin</buildtool_depend></package>
"""

UNITTEST = """#!/usr/bin/env python3
import unittest

import rostest


class Probe(unittest.TestCase):
    def test_passes(self):
        self.assertEqual(1, 1)
%s

if __name__ == "__main__":
    rostest.rosrun("runner_probe", "%s", Probe)
"""

SCRIPTS = {
    "passes.py": UNITTEST % ("", "passes"),
    "fails.py": UNITTEST % ("\n    def test_fails(self):\n        self.assertEqual(1, 2)\n",
                            "fails"),
    "crashes.py": "#!/usr/bin/env python3\nimport no_such_module_for_the_runner_test\n",
    "sleeps.py": "#!/usr/bin/env python3\nimport time\n\ntime.sleep(60)\n",
}

# test file -> (test type, extra attributes); two say they are light (run_rostests --jobs)
TESTS = {
    "passing.test": ("passes.py", ""),
    "failing.test": ("fails.py", ""),
    "crashing.test": ("crashes.py", ""),
    "missing.test": ("does_not_exist.py", ""),
    "overtime.test": ("sleeps.py", ' time-limit="3"'),
}
LIGHT = ("passing.test", "crashing.test")


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    """A planted package; returns (its test folder, environment that finds it)."""
    root = tmp_path_factory.mktemp("pkgs")
    test_dir = root / "runner_probe" / "test"
    test_dir.mkdir(parents=True)
    (root / "runner_probe" / "package.xml").write_text(PACKAGE_XML)
    for name, text in SCRIPTS.items():
        path = test_dir / name
        path.write_text(text)
        path.chmod(path.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    for name, (script, attrs) in TESTS.items():
        mark = "<!-- run_rostests: light -->" if name in LIGHT else ""
        (test_dir / name).write_text(
            '<launch>%s<test test-name="%s" pkg="runner_probe" type="%s"%s/></launch>\n'
            % (mark, name[:-5], script, attrs))
    env = dict(os.environ)
    env["ROS_PACKAGE_PATH"] = "%s:%s" % (root, env.get("ROS_PACKAGE_PATH", ""))
    return test_dir, env


def run(probe, tmp_path, *args):
    test_dir, env = probe
    summary = tmp_path / "summary.json"
    proc = subprocess.run(
        [sys.executable, RUNNER, "--summary-file", str(summary),
         "--results-dir", str(tmp_path / "results"), *args, str(test_dir)],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        timeout=300)
    counts = json.loads(summary.read_text()) if summary.exists() else None
    return proc.returncode, proc.stdout, counts


def test_every_way_of_failing_fails_the_run(probe, tmp_path):
    rc, out, counts = run(probe, tmp_path)
    assert rc == 1, out
    assert counts["files"] == 5 and counts["files_failed"] == 4, out
    # passes.py's case and fails.py's passing case; the four failures, one per file
    assert (counts["cases_passed"], counts["cases_failed"]) == (2, 4), out
    failed = {os.path.basename(f) for f in counts["failed_files"]}
    assert failed == {"failing.test", "crashing.test", "missing.test", "overtime.test"}
    # each failure by file and reason, for run_tests.sh's closing lines
    assert any(f.endswith("failing.test: __main__.Probe.test_fails: 1 != 2")
               for f in counts["failures"]), counts["failures"]
    assert {os.path.basename(f.split(": ")[0]) for f in counts["failures"]} == failed
    assert "FAILED __main__.Probe.test_fails: 1 != 2" in out
    assert re.search(r"passing\.test: 1 cases passed, 0 failed \(rc=0, \d+ s, CPU \d+ s\)",
                     out), out
    assert "[crashing] did not generate test results" in out
    assert "does not exist or is not executable" in out
    assert "max time [3.0s]" in out
    assert out.rstrip().splitlines()[-1] == "rostest: 5 files, 2 cases passed, 4 failed"


def test_two_at_a_time_gives_the_same_verdicts(probe, tmp_path):
    rc, out, counts = run(probe, tmp_path, "--jobs", "2")
    assert rc == 1, out
    assert counts["files"] == 5 and counts["files_failed"] == 4, out
    assert (counts["cases_passed"], counts["cases_failed"]) == (2, 4), out
    failed = {os.path.basename(f) for f in counts["failed_files"]}
    assert failed == {"failing.test", "crashing.test", "missing.test", "overtime.test"}
    assert "FAILED __main__.Probe.test_fails: 1 != 2" in out  # each file's output shown
    assert "max time [3.0s]" in out
    assert out.count("[rostest] started") == 5
    assert "passing.test (light;" in out and "failing.test (heavy;" in out
    # the heavy files first (one after another they are the critical path), a light one
    # beside each
    started = [line.split()[2] for line in out.splitlines()
               if line.startswith("[rostest] started")]
    assert os.path.basename(started[0]) == "failing.test", started
    heavy = [os.path.basename(f) for f in started if not f.endswith(LIGHT)]
    assert heavy == ["failing.test", "missing.test", "overtime.test"], started
    assert out.rstrip().splitlines()[-1] == "rostest: 5 files, 2 cases passed, 4 failed"


def _runner_module():
    spec = importlib.util.spec_from_file_location("run_rostests", RUNNER)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class _Running:
    def __init__(self, lane):
        self.lane = lane


@pytest.mark.parametrize("lane, running, ok", [
    ("heavy", [], True),
    ("heavy", ["light"], True),
    ("heavy", ["heavy"], False),          # never two heavy files at once
    ("light", ["heavy"], True),
    ("light", ["light"], True),
    ("light", ["exclusive"], False),
    ("exclusive", ["light"], False),      # an exclusive file runs alone
    ("exclusive", [], True),
])
def test_lanes(lane, running, ok):
    assert _runner_module().may_start(lane, [_Running(x) for x in running]) is ok


def test_lane_marks(tmp_path):
    mod = _runner_module()
    for text, lane in [("<launch/>", "heavy"),
                       ("<!-- run_rostests: light (a pty and a fake) --><launch/>", "light"),
                       ("<!--\n  run_rostests: exclusive\n--><launch/>", "exclusive")]:
        f = tmp_path / "x.test"
        f.write_text(text)
        assert mod.lane_of(str(f)) == lane
    assert mod.lane_of(str(tmp_path / "missing.test")) == "heavy"


def test_a_passing_selection_passes(probe, tmp_path):
    rc, out, counts = run(probe, tmp_path, "--filter", "passing")
    assert rc == 0, out
    assert "selected 1 of 5 rostest files" in out
    assert (counts["files"], counts["cases_passed"], counts["cases_failed"]) == (1, 1, 0)


@pytest.mark.parametrize("selection, kept", [("passing", False), ("failing", True)])
def test_its_own_results_folder_is_kept_only_when_something_failed(probe, tmp_path,
                                                                  selection, kept):
    test_dir, env = probe
    env = dict(env, TMPDIR=str(tmp_path))
    proc = subprocess.run([sys.executable, RUNNER, "--filter", selection, str(test_dir)],
                          env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=300)
    assert proc.returncode == (1 if kept else 0), proc.stdout
    left = list(tmp_path.glob("ascc_rostest_*"))
    assert len(left) == (1 if kept else 0), left
    if kept:
        assert "results and logs kept in %s" % left[0] in proc.stdout


def test_an_empty_selection_fails(probe, tmp_path):
    rc, out, counts = run(probe, tmp_path, "--filter", "matches_no_file")
    assert rc == 1, out
    assert "selected 0 of 5 rostest files" in out
    assert "FAILED: no rostest file selected" in out
    assert counts["files"] == 0


def test_a_hung_rostest_is_killed(probe, tmp_path):
    # The outer guard, for a fixture that hangs past every time-limit: the overtime
    # file's 3 s limit would fire at ~3 s, the guard at 1 s kills rostest first.
    rc, out, counts = run(probe, tmp_path, "--filter", "overtime", "--timeout-s", "1")
    assert rc == 1, out
    assert "killed after" in out
    assert counts["files_failed"] == 1 and counts["cases_failed"] >= 1


def test_rostests_run_on_loopback_unless_told_otherwise(tmp_path):
    runner = _runner_module()
    env = runner.rostest_env(str(tmp_path), {"PATH": "/bin"})
    assert env["ROS_IP"] == "127.0.0.1"
    assert env["ROS_LOG_DIR"] == str(tmp_path / "log")
    assert runner.rostest_env("r", {"ROS_IP": "10.1.2.3"})["ROS_IP"] == "10.1.2.3"
    assert "ROS_IP" not in runner.rostest_env("r", {"ROS_HOSTNAME": "robot"})


BURN = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.6:\n    pass\n"


def test_the_cpu_time_counts_what_the_run_reaped():
    # a child that burns 0.6 s of CPU in a process of its own (as rostest's nodes), then
    # exits 3; a sleeping one; one killed by a signal
    runner = _runner_module()
    parent = "import subprocess, sys\nsubprocess.run([sys.executable, '-c', %r])\nsys.exit(3)"
    burner = subprocess.Popen([sys.executable, "-c", parent % BURN])
    rc, cpu_s = runner.reap(burner, None)
    assert rc == 3 and burner.returncode == 3
    assert 0.6 <= cpu_s < 2.0, cpu_s
    sleeper = subprocess.Popen(["cat"], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
    assert runner.reap(sleeper, 0.1) is None  # still running: it waits for its input
    sleeper.stdin.close()  # its end, whenever the machine gets to it
    rc, cpu_s = runner.reap(sleeper, 10.0)
    assert rc == 0 and cpu_s < 0.3, cpu_s
    killed = subprocess.Popen(["sleep", "30"])
    killed.terminate()
    assert runner.reap(killed, 5.0)[0] == -15
