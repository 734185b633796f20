# Source this file (bash): `source env.sh` activates the venv, ROS (Debian's packages)
# and the built catkin workspace, so roslaunch/rosrun/rostest find every package.
_ascc_root="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ ! -f "$_ascc_root/.ws/devel/setup.bash" ]; then
  echo "env.sh: workspace not built; run scripts/setup.sh (or make setup) first" >&2
  return 1 2>/dev/null || exit 1
fi
# ROS's setup scripts read unset variables: relax `set -u` while sourcing them.
_ascc_nounset="$(set +o | grep nounset)"
set +u
# shellcheck disable=SC1091
source "$_ascc_root/.venv/bin/activate"
# shellcheck disable=SC1091
source "$_ascc_root/.ws/devel/setup.bash"
eval "$_ascc_nounset"
unset _ascc_nounset
export ROS_PYTHON_VERSION=3
export ASCC_ROOT="$_ascc_root"
export ROSCONSOLE_FORMAT='[${severity}] [${time}] [${node}]: ${message}'
unset _ascc_root
