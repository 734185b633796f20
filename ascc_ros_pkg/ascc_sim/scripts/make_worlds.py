#!/usr/bin/env python3
"""Draw the shipped building maps (walls and static obstacles) into worlds/maps/.

    python3 scripts/make_worlds.py [--out DIR]

The world YAMLs in worlds/ (robots, furniture, cones, posters, people) are written by
hand against these maps; ``test/test_worlds.py`` loads every one of them. All maps are
5 cm per cell with the origin at the lower-left corner of the image.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from ascc_common.map_io import PIXEL_FREE, PIXEL_OCCUPIED, PIXEL_UNKNOWN
from ascc_sim.worldgen import Canvas

WALL = 0.15  # interior wall thickness [m]
OUTER = 0.2  # outer wall thickness [m]


def office() -> Canvas:
    """One floor of an office building, 16 m x 11 m: a corridor through the middle, three
    offices south of it, an open-plan office and a meeting room north of it."""
    c = Canvas(16.0, 11.0)
    c.room(0.5, 0.5, 15.5, 10.5, OUTER)
    c.wall(0.5, 4.4, 15.5, 4.4, WALL)  # corridor y 4.4 .. 6.6
    c.wall(0.5, 6.6, 15.5, 6.6, WALL)
    c.wall(5.5, 0.5, 5.5, 4.4, WALL)  # south offices
    c.wall(10.5, 0.5, 10.5, 4.4, WALL)
    c.wall(9.5, 6.6, 9.5, 10.5, WALL)  # open office | meeting room
    for x0, x1 in ((4.2, 5.1), (9.0, 9.9), (11.0, 11.9)):
        c.door(x0, 4.3, x1, 4.5)
    for x0, x1 in ((1.4, 2.4), (6.4, 7.4), (12.0, 12.9)):
        c.door(x0, 6.5, x1, 6.7)
    c.block(7.9, 6.3, 8.3, 6.675)  # pillar half in the corridor wall
    c.block(13.9, 4.325, 14.3, 4.7)  # pillar on the other side
    # kitchenette counter in the east office, ending at the door jamb: the door keeps its
    # 0.9 m (an earlier version half blocked it, leaving a 0.5 m slot no planner with a
    # safety margin would take for a 0.33 m robot)
    c.block(10.575, 3.2, 11.0, 4.325)
    c.block(15.0, 0.6, 15.4, 1.6)  # cupboard built into the corner
    c.block(0.6, 9.6, 1.2, 10.4)  # service shaft in the open office
    c.block(0.6, 6.675, 0.85, 7.5)  # radiator in the open office
    return c


def corridor() -> Canvas:
    """The corridor loop of thesis fig. 2.11: about 100 m x 25 m, 2.4 m wide, with a
    lobby (the concave) in the middle of the south long side and door recesses."""
    c = Canvas(100.0, 25.0)
    x0, y0, x1, y1 = 0.6, 0.6, 99.4, 24.4  # outer wall centre line
    inner = 0.1 + 2.4 + 0.1  # corridor 2.4 m between the wall faces
    c.floor(x0, y0, x1, y1)
    c.rect(x0 + inner, y0 + inner, x1 - inner, y1 - inner, 205)  # the block of rooms
    for a, b in (((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)),
                 ((x0, y1), (x0, y0))):
        c.wall(a[0], a[1], b[0], b[1], OUTER)
    ix0, iy0, ix1, iy1 = x0 + inner, y0 + inner, x1 - inner, y1 - inner
    lobby = (44.0, 56.0, iy0 + 4.0)  # x from, x to, lobby's north wall
    c.floor(lobby[0], iy0 - 0.1, lobby[1], lobby[2])
    c.wall(ix0, iy0, lobby[0], iy0, OUTER)
    c.wall(lobby[0], iy0, lobby[0], lobby[2], OUTER)
    c.wall(lobby[0], lobby[2], lobby[1], lobby[2], OUTER)
    c.wall(lobby[1], lobby[2], lobby[1], iy0, OUTER)
    c.wall(lobby[1], iy0, ix1, iy0, OUTER)
    c.wall(ix1, iy0, ix1, iy1, OUTER)
    c.wall(ix1, iy1, ix0, iy1, OUTER)
    c.wall(ix0, iy1, ix0, iy0, OUTER)
    # Door recesses (0.35 m deep, 1 m wide) into the block, irregularly spaced.
    for x in (8.0, 15.5, 21.0, 30.5, 37.0, 62.0, 69.5, 77.0, 84.0, 91.5):
        c.block(x - 0.1, iy0 - 0.1, x + 1.1, iy0 + 0.45)
        c.floor(x, iy0 - 0.1, x + 1.0, iy0 + 0.25)
    for x in (6.0, 12.5, 24.0, 33.0, 41.5, 50.0, 58.5, 66.0, 73.5, 81.0, 88.5):
        c.block(x - 0.1, iy1 - 0.45, x + 1.1, iy1 + 0.1)
        c.floor(x, iy1 - 0.25, x + 1.0, iy1 + 0.1)
    for y in (7.0, 14.0):
        c.block(ix0 - 0.1, y - 0.1, ix0 + 0.45, y + 1.1)
        c.floor(ix0 - 0.1, y, ix0 + 0.25, y + 1.0)
        c.block(ix1 - 0.45, y + 1.9, ix1 + 0.1, y + 3.1)
        c.floor(ix1 - 0.25, y + 2.0, ix1 + 0.1, y + 3.0)
    # Pillars along the outer walls of the long sides.
    for x in (20.0, 40.0, 60.0, 80.0):
        c.block(x, y1 - 0.1 - 0.3, x + 0.4, y1)
    c.block(30.0, y0, 30.4, y0 + 0.1 + 0.3)
    c.block(70.0, y0, 70.4, y0 + 0.1 + 0.3)
    return c


def _offset(loop, t):
    """The closed counter-clockwise polygon ``loop`` with every edge moved by ``t`` [m] to
    its left (inwards; t < 0: outwards), the corners mitred."""
    pts = np.asarray(loop, dtype=np.float64)
    d = np.roll(pts, -1, axis=0) - pts
    d /= np.linalg.norm(d, axis=1)[:, None]
    n = np.column_stack([-d[:, 1], d[:, 0]])  # left normal of edge i (pts[i] -> pts[i + 1])
    n_prev = np.roll(n, 1, axis=0)
    return pts + t * (n_prev + n) / (1.0 + np.sum(n_prev * n, axis=1))[:, None]


def _along(loop, side, s0, s1, t0, t1):
    """The rectangle from ``s0`` to ``s1`` [m] along the loop's side ``side`` (from its
    first corner) and from ``t0`` to ``t1`` [m] left of the side's centre line."""
    a, b = np.asarray(loop[side], float), np.asarray(loop[(side + 1) % len(loop)], float)
    d = (b - a) / np.linalg.norm(b - a)
    n = np.array([-d[1], d[0]])
    return [a + s * d + t * n for s, t in ((s0, t0), (s1, t0), (s1, t1), (s0, t1))]


def annex() -> Canvas:
    """A corridor loop whose walls are not all at right angles (a held-out world for the
    mapper; no thesis figure): 2.4 m wide, 134 m round, one side at 45 degrees and a
    long side 3.6 degrees off the others' axes, door recesses and pillars."""
    c = Canvas(56.0, 30.0)
    loop = [(4.0, 3.0), (40.0, 3.0), (52.0, 15.0), (52.0, 27.0), (4.0, 24.0)]  # centre line
    face = 1.2  # the wall faces' distance from the centre line
    c.polygon(_offset(loop, -face - OUTER), PIXEL_OCCUPIED)  # outer wall ...
    c.polygon(_offset(loop, -face), PIXEL_FREE)              # ... the corridor ...
    c.polygon(_offset(loop, face), PIXEL_OCCUPIED)           # ... the rooms' wall ...
    c.polygon(_offset(loop, face + OUTER), PIXEL_UNKNOWN)    # ... and the rooms
    recesses = {0: (6.0, 13.0, 21.0, 28.0), 1: (6.0, 11.0), 2: (5.0,),
                3: (7.0, 15.0, 22.0, 30.0, 38.0), 4: (6.0, 13.0)}
    for side, starts in recesses.items():  # door recesses, 1 m wide, 0.35 m deep
        for s in starts:
            c.polygon(_along(loop, side, s - 0.1, s + 1.1, face - 0.1, face + 0.45),
                      PIXEL_OCCUPIED)
            c.polygon(_along(loop, side, s, s + 1.0, face - 0.1, face + 0.35), PIXEL_FREE)
    for side, s in ((0, 17.0), (3, 12.0), (3, 26.0), (3, 40.0), (4, 10.0)):  # pillars
        c.polygon(_along(loop, side, s, s + 0.4, -face - 0.1, -face + 0.3), PIXEL_OCCUPIED)
    return c


def lab() -> Canvas:
    """The lab room of thesis fig. 2.12: 9 m x 7 m (door closed), a pillar, a counter."""
    c = Canvas(10.0, 8.0)
    c.room(0.5, 0.5, 9.5, 7.5, OUTER)
    c.block(4.8, 7.2, 5.3, 7.6)  # pillar in the north wall
    c.block(0.6, 3.0, 1.2, 5.0)  # counter with a sink along the west wall
    c.block(8.9, 0.6, 9.4, 1.4)  # electrical cabinet
    return c


def apartment() -> Canvas:
    """The lab of chapter 5 with a mock apartment of insulation boards in the middle:
    lab 12 m x 9 m, apartment 6 m x 5 m with a 1 m entrance."""
    c = Canvas(13.0, 10.0)
    c.room(0.5, 0.5, 12.5, 9.5, OUTER)
    board = 0.1
    c.wall(3.5, 2.5, 9.5, 2.5, board)
    c.wall(9.5, 2.5, 9.5, 7.5, board)
    c.wall(9.5, 7.5, 3.5, 7.5, board)
    c.wall(3.5, 7.5, 3.5, 2.5, board)
    c.wall(6.5, 7.5, 6.5, 6.8, board)  # a short partition
    c.door(4.0, 2.4, 5.0, 2.6)  # apartment entrance
    c.block(0.6, 8.6, 1.6, 9.4)  # lab cupboard
    c.block(11.6, 0.6, 12.4, 2.0)  # lab workbench
    return c


def office_vicon() -> Canvas:
    """The office of chapter 3 (Vicon room) where three robots localise a cone: 8 m x
    6.5 m (door closed), a column."""
    c = Canvas(9.0, 7.5)
    c.room(0.5, 0.5, 8.5, 7.0, OUTER)
    c.block(4.3, 6.8, 4.7, 7.1)  # column in the north wall
    return c


MAPS = {
    "office": office,
    "corridor": corridor,
    "lab": lab,
    "apartment": apartment,
    "office_vicon": office_vicon,
    "annex": annex,
}


def main(argv=None) -> int:
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(here, "..", "worlds", "maps"),
                    help="output directory (default: the package's worlds/maps)")
    ap.add_argument("names", nargs="*", help="maps to draw: %s (default: all)"
                    % ", ".join(sorted(MAPS)))
    args = ap.parse_args(argv)
    unknown = sorted(set(args.names) - set(MAPS))
    if unknown:
        ap.error("unknown map(s): %s" % ", ".join(unknown))
    for name in args.names or sorted(MAPS):
        canvas = MAPS[name]()
        pgm, _ = canvas.save(os.path.normpath(args.out), name)
        print("%-13s %4d x %4d cells  %s" % (name, canvas.width, canvas.height, pgm))
    return 0


if __name__ == "__main__":
    sys.exit(main())
