#!/usr/bin/env bash
# Screenshot of an rviz config, headless: starts Xvfb + rviz (software GL) with CONFIG on
# the running ROS master (ROS_MASTER_URI), waits, saves a PNG and stops both again.
#
#   scripts/rviz_screenshot.sh CONFIG.rviz OUT.png [WAIT_S] [MAX_WIDTH_PX]
#
#   WAIT_S        seconds to let rviz start and receive data (default 20)
#   MAX_WIDTH_PX  downscale the PNG to at most this width (default 1000; 0 = full size)
#
# Start what the config shows first, e.g. `roslaunch launch/sim/office.launch` in another
# shell (same ROS_MASTER_URI). Needs Debian's rviz, xvfb and imagemagick
# (`apt-get install -y rviz xvfb imagemagick`). The display number is the first free one
# from :99 up; the screen is 1400x900, the size of the window in rviz/*.rviz.
set -eo pipefail
if [ $# -lt 2 ]; then
  sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
config="$1"
out="$2"
wait_s="${3:-20}"
max_width="${4:-1000}"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ -z "${ROS_DISTRO:-}" ] || ! command -v rosversion >/dev/null; then
  # shellcheck disable=SC1091
  source "$ROOT/env.sh"
fi
for tool in rviz Xvfb import; do
  command -v "$tool" >/dev/null || { echo "rviz_screenshot: $tool not found" >&2; exit 1; }
done
[ -f "$config" ] || { echo "rviz_screenshot: no such config: $config" >&2; exit 1; }
rostopic list >/dev/null 2>&1 \
  || { echo "rviz_screenshot: no ROS master at ${ROS_MASTER_URI:-?}" >&2; exit 1; }

display=99
while [ -e "/tmp/.X11-unix/X$display" ] || [ -e "/tmp/.X$display-lock" ]; do
  display=$((display + 1))
done
xvfb_pid=""
rviz_pid=""
log="$(mktemp /tmp/rviz_screenshot.XXXXXX.log)"
cleanup() {
  # (no `a && b` here: under `set -e` a failing `wait` would end the trap before Xvfb)
  local pid
  for pid in "$rviz_pid" "$xvfb_pid"; do
    if [ -n "$pid" ]; then
      kill "$pid" 2>/dev/null || true
      wait "$pid" 2>/dev/null || true
    fi
  done
}
trap cleanup EXIT INT TERM

Xvfb ":$display" -screen 0 1400x900x24 -nolisten tcp >/dev/null 2>&1 &
xvfb_pid=$!
for _ in $(seq 50); do
  [ -e "/tmp/.X11-unix/X$display" ] && break
  sleep 0.1
done
DISPLAY=":$display" LIBGL_ALWAYS_SOFTWARE=1 rviz -d "$config" __name:=rviz_screenshot \
  >"$log" 2>&1 &
rviz_pid=$!
sleep "$wait_s"
if ! kill -0 "$rviz_pid" 2>/dev/null; then
  echo "rviz_screenshot: rviz ended early; its log:" >&2
  cat "$log" >&2
  exit 1
fi
mkdir -p "$(dirname "$out")"
resize=()
[ "$max_width" -gt 0 ] && resize=(-resize "${max_width}x>")
DISPLAY=":$display" import -window root "${resize[@]}" -strip "$out"
echo "rviz_screenshot: $out ($(du -k "$out" | cut -f1) KB); rviz log: $log"
