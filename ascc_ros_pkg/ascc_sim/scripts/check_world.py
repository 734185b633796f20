#!/usr/bin/env python3
"""Validate world files: ``check_world.py WORLD.yaml [...]``.

Prints one line per world (size, robots, objects, people) or the first problem of each
(``file: field: message``) and exits 1 if any world is malformed.
"""
from __future__ import annotations

import argparse
import sys

from ascc_sim.world import WorldError, load_world


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Validate ascc_sim world files.")
    ap.add_argument("worlds", nargs="+", help="world YAML files")
    ap.add_argument("--robot-radius-m", type=float, default=0.165,
                    help="footprint radius used for the placement checks [m]")
    args = ap.parse_args(argv)
    bad = 0
    for path in args.worlds:
        try:
            w = load_world(path, args.robot_radius_m)
        except WorldError as exc:
            print("ERROR %s" % exc)
            bad += 1
            continue
        sx, sy = w.map.info.size_m
        print("ok    %s: %s, %.1f m x %.1f m (%d x %d cells), robots %s, %d objects, "
              "%d people" % (path, w.name, sx, sy, w.map.info.width, w.map.info.height,
                             ", ".join("%s[%s]" % (r.name, r.namespace or "/")
                                       for r in w.robots), len(w.objects), len(w.people)))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
