#!/usr/bin/env bash
# The main job (`make demo`). Until exploration lands (frontier_detector), it drives the
# virtual Create in a square through the real driver and prints the odometry.
set -eo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck disable=SC1091
source env.sh
roslaunch launch/demo_square.launch "$@"
