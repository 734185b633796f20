# Sourced by the stack's scripts (demo.sh) BEFORE env.sh: a run of its own, on loopback.
#  * ROS_MASTER_URI unset: a free port on 127.0.0.1 (roslaunch starts its master there),
#    so a second `make demo`, or a user's own roscore on 11311, is never joined; set
#    ROS_MASTER_URI to join a master on purpose.
#  * ROS_IP and ROS_HOSTNAME unset: ROS_IP=127.0.0.1, so the master and the nodes' XML-RPC
#    servers bind to loopback, not to every interface (README, "What ROS 1 exposes").
# Exports ASCC_OWN_MASTER=1 when it chose the port. Prints nothing.
if [ -z "${ROS_MASTER_URI:-}" ]; then
  # below the kernel's ephemeral range, where no node's own server can take it first
  _ascc_port="$(python3 "$(dirname "${BASH_SOURCE[0]}")/../ascc_ros_pkg/ascc_common/src/ascc_common/ports.py")"
  export ROS_MASTER_URI="http://127.0.0.1:${_ascc_port}"
  export ASCC_OWN_MASTER=1
  unset _ascc_port
fi
if [ -z "${ROS_IP:-}" ] && [ -z "${ROS_HOSTNAME:-}" ]; then
  export ROS_IP=127.0.0.1
fi
