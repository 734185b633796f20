#!/usr/bin/env bash
# Every test of the stack: lint gates, pure-code tests (pytest, no master), then every
# rostest launch file (each brings up its own master through rostest), one at a time.
# Prints a closing line "N passed, N failed" over all of them; exits non-zero on failure.
#   --lint-only     only ruff, vermin (Python 3.8 compatibility) and catkin_lint
#   --no-rostest    skip the rostest part
#   ROSTEST_FILTER=regex   run only the .test files whose path matches
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
step() { printf '\n==== %s ====\n' "$*"; }
record() {  # record NAME RC
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); else failed=$((failed + 1)); failures+=("$1"); fi
}

step "ruff"
ruff check . ; record ruff $?
step "vermin (code must run on Python 3.8)"
vermin -q -t=3.8- --no-tips --eval-annotations --backport dataclasses --violations \
  $(git ls-files '*.py' | tr '\n' ' ') $(grep -rl '^#!/usr/bin/env python3' ascc_ros_pkg scripts test 2>/dev/null | grep -v '\.py$' | tr '\n' ' ')
record vermin $?
step "catkin_lint"
catkin_lint -W2 --strict -q ascc_ros_pkg ; record catkin_lint $?
if [ "$lint_only" -eq 1 ]; then
  printf '\nlint: %d passed, %d failed\n' "$passed" "$failed"; [ "$failed" -eq 0 ]; exit $?
fi

step "pytest (pure code, no ROS master)"
pytest_out="$(mktemp)"
test_dirs=(ascc_ros_pkg); [ -d test ] && test_dirs+=(test)
python -m pytest -q -p no:cacheprovider --import-mode=importlib "${test_dirs[@]}" 2>&1 | tee "$pytest_out"
rc=${PIPESTATUS[0]}
[ "$rc" -eq 5 ] && rc=0   # no tests collected is not a failure of the suite
py_pass=$(grep -Eo '[0-9]+ passed' "$pytest_out" | tail -1 | grep -Eo '[0-9]+' || echo 0)
py_fail=$(grep -Eo '[0-9]+ (failed|error)' "$pytest_out" | awk '{s+=$1} END {print s+0}')
rm -f "$pytest_out"
passed=$((passed + py_pass)); failed=$((failed + py_fail))
[ "$rc" -ne 0 ] && [ "$py_fail" -eq 0 ] && { failed=$((failed + 1)); failures+=("pytest rc=$rc"); }
[ "$py_fail" -gt 0 ] && failures+=("pytest: $py_fail")

if [ "$no_rostest" -eq 0 ]; then
  mapfile -t tests < <(find "${test_dirs[@]}" -name '*.test' | sort | grep -E "${ROSTEST_FILTER:-.}")
  for t in "${tests[@]}"; do
    step "rostest $t"
    start=$(date +%s)
    timeout 900 rostest --text "$t"
    rc=$?
    echo "($t: rc=$rc, $(( $(date +%s) - start )) s)"
    record "rostest $t" $rc
  done
fi

printf '\n==== summary ====\n'
for f in "${failures[@]}"; do echo "FAILED: $f"; done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
