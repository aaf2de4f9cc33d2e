"""Shortest-path distances to goals, by breadth-first search in numpy.

`dist_array(grid, goal)[cell id]` is the number of moves from that cell to
`goal` (cell id = y * width + x), -1 where the goal cannot be reached. Many
goals are searched at once: each wavefront step grows every goal's reached set
by one cell with four shifted ORs, so 300 goals cost about as much as a few. Goals are bits of uint64 words (64
goals a word), so a step is a handful of vector operations on
(height, width, goals/64) words; the distance itself is counted in
bit-sliced binary counters (one uint64 plane per bit of the count) and
unpacked into the int32 table once at the end. Results are cached on the grid
(`grid.derived[("dist", goal)]`), so a map's tables are built once per goal.
"""
from __future__ import annotations

from typing import Dict, List, Sequence, Tuple

import numpy as np

from ..grid import Coord, Grid

#: Goals searched together; bounds the temporary arrays to a few tens of MB.
_CELLS_PER_BATCH = 64_000_000


def _key(goal: Coord) -> Tuple[str, Coord]:
    return ("dist", (int(goal[0]), int(goal[1])))


def dist_array(grid: Grid, goal: Coord) -> np.ndarray:
    """Distances from every cell to `goal` (int32, length width*height, -1 unreachable)."""
    return dist_arrays(grid, [goal])[0]


def dist_arrays(grid: Grid, goals: Sequence[Coord]) -> List[np.ndarray]:
    """`dist_array` for each goal, computing the missing ones in batches."""
    missing = sorted({_key(g)[1] for g in goals if _key(g) not in grid.derived})
    batch = max(1, _CELLS_PER_BATCH // max(grid.num_cells, 1))
    for k in range(0, len(missing), batch):
        chunk = missing[k:k + batch]
        for goal, table in zip(chunk, _bfs(grid, chunk)):
            table.setflags(write=False)
            grid.derived[_key(goal)] = table
    return [grid.derived[_key(g)] for g in goals]  # type: ignore[misc]


def dist_lists(grid: Grid, goals: Sequence[Coord], unreachable: int) -> List[List[int]]:
    """Distances as plain lists for solvers' inner loops, with -1 replaced by `unreachable`."""
    out = []
    cache: Dict[Coord, List[int]] = {}
    for g, arr in zip(goals, dist_arrays(grid, goals)):
        key = (int(g[0]), int(g[1]))
        if key not in cache:
            cache[key] = np.where(arr < 0, unreachable, arr).tolist()
        out.append(cache[key])
    return out


def lower_bounds(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord]) -> Tuple[int, int]:
    """(sum, max) of start-to-goal distances: mapf-IR's lb_soc and lb_makespan."""
    if not starts:
        return 0, 0
    d = [int(t[grid.index(s)]) for s, t in zip(starts, dist_arrays(grid, goals))]
    if min(d) < 0:
        raise ValueError("a goal is unreachable from its start; check the problem first")
    return sum(d), max(d)


def _bfs(grid: Grid, goals: Sequence[Coord]) -> List[np.ndarray]:
    h, w = grid.height, grid.width
    n = len(goals)
    words = (n + 63) // 64
    # bit k % 64 of word k // 64 at a cell: goal k's search has reached that cell
    reached = np.zeros((h, w, words), dtype="<u8")
    for k, (x, y) in enumerate(goals):
        if grid.is_free((x, y)):
            reached[y, x, k // 64] |= np.uint64(1) << np.uint64(k % 64)
    free_mask = np.where(grid.free, ~np.uint64(0), np.uint64(0)).astype("<u8")[:, :, None]
    planes: List[np.ndarray] = []  # bit-sliced counters: steps each bit was still unreached
    grown = np.empty_like(reached)
    while True:
        np.copyto(grown, reached)
        grown[:, 1:] |= reached[:, :-1]
        grown[:, :-1] |= reached[:, 1:]
        grown[1:, :] |= reached[:-1, :]
        grown[:-1, :] |= reached[1:, :]
        grown &= free_mask
        if np.array_equal(grown, reached):
            break
        _increment(planes, ~reached)
        reached, grown = grown, reached
    dist = np.zeros((h * w, words * 64), dtype=np.int32)
    for k, plane in enumerate(planes):
        dist += _unpack(plane, h * w).astype(np.int32) << k
    dist[_unpack(reached, h * w) == 0] = -1
    return list(np.ascontiguousarray(dist[:, :n].T))


def _increment(planes: List[np.ndarray], mask: np.ndarray) -> None:
    """Add one to every counter whose bit is set in `mask` (ripple carry over the planes)."""
    carry = mask
    for plane in planes:
        nxt = plane & carry
        plane ^= carry
        carry = nxt
        if not carry.any():
            return
    planes.append(carry)


def _unpack(words: np.ndarray, cells: int) -> np.ndarray:
    """(cells, goals) 0/1 array from a (..., goals/64) uint64 bit array."""
    as_bytes = np.ascontiguousarray(words).reshape(cells, -1).view(np.uint8)
    return np.unpackbits(as_bytes, axis=1, bitorder="little")
