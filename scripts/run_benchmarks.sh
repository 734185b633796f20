#!/usr/bin/env bash
# `make bench`: every package's benchmark script (ascc_ros_pkg/*/scripts/bench_*.py), one
# after another, printing their numbers. Benchmarks are not tests: they measure speed and
# quality on this machine; docs/results/<package>.md record the numbers with the machine.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck disable=SC1091
source env.sh
echo "machine: $(nproc) cores, $(free -g | awk '/Mem:/ {print $2}') GiB, $(python --version)"
rc=0
for b in ascc_ros_pkg/*/scripts/bench_*.py; do
  [ -e "$b" ] || continue
  # hours of simulated exploration, a 10-minute real-time CPU run: only with BENCH_ALL=1
  # (or run them by hand)
  case "$b" in *bench_exploration.py|*bench_cpu.py) [ "${BENCH_ALL:-0}" = 1 ] || { echo "(skipping $b; BENCH_ALL=1 runs it)"; continue; } ;; esac
  printf '\n==== %s ====\n' "$b"
  python "$b" || { echo "benchmark $b failed"; rc=1; }
done
exit $rc
