#!/usr/bin/env bash
# The pure tests (pytest over ascc_ros_pkg, no master) under Python 3.8, the robots'
# (Ubuntu 20.04 + Noetic), in a venv of their own (.ws/py38-<profile>, rebuilt when its
# requirements file changes):
#   scripts/test_py38.sh [pins|focal]
#     pins  (default) requirements.txt, whose markers pick its Python 3.8 pins
#     focal requirements-focal.txt: Ubuntu 20.04's numpy 1.17.4, OpenCV 4.2, matplotlib
#           3.1.2, pyserial 3.4 (what rosdep installs on a robot), rosbags 0.9.23
# The interpreter: $PYTHON38, else python3.8 on PATH, else pyenv's newest 3.8. ROS's
# pure-Python modules (rospkg, genpy, rospy, the generated messages) come from Debian's
# dist-packages and .ws/devel, after the venv's own packages. Exit code: pytest's; 3 when
# there is no Python 3.8 (nothing was run).
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
profile="${1:-pins}"
case "$profile" in
  pins) reqs=requirements.txt ;;
  focal) reqs=requirements-focal.txt ;;
  *) echo "test_py38: unknown profile $profile (pins | focal)" >&2; exit 2 ;;
esac
py="${PYTHON38:-}"
[ -z "$py" ] && py="$(command -v python3.8 2>/dev/null || true)"
if [ -z "$py" ] || ! "$py" -c 'import sys; assert sys.version_info[:2] == (3, 8)' 2>/dev/null; then
  py="$(ls -d "${PYENV_ROOT:-$HOME/.pyenv}"/versions/3.8.*/bin/python 2>/dev/null | sort -V | tail -1)"
fi
if [ -z "$py" ] || ! "$py" -c 'import sys; assert sys.version_info[:2] == (3, 8)' 2>/dev/null; then
  echo "test_py38: no Python 3.8 interpreter (set PYTHON38, or pyenv install 3.8)" >&2
  exit 3
fi
venv=".ws/py38-$profile"
if [ ! -x "$venv/bin/python" ] || ! cmp -s "$reqs" "$venv/.requirements.txt"; then
  echo "test_py38: creating $venv with $("$py" --version) and $reqs"
  rm -rf "$venv"
  "$py" -m venv "$venv" || exit 1
  "$venv/bin/python" -m pip install -q -r "$reqs" 2>&1 | { grep -v "is neither a file nor a directory" || true; }
  [ "${PIPESTATUS[0]}" -eq 0 ] || { echo "test_py38: pip install -r $reqs failed" >&2; exit 1; }
  # Debian's ROS modules after the venv's packages (a .pth line is appended to sys.path)
  site="$("$venv/bin/python" -c 'import site; print(site.getsitepackages()[0])')"
  echo /usr/lib/python3/dist-packages > "$site/zz_debian_ros.pth"
  cp "$reqs" "$venv/.requirements.txt"
fi
# shellcheck disable=SC1091
source env.sh
echo "test_py38: $("$venv/bin/python" --version); $("$venv/bin/python" -c 'import numpy, cv2, matplotlib; print("numpy", numpy.__version__, "opencv", cv2.__version__, "matplotlib", matplotlib.__version__)')"
exec "$venv/bin/python" -m pytest -q -p no:cacheprovider --import-mode=importlib ascc_ros_pkg
