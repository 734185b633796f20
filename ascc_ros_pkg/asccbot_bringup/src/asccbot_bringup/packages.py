"""``run_if_installed``: start a node of a ROS package that may not be installed, or check
that packages are installed, with a clear message naming what is missing.

Debian 12 ships no ``urg_node``, ``hokuyo_node``, ``gmapping``, ``amcl`` or ``move_base``;
a Noetic robot has them. roslaunch, given a node of a missing package, prints a resource
error and carries on, and ``roslaunch-check`` fails the file. Launch files therefore start
such nodes through this tool::

    <node pkg="asccbot_bringup" type="run_if_installed" name="urg_node"
          args="--what 'the Hokuyo driver' --hint 'laser:=false' urg_node urg_node"/>

    run_if_installed [--what TEXT] [--hint TEXT] PACKAGE EXECUTABLE [ARG ...]
        exec the package's executable with the remaining arguments (roslaunch's
        __name:=/__log:= remaps included, so the node keeps its name and ~params);
        exit 1 with one message if the package or executable is missing.
    run_if_installed --check [--what TEXT] [--hint TEXT] PACKAGE [PACKAGE ...]
        exit 1 with one message naming every missing package; otherwise stay up until
        SIGINT/SIGTERM (use as a required="true" node: a missing package ends the launch).

The message names the Debian package of a Noetic robot (``ros-noetic-<name>``) and the
launch argument that picks the stand-in or drops the device (``--hint``). Uses rospkg and
roslib (no rospy).
"""
import os
import signal
import sys
from typing import List, Optional, Tuple


def missing_packages(names: List[str], rospack=None) -> List[str]:
    """The names in ``names`` that no package on ROS_PACKAGE_PATH has."""
    import rospkg
    rospack = rospack or rospkg.RosPack()
    out = []
    for name in names:
        try:
            rospack.get_path(name)
        except rospkg.ResourceNotFound:
            out.append(name)
    return out


def message(missing: List[str], what: str = "", hint: str = "") -> str:
    """One line: what is missing, how to install it on Noetic, the launch argument."""
    debs = " ".join("ros-noetic-" + m.replace("_", "-") for m in missing)
    text = "ROS package%s %s not installed%s; on a Noetic robot: sudo apt install %s" % (
        "s" if len(missing) > 1 else "", ", ".join(missing),
        " (%s cannot start)" % what if what else "", debs)
    return text + ("; or launch with %s" % hint if hint else "")


def _options(argv: List[str]) -> Tuple[bool, str, str, List[str]]:
    check, what, hint, rest = False, "", "", list(argv)
    while rest and rest[0].startswith("--"):
        opt = rest.pop(0)
        if opt == "--check":
            check = True
        elif opt in ("--what", "--hint") and rest:
            value = rest.pop(0)
            what, hint = (value, hint) if opt == "--what" else (what, value)
        else:
            raise SystemExit("run_if_installed: unknown option %r (see its docstring)" % opt)
    return check, what, hint, rest


def main(argv: Optional[List[str]] = None) -> int:
    check, what, hint, rest = _options(sys.argv[1:] if argv is None else argv)
    names = [a for a in rest if ":=" not in a]  # roslaunch's remaps are not packages
    if not names or (not check and len(names) < 2):
        print("run_if_installed: give PACKAGE EXECUTABLE [ARG ...] or --check PACKAGE ...",
              file=sys.stderr)
        return 2
    missing = missing_packages(names if check else names[:1])
    if missing:
        print("[ERROR] asccbot bring-up: " + message(missing, what, hint), file=sys.stderr,
              flush=True)
        return 1
    if check:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: sys.exit(0))
        while True:
            signal.pause()
    import roslib.packages
    package, executable = rest[0], rest[1]
    path = roslib.packages.find_node(package, executable)
    if not path:
        print("[ERROR] asccbot bring-up: package %s has no executable %s%s" % (
            package, executable, "; or launch with %s" % hint if hint else ""),
            file=sys.stderr, flush=True)
        return 1
    args = rest[2:]
    os.execv(path[0], [path[0]] + args)
    return 0  # not reached
