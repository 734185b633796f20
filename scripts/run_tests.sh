#!/usr/bin/env bash
# Every test of the stack: lint gates, pure-code tests (pytest, no master), then every
# rostest launch file (each brings up its own master through rostest), two at a time where
# a file says it is light (run_rostests.py --jobs 2: never two simulators at once), judged
# by rostest's own JUnit results (scripts/run_rostests.py).
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

# The robots run Python 3.8: the pure tests again under 3.8, with requirements.txt's 3.8
# pins and with Ubuntu 20.04's library versions (scripts/test_py38.sh). Both profiles run
# from the start to the end, at the lowest CPU priority (nice 19): they take the CPU the
# main pytest's rviz checks and the rostests leave while those wait for their launches
# and real-time simulations, and never take it from them. (Beside the main pytest at equal
# priority they made it the longest step: 8.2 min in a clean clone, 5.3 min alone.) Their
# output is shown after the rostests.
py38_dir="$(mktemp -d)"
py38_pids=()
for profile in pins focal; do
  ( nice -n 19 bash scripts/test_py38.sh "$profile" > "$py38_dir/$profile.out" 2>&1
    echo $? > "$py38_dir/$profile.rc"; date +%s > "$py38_dir/$profile.end" ) &
  py38_pids+=($!)
done

step "pytest (pure code, no ROS master)"
pytest_out="$(mktemp)"
test_dirs=(ascc_ros_pkg); [ -d test ] && test_dirs+=(test)
python -m pytest -q -p no:cacheprovider --import-mode=importlib "${test_dirs[@]}" 2>&1 | tee "$pytest_out"
rc=${PIPESTATUS[0]}
py_pass=$(tail -1 "$pytest_out" | grep -Eo '[0-9]+ passed' | grep -Eo '[0-9]+' || echo 0)
py_fail=$(tail -1 "$pytest_out" | grep -Eo '[0-9]+ (failed|errors?)' | awk '{s+=$1} END {print s+0}')
rm -f "$pytest_out"
pytest_end="$(clock)"; rostest_end="-"
# rc 5 is "no tests collected": a failure here, since the test folders exist.
if [ "$rc" -eq 5 ]; then
  py_fail=$((py_fail + 1)); failures+=("pytest collected no tests in ${test_dirs[*]}")
elif [ "$rc" -ne 0 ]; then
  [ "$py_fail" -eq 0 ] && py_fail=1
  failures+=("pytest (rc=$rc): $py_fail failed")
fi
passed=$((passed + py_pass)); failed=$((failed + py_fail))
summary+=("pytest $py_pass passed, $py_fail failed")


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

wait "${py38_pids[@]}"
py38_end="$(clock "$(sort -n "$py38_dir"/*.end 2>/dev/null | tail -1)")"
for profile in pins focal; do
  step "pytest under Python 3.8 ($profile)"
  py38_out="$py38_dir/$profile.out"
  cat "$py38_out"
  rc="$(cat "$py38_dir/$profile.rc" 2>/dev/null || echo 1)"
  p38_pass=$(tail -1 "$py38_out" | grep -Eo '[0-9]+ passed' | grep -Eo '[0-9]+' || echo 0)
  p38_fail=$(tail -1 "$py38_out" | grep -Eo '[0-9]+ (failed|errors?)' | awk '{s+=$1} END {print s+0}')
  if [ "$rc" -eq 3 ]; then
    summary+=("pytest-3.8 $profile SKIPPED (no Python 3.8 interpreter)")
    continue
  elif [ "$rc" -ne 0 ]; then
    [ "$p38_fail" -eq 0 ] && p38_fail=1
    failures+=("pytest under Python 3.8 $profile (rc=$rc): $p38_fail failed")
  fi
  passed=$((passed + p38_pass)); failed=$((failed + p38_fail))
  summary+=("pytest-3.8 $profile $p38_pass passed, $p38_fail failed")
done
rm -rf "$py38_dir"

step "summary (ended: pytest $pytest_end, rostests $rostest_end, Python 3.8 $py38_end)"
for f in "${failures[@]}"; do echo "FAILED: $f"; done
printf -v line '%s; ' "${summary[@]}"; echo "${line%; }"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
