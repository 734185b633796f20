#!/usr/bin/env bash
# Every test of the stack: lint gates, pytest (test/ first; the packages' own tests, which
# need no master, in the background, see below), then every rostest launch file (each
# brings up its own master through rostest), two at a time where a file says it is light
# (run_rostests.py --jobs 2: never two simulators at once), judged by rostest's own JUnit
# results (scripts/run_rostests.py).
# Prints "lint ...; pytest ...; rostest N files, C cases passed, F failed", then a closing
# line "N passed, N failed" over all of them; exits non-zero on any failure.
#   --lint-only     only ruff, vermin (Python 3.8 compatibility) and catkin_lint
#   --no-rostest    skip the rostest part
# The pure tests also run under Python 3.8 (scripts/test_py38.sh pins, focal), in the
# background at the lowest CPU priority, from the start to the end.
#   ROSTEST_FILTER=regex   run only the .test files whose path matches (none: a failure)
#   ROSTEST_JOBS=1         the rostest files one after another, their output live
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck disable=SC1091
source env.sh
export PYTHONDONTWRITEBYTECODE=1

lint_only=0; no_rostest=0
for a in "$@"; do
  case "$a" in
    --lint-only) lint_only=1 ;;
    --no-rostest) no_rostest=1 ;;
    *) echo "run_tests.sh: unknown option $a" >&2; exit 2 ;;
  esac
done

passed=0; failed=0; failures=()
lint_pass=0; lint_fail=0
# each step's heading says when it started ([m:ss] since this script began), so that a
# log shows where the time of `make test` goes
t0=$(date +%s)
clock() { local s=$(( ${1:-$(date +%s)} - t0 )); printf '%d:%02d' $((s / 60)) $((s % 60)); }
step() { printf '\n==== %s ==== [%s]\n' "$*" "$(clock)"; }
lint_gate() {  # lint_gate NAME RC
  if [ "$2" -eq 0 ]; then lint_pass=$((lint_pass + 1)); else lint_fail=$((lint_fail + 1)); failures+=("$1"); fi
}

step "ruff"
ruff check . ; lint_gate ruff $?
step "vermin (code must run on Python 3.8)"
vermin -q -t=3.8- --no-tips --eval-annotations --backport dataclasses --violations \
  $(git ls-files '*.py' | tr '\n' ' ') $(grep -rl '^#!/usr/bin/env python3' ascc_ros_pkg scripts test 2>/dev/null | grep -v '\.py$' | tr '\n' ' ')
lint_gate vermin $?
step "catkin_lint"
catkin_lint -W2 --strict -q ascc_ros_pkg ; lint_gate catkin_lint $?
passed=$((passed + lint_pass)); failed=$((failed + lint_fail))
summary=("lint $lint_pass passed, $lint_fail failed")
if [ "$lint_only" -eq 1 ]; then
  printf '\n%s\n%d passed, %d failed\n' "${summary[0]}" "$passed" "$failed"; [ "$failed" -eq 0 ]; exit $?
fi

# pytest_counts NAME OUT RC: a pytest run's counts (the last line of its output OUT) in
# cnt_pass and cnt_fail, its failure named in failures; rc 5 ("no tests collected") is a
# failure, since the test folders exist
pytest_counts() {
  local name="$1" out="$2" rc="$3"
  cnt_pass=$(tail -1 "$out" | grep -Eo '[0-9]+ passed' | grep -Eo '[0-9]+' || echo 0)
  cnt_fail=$(tail -1 "$out" | grep -Eo '[0-9]+ (failed|errors?)' | awk '{s+=$1} END {print s+0}')
  if [ "$rc" -eq 5 ]; then
    cnt_fail=$((cnt_fail + 1)); failures+=("$name collected no tests")
  elif [ "$rc" -ne 0 ]; then
    [ "$cnt_fail" -eq 0 ] && cnt_fail=1
    failures+=("$name (rc=$rc): $cnt_fail failed")
  fi
}
PYTEST=(python -m pytest -q -p no:cacheprovider --import-mode=importlib)

# In the background from the start to the end, at the lowest CPU priority (nice 19), so
# that they take the CPU the rostests leave while those wait for their launches and
# real-time simulations, and never take it from them; their output is shown after the
# rostests:
#  * the robots run Python 3.8: the pure tests again under 3.8, with requirements.txt's
#    3.8 pins and with Ubuntu 20.04's library versions (scripts/test_py38.sh);
#  * the packages' own tests (ascc_ros_pkg, no master) but those in FOREGROUND_TESTS:
#    the 3.8 passes have always run these same tests there. (Run first in the
#    foreground, they made the rostests start 6.5 min late: a clean clone's `make test`
#    took 20.7 min on the 2-core VM, 18.2 min with them here.)
# In the foreground, before the rostests: test/ (the rviz configs rendered, launches side
# by side, the rostest runner's own tests: they start rviz, masters and launches with
# wall-clock deadlines) and the Qt tests, which the 3.8 passes skip (PyQt5 is Debian's
# only) and one of which restarts a real master.
FOREGROUND_TESTS=(ascc_ros_pkg/telepresence/test/test_operator_gui_node.py
                  ascc_ros_pkg/telepresence/test/test_gui.py)
bg_dir="$(mktemp -d)"
bg_pids=()
background() {  # background NAME COMMAND...: nice 19; NAME.out, NAME.rc, NAME.end
  local name="$1"; shift
  ( nice -n 19 "$@" > "$bg_dir/$name.out" 2>&1
    echo $? > "$bg_dir/$name.rc"; date +%s > "$bg_dir/$name.end" ) &
  bg_pids+=($!)
}
ignore=(); for f in "${FOREGROUND_TESTS[@]}"; do ignore+=(--ignore="$f"); done
background packages "${PYTEST[@]}" ascc_ros_pkg "${ignore[@]}"
for profile in pins focal; do
  background "py38-$profile" bash scripts/test_py38.sh "$profile"
done

test_dirs=(ascc_ros_pkg); [ -d test ] && test_dirs+=(test)
step "pytest: test/ and the packages' tests that wait on a master (the others: background)"
fg_out="$(mktemp)"
"${PYTEST[@]}" "${test_dirs[@]:1}" "${FOREGROUND_TESTS[@]}" 2>&1 | tee "$fg_out"
pytest_counts "pytest (foreground)" "$fg_out" "${PIPESTATUS[0]}"
py_pass=$cnt_pass; py_fail=$cnt_fail
rm -f "$fg_out"
pytest_end="$(clock)"; rostest_end="-"


if [ "$no_rostest" -eq 0 ]; then
  # Each .test runs with its own master; its verdict is read from rostest's JUnit XML
  # (scripts/run_rostests.py), never from `rostest --text`, whose exit code is always 0.
  results_dir="$ROOT/.ws/test_results"
  rm -rf "$results_dir"; mkdir -p "$results_dir"
  python scripts/run_rostests.py --results-dir "$results_dir" --summary-file "$results_dir/summary.json" \
    --jobs "${ROSTEST_JOBS:-2}" --filter "${ROSTEST_FILTER:-}" "${test_dirs[@]}"
  rc=$?
  # the counts on the first line, then each failed file and case by name, so that the
  # log's last lines say what failed
  mapfile -t rt_summary < <(python - "$results_dir/summary.json" <<'PY'
import json, sys
try:
    s = json.load(open(sys.argv[1]))
    print(s["files"], s["cases_passed"], s["cases_failed"], s["cases_skipped"])
    for failure in s.get("failures", []):
        print("rostest " + failure)
except (OSError, ValueError, KeyError):
    print(0, 0, 0, 0)
PY
)
  read -r rt_files rt_pass rt_fail rt_skip <<< "${rt_summary[0]}"
  rt_failures=("${rt_summary[@]:1}")
  [ "$rc" -ne 0 ] && [ "$rt_fail" -eq 0 ] && rt_fail=1
  failures+=("${rt_failures[@]}")
  [ "$rc" -ne 0 ] && [ "${#rt_failures[@]}" -eq 0 ] && failures+=("rostest: see the rostest results above")
  passed=$((passed + rt_pass)); failed=$((failed + rt_fail))
  rt_line="rostest $rt_files files, $rt_pass cases passed, $rt_fail failed"
  [ "$rt_skip" -gt 0 ] && rt_line+=", $rt_skip skipped"
  [ -n "${ROSTEST_FILTER:-}" ] && rt_line+=" (ROSTEST_FILTER=$ROSTEST_FILTER)"
  summary+=("$rt_line")
  rostest_end="$(clock)"
fi

wait "${bg_pids[@]}"
bg_end="$(clock "$(sort -n "$bg_dir"/*.end 2>/dev/null | tail -1)")"
step "pytest: the packages' tests (background)"
cat "$bg_dir/packages.out"
pytest_counts "pytest (packages)" "$bg_dir/packages.out" "$(cat "$bg_dir/packages.rc" 2>/dev/null || echo 1)"
py_pass=$((py_pass + cnt_pass)); py_fail=$((py_fail + cnt_fail))
passed=$((passed + py_pass)); failed=$((failed + py_fail))
summary=("${summary[0]}" "pytest $py_pass passed, $py_fail failed" "${summary[@]:1}")
for profile in pins focal; do
  step "pytest under Python 3.8 ($profile)"
  py38_out="$bg_dir/py38-$profile.out"
  cat "$py38_out"
  rc="$(cat "$bg_dir/py38-$profile.rc" 2>/dev/null || echo 1)"
  if [ "$rc" -eq 3 ]; then
    summary+=("pytest-3.8 $profile SKIPPED (no Python 3.8 interpreter)")
    continue
  fi
  pytest_counts "pytest under Python 3.8 $profile" "$py38_out" "$rc"
  passed=$((passed + cnt_pass)); failed=$((failed + cnt_fail))
  summary+=("pytest-3.8 $profile $cnt_pass passed, $cnt_fail failed")
done
rm -rf "$bg_dir"

step "summary (ended: foreground pytest $pytest_end, rostests $rostest_end, background $bg_end)"
for f in "${failures[@]}"; do echo "FAILED: $f"; done
printf -v line '%s; ' "${summary[@]}"; echo "${line%; }"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
