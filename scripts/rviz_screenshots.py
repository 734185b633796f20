#!/usr/bin/env python3
"""Render every rviz config of the stack against a running simulation and save the
screenshots for the READMEs: for each config of rviz/launches.yaml, start its launch file
on a master of its own (free loopback port, scripts/ros_isolation.sh), let it run
``wait_s``, take the picture with scripts/rviz_screenshot.sh (Xvfb + rviz, software GL),
stop the launch.

    python scripts/rviz_screenshots.py [--out-dir docs/images] [CONFIG.rviz ...]

Needs Debian's rviz, xvfb and imagemagick (make setup installs rviz; `apt-get install -y
xvfb imagemagick`). Exits 1 if any screenshot failed.
"""
import argparse
import os
import signal
import subprocess
import sys
import time
import xmlrpc.client

import yaml

from ascc_common.ports import free_port

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def load_specs():
    """rviz/launches.yaml: entry name -> launch, args, image, wait_s and config (the rviz
    file in rviz/; the entry's name when not given)."""
    with open(os.path.join(ROOT, "rviz", "launches.yaml")) as f:
        specs = yaml.safe_load(f)
    for name, spec in specs.items():
        spec.setdefault("config", name)
    return specs


def isolated_env():
    """The environment of a run of its own: scripts/ros_isolation.sh's master and ROS_IP."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOSTNAME")}
    out = subprocess.run(["bash", "-c", "source scripts/ros_isolation.sh; "
                          "echo $ROS_MASTER_URI $ROS_IP"], cwd=ROOT, env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    env.update(ROS_MASTER_URI=out[0], ROS_IP=out[1])
    return env


def shoot(name, spec, out_dir):
    env = isolated_env()
    args = [a.replace("FREE", str(free_port())) for a in spec["args"]]
    print("rviz_screenshots: %s (%s) <- %s %s (%s)" % (
        name, spec["config"], spec["launch"], " ".join(args), env["ROS_MASTER_URI"]),
        flush=True)
    run = subprocess.Popen(["bash", "-c", "source env.sh; exec roslaunch %s %s"
                            % (spec["launch"], " ".join(args))], cwd=ROOT, env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                           start_new_session=True)
    try:
        master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
        for _ in range(60):  # the launch starts its master
            try:
                master.getSystemState("/rviz_screenshots")
                break
            except OSError:
                time.sleep(1)
        rc = subprocess.call(["bash", os.path.join(ROOT, "scripts", "rviz_screenshot.sh"),
                              os.path.join(ROOT, "rviz", spec["config"]),
                              os.path.join(out_dir, spec["image"]), str(spec["wait_s"])],
                             cwd=ROOT, env=env)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGINT)
        try:
            run.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(run.pid, signal.SIGKILL)
    return rc == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default=os.path.join(ROOT, "docs", "images"))
    ap.add_argument("configs", nargs="*",
                    help="entries of rviz/launches.yaml, e.g. sim.rviz (default: all)")
    a = ap.parse_args()
    specs = load_specs()
    names = [os.path.basename(c) for c in a.configs] or sorted(specs)
    unknown = [n for n in names if n not in specs]
    if unknown:
        sys.exit("rviz_screenshots: not in rviz/launches.yaml: %s" % ", ".join(unknown))
    failed = [n for n in names if not shoot(n, specs[n], a.out_dir)]
    if failed:
        print("rviz_screenshots: failed: %s" % ", ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
