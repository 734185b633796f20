#!/usr/bin/env python3
"""How much map agreement a rigid offset of part of a map costs (issue 24; no ROS master).

The corridor goal asks the SLAM map to agree >= 97 % cell by cell with the floor plan
(``ascc_navigation.grid.map_agreement``, the measure of ``bench_mapper.py`` and
``bench_exploration.py``). A long side whose neighbour came out a little too long or too
short is mapped whole beside its true place. This tool takes the best map a laser could
give (the plan's free cells and its wall faces, nothing else) and moves one
half of it (north or east of the plan's middle) by 1..N cells, then prints the agreement:
the size of the global error each agreement allows, whatever the mapper.

    python3 scripts/agreement_vs_offset.py [--world-map ascc_sim/worlds/maps/corridor.yaml]
                                           [--max-cells 6]
"""
import argparse
import os

import numpy as np

from ascc_common.grid import FREE, OCCUPIED, UNKNOWN
from ascc_common.map_io import load_map
from ascc_eval.map_quality import wall_faces
from ascc_navigation.grid import map_agreement

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_MAP = os.path.join(HERE, "..", "..", "ascc_sim", "worlds", "maps", "corridor.yaml")


def visible_map(plan: np.ndarray) -> np.ndarray:
    """The plan's free cells and its wall faces (``map_quality.wall_faces``: what a laser
    maps)."""
    out = np.full(plan.shape, UNKNOWN, dtype=np.int8)
    out[plan == FREE] = FREE
    out[wall_faces(plan)] = OCCUPIED
    return out


def shifted_half(grid: np.ndarray, cells: int, axis: int) -> np.ndarray:
    """``grid`` with the half beyond the middle along ``axis`` (0: rows, +y; 1: columns,
    +x) moved ``cells`` further out; what it leaves behind becomes unknown."""
    out = grid.copy()
    mid = grid.shape[axis] // 2
    src = [slice(None), slice(None)]
    dst = [slice(None), slice(None)]
    src[axis] = slice(mid, grid.shape[axis] - cells)
    dst[axis] = slice(mid + cells, grid.shape[axis])
    half = [slice(None), slice(None)]
    half[axis] = slice(mid, None)
    out[tuple(half)] = UNKNOWN
    out[tuple(dst)] = grid[tuple(src)]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--world-map", default=DEFAULT_MAP)
    ap.add_argument("--max-cells", type=int, default=6)
    args = ap.parse_args()
    plan, info = load_map(args.world_map)
    best = visible_map(plan)
    print("map %s: %d x %d cells of %.3f m" % (args.world_map, info.width, info.height,
                                                 info.resolution))
    print("offset [cells]  offset [m]  north half moved  east half moved")
    for k in range(0, args.max_cells + 1):
        acc = [map_agreement(shifted_half(best, k, axis) if k else best, info, plan,
                             info)["accuracy"] for axis in (0, 1)]
        print("%14d  %10.2f  %15.2f %%  %14.2f %%" % (k, k * info.resolution,
                                                      100 * acc[0], 100 * acc[1]))


if __name__ == "__main__":
    main()
