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
    t = traversable
    if t.dtype != np.uint8:
        t = (t if t.dtype == bool else t != 0).view(np.uint8)
    allow = np.zeros((h // k + 2, w // k + 2), np.uint8)
    if h and w:
        _allow_bits(np.ascontiguousarray(t), k, allow)
    return CoarseGraph(k, allow.shape, allow.ravel())


@njit(cache=True, nogil=True)
def _allow_bits(t, k, allow):
    """The move bits of the inner blocks of `allow` (padded by one block on every side).

    Crossings first: east[i, j] (block (i, j) to (i, j + 1)): a traversable cell on the
    block's last column next to one on the neighbour's first, in one of the block's k rows;
    south likewise over the k columns. Each row pair is ANDed whole (contiguous, so
    vectorised) and ORed over the block's rows; the block borders are read from that. Then
    E, W, S, N from the crossings, and a diagonal move from one of its two L-shaped
    detours.
    """
    h, w = t.shape
    hc, wc = h // k, w // k
    east = np.zeros((hc + 2, wc + 2), np.uint8)    # padded like allow: block (i, j) at i + 1
    south = np.zeros((hc + 2, wc + 2), np.uint8)
    pair = np.zeros(w, np.uint8)
    for bi in range(hc):
        pair[:] = 0
        for j in range(k):
            row = t[bi * k + j]
            left, right = row[: w - 1], row[1:]
            for x in range(w - 1):
                pair[x] |= left[x] & right[x]
        for bj in range(wc - 1):
            east[bi + 1, bj + 1] = pair[bj * k + k - 1] != 0
        if bi < hc - 1:
            up, down = t[bi * k + k - 1], t[bi * k + k]
            for x in range(w):
                pair[x] = up[x] & down[x]
            for bj in range(wc):
                any_col = np.uint8(0)
                for c in range(bj * k, bj * k + k):
                    any_col |= pair[c]
                south[bi + 1, bj + 1] = any_col != 0
    for i in range(1, hc + 1):
        for j in range(1, wc + 1):
            e, ew, s, sn = east[i, j], east[i, j - 1], south[i, j], south[i - 1, j]
            se = (e & south[i, j + 1]) | (s & east[i + 1, j])
            sw = (ew & south[i, j - 1]) | (s & east[i + 1, j - 1])
            ne = (e & south[i - 1, j + 1]) | (sn & east[i - 1, j])
            nw = (ew & south[i - 1, j - 1]) | (sn & east[i - 1, j - 1])
            allow[i, j] = (e | (ew << 1) | (s << 2) | (sn << 3) | (se << 4) | (sw << 5)
                           | (ne << 6) | (nw << 7))


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
