#!/usr/bin/env python3
"""Run rostest launch files and judge them by rostest's own results.

`rostest --text` exits 0 whatever its test scripts report, so this runner never uses it.
Each file runs as `rostest --results-base-dir DIR FILE` (own master on a free port, own
log folder), and its verdict is read from the JUnit XML that rostest and rosunit write:

* every test case of the test scripts (`rosunit-*.xml`) counts as passed, failed
  (a failure or an error) or skipped;
* a test that never produced results (crash at import, missing executable, time-limit,
  fixture node that failed to launch) is a failed case of rostest's own file
  (`rostest-*.xml`);
* a non-zero rostest exit code, a file killed by ``--timeout-s``, or a file that ran no
  test case at all fails the file even when no case says so.

Prints a line per file (its cases, exit code, wall time and CPU time: user + system of
rostest and what it reaped, i.e. its master, nodes and test scripts, on all cores; a file
whose CPU is well under its wall time mostly waits), then `rostest: N files, C cases
passed, F failed[, S skipped]`;
exits 1 if anything failed (also when the selection is empty), 0 otherwise.
``--summary-file`` writes the counts, the failed files and each failure's reason as JSON
for scripts/run_tests.sh. Without ``--results-dir`` the XML and logs go to a new
temporary folder, removed when every file passed and named at the end otherwise.

``--jobs 1`` (the default) runs the files one after another, their output live. With
``--jobs 2`` a file may run beside another, by what it says of itself in a comment:
``run_rostests: light`` (little CPU: no simulator at speed, no camera rendering, no model
training beyond a few seconds; its CPU time well under its wall time, see the lines
printed) may run beside any file but an exclusive one; ``run_rostests: exclusive`` runs
alone, before the others; any other file is heavy: never beside another heavy one. The
heavy files go before the light ones: one after another they are the run's critical path
(a light one taking the second slot as a heavy one ends would leave the next heavy one
waiting); the light ones fill the other slot. Each file's output is shown as a block
when it ends.

    run_rostests.py [--filter REGEX] [--jobs N] [--timeout-s S] [--summary-file F] PATH...

PATH is a .test file or a folder searched for *.test (hidden folders skipped).
"""
import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET


def find_tests(paths):
    """The .test files named or found below ``paths``, sorted, each once."""
    found = set()
    for path in paths:
        if os.path.isfile(path):
            found.add(os.path.normpath(path))
            continue
        for root, dirs, files in os.walk(path):
            dirs[:] = [d for d in dirs if not d.startswith(".")]
            found.update(os.path.normpath(os.path.join(root, f))
                         for f in files if f.endswith(".test"))
    return sorted(found)


LANE_MARK = re.compile(r"run_rostests:\s*(light|exclusive)\b")


def lane_of(test_file):
    """"light", "exclusive" or "heavy": what the file's comments say of it."""
    try:
        with open(test_file) as f:
            m = LANE_MARK.search(f.read())
    except OSError:
        return "heavy"
    return m.group(1) if m else "heavy"


def _first_line(text, limit=300):
    lines = [ln.strip() for ln in (text or "").splitlines() if ln.strip()]
    return (lines[0] if lines else "(no message)")[:limit]


def read_results(results_dir):
    """Test cases in the JUnit XML below ``results_dir``: a list of
    (kind, name, outcome, message) with kind "case" (a test script's case) or "rostest"
    (rostest's check that a test ran), outcome "passed", "failed" or "skipped"."""
    cases = []
    for root, _dirs, files in os.walk(results_dir):
        for fname in sorted(files):
            if not fname.endswith(".xml"):
                continue
            kind = "rostest" if fname.startswith("rostest-") else "case"
            path = os.path.join(root, fname)
            try:
                tree = ET.parse(path)
            except ET.ParseError as e:
                cases.append(("rostest", fname, "failed", "unreadable results: %s" % e))
                continue
            for tc in tree.getroot().iter("testcase"):
                name = "%s.%s" % (tc.get("classname", "?"), tc.get("name", "?"))
                outcome, message = "passed", ""
                for child in tc:
                    if child.tag in ("failure", "error"):
                        outcome = "failed"
                        message = child.get("message") or child.text or child.tag
                        break
                    if child.tag == "skipped":
                        outcome, message = "skipped", child.get("message") or ""
                cases.append((kind, name, outcome, _first_line(message)))
    return cases


def judge(cases, rc, killed_after_s):
    """Counts for one file and the lines that explain its failures."""
    script = [c for c in cases if c[0] == "case"]
    ran = [c for c in cases if c[0] == "rostest"]
    passed = sum(1 for c in script if c[2] == "passed")
    skipped = sum(1 for c in script if c[2] == "skipped")
    failed_cases = [c for c in script + ran if c[2] == "failed"]
    reasons = ["%s: %s" % (c[1], c[3]) for c in failed_cases]
    failed = len(failed_cases)
    if killed_after_s is not None:
        reasons.append("killed after %.0f s (--timeout-s)" % killed_after_s)
    elif rc != 0 and not failed_cases:
        reasons.append("rostest exited with %d and no case says why" % rc)
    elif rc == 0 and not script:
        reasons.append("ran no test case")
    if reasons and not failed:
        failed = 1                      # the file fails even when no case counted it
    return passed, failed, skipped, reasons


def rostest_env(results_dir, environ=None):
    """The environment of one rostest: its logs in ``results_dir/log``, and its master and
    nodes on loopback (``ROS_IP=127.0.0.1``, as scripts/ros_isolation.sh) unless the
    user set ROS_IP or ROS_HOSTNAME: a test run is no ROS graph for the lab's network."""
    env = dict(os.environ if environ is None else environ,
               ROS_LOG_DIR=os.path.join(results_dir, "log"))
    if not env.get("ROS_IP") and not env.get("ROS_HOSTNAME"):
        env["ROS_IP"] = "127.0.0.1"
    return env


class Run:
    """One .test file's rostest process (own session, so a timeout kills its nodes);
    ``output``: a file for its output, or None for the runner's own stdout."""

    def __init__(self, index, test_file, results_dir, timeout_s, output=None, lane=None):
        self.index, self.test_file, self.results_dir = index, test_file, results_dir
        self.lane = lane or lane_of(test_file)
        self.output = output
        env = rostest_env(results_dir)
        cmd = ["rostest", "--results-base-dir", results_dir, test_file]
        self.start = time.monotonic()
        self.deadline = self.start + timeout_s
        out = open(output, "w") if output else None
        try:
            self.proc = subprocess.Popen(cmd, env=env, start_new_session=True, stdout=out,
                                         stderr=subprocess.STDOUT if out else None)
        finally:
            if out:
                out.close()
        self.killed = None
        self.seconds = self.cpu_s = None
        self.rc = None

    def poll(self):
        """The exit code once it has ended (killed at its deadline), else None."""
        if self.rc is None:
            ended = reap(self.proc)
            if ended is None and time.monotonic() > self.deadline:
                self.killed = time.monotonic() - self.start
                os.killpg(self.proc.pid, signal.SIGINT)  # let roslaunch tear its nodes down
                ended = reap(self.proc, 20.0)
                if ended is None:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                    ended = reap(self.proc, None)
            if ended is not None:
                self.rc, self.cpu_s = ended
                self.seconds = time.monotonic() - self.start
        return self.rc


def reap(proc, timeout_s=0.0):
    """(exit code, CPU seconds) of ``proc`` once it has ended, else None after waiting up
    to ``timeout_s`` (None: until it ends). The CPU time (user + system, ``os.wait4``) is
    the process's and its reaped descendants': rostest's master, nodes and test scripts.
    Sets ``proc.returncode``, as ``Popen.poll`` would."""
    end = None if timeout_s is None else time.monotonic() + timeout_s
    while True:
        pid, status, usage = os.wait4(proc.pid, 0 if timeout_s is None else os.WNOHANG)
        if pid:
            rc = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
            proc.returncode = rc
            return rc, usage.ru_utime + usage.ru_stime
        if time.monotonic() >= end:
            return None
        time.sleep(0.05)


def run_one(index, test_file, results_dir, timeout_s):
    """Run one .test file, its output live; return its ended ``Run``."""
    r = Run(index, test_file, results_dir, timeout_s)
    while r.poll() is None:
        time.sleep(0.2)
    return r


def may_start(lane, running):
    """Whether a file of ``lane`` may start beside the ``running`` ones."""
    lanes = [r.lane for r in running]
    if "exclusive" in lanes:
        return False
    if lane == "exclusive":
        return not running
    return lane == "light" or "heavy" not in lanes


def run_in_order(tests, results_dir_of, timeout_s):
    """Each file after the other, output live; yields each ``Run`` as it ends (rc,
    seconds, cpu_s, killed: seconds after which it was killed, or None)."""
    for i, test_file in enumerate(tests):
        print("\n==== rostest %s (%d/%d) ====" % (test_file, i + 1, len(tests)), flush=True)
        d = results_dir_of(i, test_file)
        yield run_one(i, test_file, d, timeout_s)


def run_in_lanes(tests, results_dir_of, timeout_s, jobs):
    """Up to ``jobs`` files at a time as their lanes allow (``may_start``): exclusive
    files first, alone, then the heavy ones, then the light ones (each group in its
    order; a light one starts whenever a slot is free and no heavy one may take it); each
    file's output is shown when it ends. Yields as ``run_in_order``."""
    lanes = [lane_of(t) for t in tests]  # read once, not on every poll
    rank = {"exclusive": 0, "heavy": 1, "light": 2}
    order = sorted(range(len(tests)), key=lambda k: rank[lanes[k]])
    pending, running = list(order), []
    while pending or running:
        for k in list(pending):
            if len(running) >= jobs:
                break
            if may_start(lanes[k], running):
                pending.remove(k)
                d = results_dir_of(k, tests[k])
                running.append(Run(k, tests[k], d, timeout_s,
                                   os.path.join(d, "rostest_output.txt"), lanes[k]))
                print("[rostest] started %s (%s; %d/%d)" % (
                    tests[k], running[-1].lane, len(tests) - len(pending), len(tests)),
                    flush=True)
            elif lanes[k] == "exclusive":
                break  # an exclusive file waits for the ones running; nothing jumps it
        time.sleep(0.2)
        for r in [r for r in running if r.poll() is not None]:
            running.remove(r)
            print("\n==== rostest %s (%d/%d, %s) ====" % (
                r.test_file, r.index + 1, len(tests), r.lane), flush=True)
            with open(r.output, errors="replace") as f:
                sys.stdout.write(f.read())
            yield r


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help=".test files or folders to search")
    ap.add_argument("--filter", default="", help="run only files whose path matches REGEX")
    ap.add_argument("--timeout-s", type=float, default=900.0,
                    help="kill a file's rostest after this many seconds (default 900)")
    ap.add_argument("--results-dir", default=None,
                    help="where rostest writes XML and logs (default: a new temp folder, "
                         "removed when every file passed)")
    ap.add_argument("--summary-file", default=None, help="write the counts here as JSON")
    ap.add_argument("--jobs", type=int, default=1,
                    help="files at a time (2: light files beside the others; see above)")
    args = ap.parse_args(argv)

    tests = find_tests(args.paths)
    if args.filter:
        selected = [t for t in tests if re.search(args.filter, t)]
        print("ROSTEST_FILTER=%r selected %d of %d rostest files"
              % (args.filter, len(selected), len(tests)), flush=True)
        tests = selected
    results_root = args.results_dir or tempfile.mkdtemp(prefix="ascc_rostest_")
    totals = {"files": len(tests), "files_failed": 0, "cases_passed": 0, "cases_failed": 0,
              "cases_skipped": 0, "failed_files": [], "failures": []}
    lines = []

    def results_dir_of(i, test_file):
        d = os.path.join(results_root, "%02d_%s" % (
            i, re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.splitext(test_file)[0])))
        os.makedirs(d, exist_ok=True)
        return d

    runs = (run_in_order(tests, results_dir_of, args.timeout_s) if args.jobs <= 1
            else run_in_lanes(tests, results_dir_of, args.timeout_s, args.jobs))
    for r in runs:
        test_file, results_dir = r.test_file, r.results_dir
        passed, failed, skipped, reasons = judge(read_results(results_dir), r.rc, r.killed)
        totals["cases_passed"] += passed
        totals["cases_failed"] += failed
        totals["cases_skipped"] += skipped
        line = "rostest %s: %d cases passed, %d failed%s (rc=%d, %.0f s, CPU %.0f s)" % (
            test_file, passed, failed, ", %d skipped" % skipped if skipped else "", r.rc,
            r.seconds, r.cpu_s)
        if reasons:
            totals["files_failed"] += 1
            totals["failed_files"].append(test_file)
            totals["failures"].extend("%s: %s" % (test_file, r) for r in reasons)
            line += "".join("\n    FAILED %s" % r for r in reasons)
            line += "\n    results and logs: %s" % results_dir
        print(line, flush=True)
        lines.append(line)

    print("\n==== rostest results ====")
    for line in lines:
        print(line)
    if not tests:
        print("FAILED: no rostest file selected")
    summary = "rostest: %d files, %d cases passed, %d failed" % (
        totals["files"], totals["cases_passed"], totals["cases_failed"])
    if totals["cases_skipped"]:
        summary += ", %d skipped" % totals["cases_skipped"]
    print(summary)
    if args.summary_file:
        with open(args.summary_file, "w") as f:
            json.dump(totals, f)
    passed = bool(tests) and totals["files_failed"] == 0
    if not args.results_dir:
        if passed:  # a folder of its own that nobody needs: not left in the temp dir
            shutil.rmtree(results_root, ignore_errors=True)
        else:
            print("results and logs kept in %s" % results_root)
    return 0 if passed else 1


if __name__ == "__main__":
    sys.exit(main())
