"""Run one roslaunch of a benchmark on its own master port, its output in a log file."""
from __future__ import annotations

import os
import subprocess
import time
from typing import Dict


def run_launch(launch_file: str, args: Dict[str, object], run_dir: str, port: int,
               timeout_s: float, label: str = "") -> float:
    """``roslaunch -p port launch_file name:=value ...`` with ``ROS_MASTER_URI`` on that
    port, its output to ``run_dir/launch.log``; killed after ``timeout_s`` (said on
    stdout). Returns the wall time [s]."""
    os.makedirs(run_dir, exist_ok=True)
    env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % port)
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
