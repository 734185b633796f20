"""Run one roslaunch of a benchmark on its own master port, on loopback, its output in a
log file."""
from __future__ import annotations

import os
import subprocess
import time
from typing import Dict, Mapping, Optional


def loopback_env(port: int, environ: Optional[Mapping[str, str]] = None) -> Dict[str, str]:
    """``environ`` (default: this process's) with the master on 127.0.0.1:``port`` and,
    unless ROS_IP or ROS_HOSTNAME is set, ``ROS_IP=127.0.0.1``: the run's master and nodes
    then listen on loopback, not on the lab's network (as scripts/ros_isolation.sh)."""
    env = dict(os.environ if environ is None else environ)
    env["ROS_MASTER_URI"] = "http://127.0.0.1:%d" % port
    if not env.get("ROS_IP") and not env.get("ROS_HOSTNAME"):
        env["ROS_IP"] = "127.0.0.1"
    return env


def run_launch(launch_file: str, args: Dict[str, object], run_dir: str, port: int,
               timeout_s: float, label: str = "") -> float:
    """``roslaunch -p port launch_file name:=value ...`` with ``ROS_MASTER_URI`` on that
    port (``loopback_env``), its output to ``run_dir/launch.log``; killed after
    ``timeout_s`` (said on stdout). Returns the wall time [s]."""
    os.makedirs(run_dir, exist_ok=True)
    env = loopback_env(port)
    cmd = ["roslaunch", "-p", str(port), launch_file] + \
        ["%s:=%s" % (k, v) for k, v in args.items()]
    start = time.time()
    with open(os.path.join(run_dir, "launch.log"), "w") as log:
        try:
            subprocess.run(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                           timeout=timeout_s, check=False)
        except subprocess.TimeoutExpired:
            print("  %s: timed out after %d s" % (label or launch_file, timeout_s))
    return time.time() - start
