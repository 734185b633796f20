#!/usr/bin/env python3
"""Run rostest launch files one after another and judge them by rostest's own results.

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

Prints a line per file, then `rostest: N files, C cases passed, F failed[, S skipped]`;
exits 1 if anything failed (also when the selection is empty), 0 otherwise.
``--summary-file`` writes the counts as JSON for scripts/run_tests.sh.

    run_rostests.py [--filter REGEX] [--timeout-s S] [--summary-file F] PATH...

PATH is a .test file or a folder searched for *.test (hidden folders skipped).
"""
import argparse
import json
import os
import re
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


def run_one(test_file, results_dir, timeout_s):
    """Run one .test file; return (rc, seconds, killed_after_s or None)."""
    env = dict(os.environ, ROS_LOG_DIR=os.path.join(results_dir, "log"))
    cmd = ["rostest", "--results-base-dir", results_dir, test_file]
    start = time.monotonic()
    proc = subprocess.Popen(cmd, env=env, start_new_session=True)
    killed = None
    try:
        rc = proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        killed = time.monotonic() - start
        os.killpg(proc.pid, signal.SIGINT)          # let roslaunch tear its nodes down
        try:
            rc = proc.wait(timeout=20.0)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            rc = proc.wait()
    return rc, time.monotonic() - start, killed


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help=".test files or folders to search")
    ap.add_argument("--filter", default="", help="run only files whose path matches REGEX")
    ap.add_argument("--timeout-s", type=float, default=900.0,
                    help="kill a file's rostest after this many seconds (default 900)")
    ap.add_argument("--results-dir", default=None,
                    help="where rostest writes XML and logs (default: a new temp folder)")
    ap.add_argument("--summary-file", default=None, help="write the counts here as JSON")
    args = ap.parse_args(argv)

    tests = find_tests(args.paths)
    if args.filter:
        selected = [t for t in tests if re.search(args.filter, t)]
        print("ROSTEST_FILTER=%r selected %d of %d rostest files"
              % (args.filter, len(selected), len(tests)), flush=True)
        tests = selected
    results_root = args.results_dir or tempfile.mkdtemp(prefix="ascc_rostest_")
    totals = {"files": len(tests), "files_failed": 0, "cases_passed": 0, "cases_failed": 0,
              "cases_skipped": 0, "failed_files": []}
    lines = []
    for i, test_file in enumerate(tests):
        print("\n==== rostest %s (%d/%d) ====" % (test_file, i + 1, len(tests)), flush=True)
        results_dir = os.path.join(results_root, "%02d_%s" % (
            i, re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.splitext(test_file)[0])))
        os.makedirs(results_dir, exist_ok=True)
        rc, seconds, killed = run_one(test_file, results_dir, args.timeout_s)
        passed, failed, skipped, reasons = judge(read_results(results_dir), rc, killed)
        totals["cases_passed"] += passed
        totals["cases_failed"] += failed
        totals["cases_skipped"] += skipped
        line = "rostest %s: %d cases passed, %d failed%s (rc=%d, %.0f s)" % (
            test_file, passed, failed, ", %d skipped" % skipped if skipped else "", rc, seconds)
        if reasons:
            totals["files_failed"] += 1
            totals["failed_files"].append(test_file)
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
    return 0 if tests and totals["files_failed"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
