"""Path lengths through free space on a coarse grid (navigation cost and reachability).

The fine traversable mask (FREE cells with the robot's clearance) is summarised on blocks of
k x k cells:
    edge (i, j)-(i, j+1) exists if a traversable cell on the block's east border touches
                                  one on the neighbour's west border (4-adjacency), likewise
                                  for south; a diagonal move needs one of its two L-shaped
                                  detours to exist.
k is kept below 2 r / (resolution * sqrt(2)) (r = clearance radius): two traversable cells of
one block are then closer than 2 r, so they cannot lie on both sides of a wall, and a coarse
path never cuts through an obstacle. Lengths come from a breadth-first search over the
blocks (8-connected, level by level, compiled by numba); among the fewest-step paths the
shortest (straight 1, diagonal sqrt 2, summed in float32) is kept, which is the octile
distance in open space. Result in metres; unreachable blocks are +inf. No ROS import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

import cv2
import numpy as np
from numba import njit

# Public (ascc_eval.offline walks the same graph): DR, DC are the row and column steps of
# the 8 moves, in the order of the allow bits: E, W, S, N, SE, SW, NE, NW, where E/W = col
# +1/-1 and S/N = row +1/-1 of the grid (names only: row +1 is +y in the map frame).
DR = np.array([0, 0, 1, -1, 1, 1, -1, -1])
DC = np.array([1, -1, 0, 0, 1, -1, 1, -1])
_STEP = np.array([1.0, 1.0, 1.0, 1.0, math.sqrt(2), math.sqrt(2), math.sqrt(2), math.sqrt(2)],
                 dtype=np.float32)
# MOVES[allow byte] -> the 8 booleans of its bits (move d allowed), shape (256, 8).
MOVES = ((np.arange(256)[:, None] >> np.arange(8)[None, :]) & 1).astype(bool)


def block_size(resolution: float, clearance_m: float, path_resolution_m: float) -> int:
    """Coarse block side k [cells]: about path_resolution_m, but small enough to be safe."""
    wanted = max(1, int(round(path_resolution_m / resolution)))
    safe = max(1, int(math.floor(2.0 * clearance_m / (resolution * math.sqrt(2.0)) - 1e-9)))
    return max(1, min(wanted, safe))


@dataclass
class CoarseGraph:
    """Blocks of k x k fine cells, padded by one empty block on every side (flattened)."""

    k: int
    shape: Tuple[int, int]     # padded coarse shape (rows, cols)
    allow: np.ndarray          # uint8 per padded block: bit d set = move d allowed

    def node(self, row: int, col: int) -> int:
        """Flat node index of the block holding fine cell (row, col) of the mask."""
        return (row // self.k + 1) * self.shape[1] + (col // self.k + 1)

    def nodes(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Vectorised `node`."""
        return (np.asarray(rows) // self.k + 1) * self.shape[1] + (np.asarray(cols) // self.k + 1)


def build_graph(traversable: np.ndarray, k: int) -> CoarseGraph:
    """Coarse graph of a uint8 traversable mask (nonzero = traversable).

    The mask's shape must be a multiple of k (the caller pads its window).
    """
    h, w = traversable.shape
    if h % k or w % k:
        raise ValueError(f"mask shape {traversable.shape} is not a multiple of k={k}")
    hc, wc = h // k, w // k
    t = traversable
    if t.dtype != np.uint8:                          # OpenCV below: 0/1 bytes will do
        t = (t if t.dtype == bool else t != 0).view(np.uint8)
    # East edges: the last column of block j touches the first column of block j+1.
    ep = np.zeros((hc + 2, wc + 2), bool)
    if wc > 1 and hc > 0:
        # Row j of every block at a time (row-strided views, contiguous along the row):
        # each cell AND its east neighbour, ORed over the block's k rows; the block borders'
        # columns are picked from the small result. Several times faster than the
        # column-strided views over the whole mask.
        pair_any = np.zeros((hc, w - k), np.uint8)
        for j in range(k):
            rows_j = t[j::k]
            cv2.bitwise_or(pair_any, cv2.bitwise_and(rows_j[:, k - 1: w - 1], rows_j[:, k:]),
                           dst=pair_any)
        ep[1:-1, 1:-2] = pair_any[:, ::k] > 0
    sp = np.zeros((hc + 2, wc + 2), bool)
    if hc > 1:
        cross = cv2.bitwise_and(t[k - 1: h - 1: k, :], t[k:: k, :])
        # Any of each block's k columns: a forward running maximum of width k (OpenCV,
        # anchored at the window's start), read at every block's first column.
        any_col = cv2.dilate(cross, np.ones((1, k), np.uint8), anchor=(0, 0))[:, ::k]
        sp[1:-2, 1:-1] = any_col > 0
    # Padding by one block on every side keeps neighbour indices from wrapping around; the
    # padding blocks allow no move, so the bits are computed for the inner blocks only, on
    # shifted views of the 0/1 crossing arrays (no shifted copies).
    e, s = ep.view(np.uint8), sp.view(np.uint8)
    hp, wp = hc + 2, wc + 2

    def at(a: np.ndarray, dr: int, dc: int) -> np.ndarray:
        """a[i + dr, j + dc] for the inner blocks (i, j)."""
        return a[1 + dr: hp - 1 + dr, 1 + dc: wp - 1 + dc]

    allow = np.zeros((hp, wp), np.uint8)
    inner = allow[1:-1, 1:-1]
    # Bits: E, W, S, N; a diagonal move needs one of its two L-shaped detours. OpenCV on
    # the 0/1 bytes (several times faster than numpy's bool operators here); each move
    # sets its bit by one masked OR.
    band, bor = cv2.bitwise_and, cv2.bitwise_or
    for bit, m in enumerate((
            at(e, 0, 0), at(e, 0, -1), at(s, 0, 0), at(s, -1, 0),
            bor(band(at(e, 0, 0), at(s, 0, 1)), band(at(s, 0, 0), at(e, 1, 0))),          # SE
            bor(band(at(e, 0, -1), at(s, 0, -1)), band(at(s, 0, 0), at(e, 1, -1))),       # SW
            bor(band(at(e, 0, 0), at(s, -1, 1)), band(at(s, -1, 0), at(e, -1, 0))),       # NE
            bor(band(at(e, 0, -1), at(s, -1, -1)), band(at(s, -1, 0), at(e, -1, -1))))):  # NW
        cv2.bitwise_or(inner, 1 << bit, dst=inner, mask=m)
    return CoarseGraph(k, (hp, wp), allow.ravel())


def path_lengths(graph: CoarseGraph, start_node: int, resolution: float) -> np.ndarray:
    """Path length [m] from start_node's block to every block (flat, padded); inf if none.

    The start block is taken as passable (the caller checked the robot's cell). The first
    call in a process loads the compiled search from numba's cache (or compiles it once,
    ~1 s, when the cache is missing or stale).
    """
    offsets = (DR * graph.shape[1] + DC).astype(np.int64)
    steps = _bfs_steps(graph.allow, np.int64(start_node), offsets, _STEP)
    return steps * np.float32(graph.k * resolution)


@njit(cache=True, nogil=True)
def _bfs_steps(allow, start, offsets, step):
    """Breadth-first search over the flat padded blocks: for every block, the shortest
    float32 sum of move lengths among its fewest-step paths (+inf if unreachable).

    One plain FIFO queue: the blocks of level L are popped before any of level L + 1, and a
    block found on level L + 1 keeps the smallest sum over all its level-L parents, so the
    result does not depend on the order within a level. Only inner blocks carry moves (the
    padding allows none), so every neighbour index is inside the array.
    """
    n = allow.size
    steps = np.full(n, np.inf, dtype=np.float32)
    level = np.zeros(n, dtype=np.int32)
    queue = np.empty(n, dtype=np.int64)
    steps[start] = np.float32(0.0)
    level[start] = 1
    queue[0] = start
    head, tail = 0, 1
    while head < tail:
        node = queue[head]
        head += 1
        bits = allow[node]
        if bits == 0:
            continue
        here = steps[node]
        nxt = level[node] + 1
        for d in range(8):
            if (bits >> d) & 1:
                nb = node + offsets[d]
                cand = here + step[d]
                lv = level[nb]
                if lv == 0:
                    level[nb] = nxt
                    steps[nb] = cand
                    queue[tail] = nb
                    tail += 1
                elif lv == nxt and cand < steps[nb]:
                    steps[nb] = cand
    return steps
