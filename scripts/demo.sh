#!/usr/bin/env bash
# The main job (`make demo`): the ASCCbot explores a simulated world on its own
# (simulator + Create driver + mapper + navigator + frontier_explorer, headless) and writes
# its report to output/<world>_<strategy>_seed<seed>/: summary.json, summary_map.png (map,
# path, goals), summary_coverage.png, summary_explored.yaml/.pgm (final map), run.bag.
#   make demo                                      # office, utility strategy, seed 0
#   make demo ARGS="world:=lab strategy:=nearest seed:=3"
#   make demo ARGS="real_time_factor:=1 rviz:=true" # watch it (needs Debian's rviz)
# `bash scripts/demo.sh --square` runs the foundation demo instead: the driver drives the
# virtual Create in a 1 m square and prints the odometry.
# Each run has its own master on a free loopback port unless ROS_MASTER_URI is set
# (scripts/ros_isolation.sh); it prints how to attach rostopic or rviz to it.
set -eo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck disable=SC1091
source scripts/ros_isolation.sh
# shellcheck disable=SC1091
source env.sh
echo "demo: ROS master $ROS_MASTER_URI; attach with: ROS_MASTER_URI=$ROS_MASTER_URI ROS_IP=${ROS_IP:-127.0.0.1} rostopic list (or rviz -d rviz/exploration.rviz)"
if [ "${1:-}" = "--square" ]; then
  shift
  exec roslaunch launch/demo_square.launch "$@"
fi
world=office; strategy=utility; seed=0
for a in "$@"; do
  case "$a" in
    world:=*) world="${a#world:=}" ;;
    strategy:=*) strategy="${a#strategy:=}" ;;
    seed:=*) seed="${a#seed:=}" ;;
  esac
done
out="$ROOT/output/${world}_${strategy}_seed${seed}"
rm -rf "$out"
mkdir -p "$out"
echo "demo: exploring '$world' with the '$strategy' strategy (seed $seed); report in $out"
roslaunch launch/explore_demo.launch output_dir:="$out" "$@" 2>&1 \
  | grep --line-buffered -E "exploration_monitor|frontier_explorer: status|ERROR|FATAL|Traceback" \
  || true
if [ ! -f "$out/summary.json" ]; then
  echo "demo: no summary was written (see ~/.ros/log/latest)" >&2
  exit 1
fi
echo "demo: files in $out:"
ls -1 "$out"
python - "$out/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
keys = ("label", "final_coverage", "path_m", "time_s", "time_to_coverage_s", "goals", "bumps",
        "end_reason")
print(json.dumps({k: s[k] for k in keys if k in s}, indent=1))
PY
