#!/usr/bin/env bash
# One-time (idempotent) set-up of ascc-ros-pkg on a fresh Debian 12 machine:
#   1. Debian's ROS 1 (Noetic line) packages the stack needs,
#   2. a virtualenv (.venv) from /usr/bin/python3 --system-site-packages with pinned
#      pip requirements (so rospy & co. from Debian stay importable),
#   3. the catkin workspace, built out of tree in .ws/ (git-ignored).
# Safe to rerun: each step is skipped when already done (delete .ws/ to force a rebuild).
#   scripts/setup.sh [--screenshots]   --screenshots: also Xvfb and ImageMagick, for
#                                      scripts/rviz_screenshots.py (make screenshots)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

APT_PACKAGES=(
  ros-core-dev catkin catkin-lint ros-message-generation ros-message-runtime
  python3-rospy python3-roslaunch python3-rostest librostest-dev python3-rosbag
  python3-tf2-ros libtf2-ros-dev python3-actionlib libactionlib-dev
  python3-actionlib-msgs python3-diagnostic-msgs python3-geometry-msgs python3-nav-msgs
  python3-sensor-msgs python3-visualization-msgs python3-move-base-msgs python3-std-msgs
  python3-std-srvs python3-tf2-msgs python3-rosgraph-msgs python3-diagnostic-updater
  libactionlib-msgs-dev libdiagnostic-msgs-dev libgeometry-msgs-dev libnav-msgs-dev
  libsensor-msgs-dev libvisualization-msgs-dev libmove-base-msgs-dev libstd-msgs-dev
  libstd-srvs-dev libtf2-msgs-dev python3-venv python3-dev
  ros-robot-state-publisher libdiagnostic-aggregator-dev libdiagnostic-aggregator-tools
  liburdfdom-tools rviz python3-pyqt5
  python3-tornado python3-selenium chromium chromium-driver
  python3-numba
)
# rviz headless: a virtual X server and ImageMagick's `import` (scripts/rviz_screenshot.sh)
[ "${1:-}" = "--screenshots" ] && APT_PACKAGES+=(xvfb imagemagick)

log() { printf '[setup] %s\n' "$*"; }

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  log "installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
else
  log "Debian packages present"
fi

# The venv is keyed on requirements.txt: a changed pin reinstalls.
if [ ! -x .venv/bin/python ] || ! cmp -s requirements.txt .venv/.requirements.txt; then
  log "creating .venv (system site packages visible)"
  [ -x .venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages .venv
  .venv/bin/python -m pip install -q --upgrade pip 2>&1 | { grep -v "is neither a file nor a directory" || true; }
  .venv/bin/python -m pip install -q -r requirements.txt 2>&1 | { grep -v "is neither a file nor a directory" || true; }
  cp requirements.txt .venv/.requirements.txt
else
  log ".venv up to date"
fi

# Build the catkin workspace out of tree: .ws/src -> ../ascc_ros_pkg
mkdir -p .ws
[ -L .ws/src ] || ln -sfn ../ascc_ros_pkg .ws/src
stamp_now="$(find ascc_ros_pkg -name package.xml -o -name CMakeLists.txt -o -name '*.msg' \
  -o -name '*.srv' -o -name '*.action' -o -name setup.py | sort | xargs cat | md5sum)"
if [ ! -f .ws/devel/setup.bash ] || [ "$stamp_now" != "$(cat .ws/.stamp 2>/dev/null)" ]; then
  log "building catkin workspace in .ws/"
  # shellcheck disable=SC1091
  source .venv/bin/activate
  (cd .ws && catkin_make -DPYTHON_EXECUTABLE="$ROOT/.venv/bin/python3" -DCATKIN_ENABLE_TESTING=ON \
      -DCMAKE_BUILD_TYPE=Release > build.log 2>&1) || { tail -40 .ws/build.log; exit 1; }
  echo "$stamp_now" > .ws/.stamp
else
  log "catkin workspace up to date"
fi
log "done: 'source env.sh' to use the stack"
