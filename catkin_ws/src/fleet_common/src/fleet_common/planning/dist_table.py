"""Shortest-path distances to goals, by breadth-first search (`bfs`: C, or numpy).

`dist_array(grid, goal)[cell id]` is the number of moves from that cell to
`goal` (cell id = y * width + x), -1 where the goal cannot be reached.

Tables are kept once per map and goal (cached on the grid) as uint16, with
`UNREACHED` (65535) for cells the goal cannot be reached from: 2 bytes a cell
instead of int32's 4 and far less than a Python list's, which is what lets
1,500 agents on a 530x481 map fit in under a GB. A shortest path of 65535
moves or more is refused (`dist_codes` raises), never wrapped around.

The search (`bfs`, through `goal_distances`) runs many goals at once, one
frontier of (goal, cell) pairs per level, so the work is goals x free cells
whatever the diameter and the temporary arrays stay a few tens of MB.

These are complete tables over all grid cells, for solvers that look
anywhere (space-time A*). PIBT and LaCAM use `goal_distances` directly:
free cells only, searched as far as agents need.

`dist_lists` hands solvers' inner loops plain Python lists while all tables
together stay under `LIST_ENTRIES` entries (fastest to index); above that,
read-only memoryviews of the uint16 tables (a little slower to index, no copy).
"""
from __future__ import annotations

from typing import Dict, List, Sequence, Tuple, Union

import numpy as np

from ..grid import Coord, Grid
from .bfs import UNREACHED
from .free_cells import FreeCells
from .goal_distances import GoalDistances

#: Goals x cells up to which `dist_lists` returns Python lists (about 0.1-0.3 GB at this size).
LIST_ENTRIES = 10_000_000

DistList = Union[List[int], memoryview]


def _key(goal: Coord, kind: str = "dist") -> Tuple[str, Coord]:
    return (kind, (int(goal[0]), int(goal[1])))


def dist_array(grid: Grid, goal: Coord) -> np.ndarray:
    """Distances from every cell to `goal` (int32, length width*height, -1 unreachable)."""
    return dist_arrays(grid, [goal])[0]


def dist_arrays(grid: Grid, goals: Sequence[Coord]) -> List[np.ndarray]:
    """`dist_array` for each goal (cached; 4 bytes a cell each: prefer `dist_codes` for many goals)."""
    out = []
    for g, codes in zip(goals, dist_codes(grid, goals)):
        key = _key(g)
        if key not in grid.derived:
            table = codes.astype(np.int32)
            table[codes == UNREACHED] = -1
            table.setflags(write=False)
            grid.derived[key] = table
        out.append(grid.derived[key])
    return out  # type: ignore[return-value]


def dist_codes(grid: Grid, goals: Sequence[Coord]) -> List[np.ndarray]:
    """Distances to each goal as uint16 per cell, `UNREACHED` where unreachable (cached, read-only)."""
    missing = sorted({_key(g)[1] for g in goals if _key(g, "dist16") not in grid.derived})
    if missing:
        for goal, table in zip(missing, _complete_tables(grid, missing)):
            table.setflags(write=False)
            grid.derived[_key(goal, "dist16")] = table
    return [grid.derived[_key(g, "dist16")] for g in goals]  # type: ignore[misc]


def dist_lists(grid: Grid, goals: Sequence[Coord], unreachable: int) -> List[DistList]:
    """Distances for solvers' inner loops, indexed by cell id, unreachable cells reading `unreachable`.

    Lists while goals x cells <= `LIST_ENTRIES`; else memoryviews of uint16
    tables, where an `unreachable` above 65535 reads as 65535 (still larger
    than every distance, which is all solvers use it for).
    """
    big = len({_key(g) for g in goals}) * grid.num_cells > LIST_ENTRIES
    out: List[DistList] = []
    cache: Dict[Coord, DistList] = {}
    for g, codes in zip(goals, dist_codes(grid, goals)):
        key = _key(g)[1]
        if key not in cache:
            if not big:
                cache[key] = np.where(codes == UNREACHED, unreachable, codes).tolist()
            elif unreachable >= UNREACHED:
                cache[key] = memoryview(codes)
            else:
                cache[key] = memoryview(np.where(codes == UNREACHED, unreachable, codes).astype(np.uint16))
        out.append(cache[key])
    return out


def lower_bounds(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord]) -> Tuple[int, int]:
    """(sum, max) of start-to-goal distances: mapf-IR's lb_soc and lb_makespan.

    Read from the tables a solver left on the grid when it has them (complete
    ones, or the lazy `goal_distances`, searched only as far as the starts).
    """
    if not starts:
        return 0, 0
    if all(_key(g, "dist16") in grid.derived for g in goals):
        d = [int(t[grid.index(s)]) for s, t in zip(starts, dist_codes(grid, goals))]
    else:
        free = FreeCells.of(grid)
        d = GoalDistances.of(grid, free.to_free(goals)).distances(range(len(starts)), free.to_free(starts))
    if max(d) == UNREACHED:
        raise ValueError("a goal is unreachable from its start; check the problem first")
    return sum(d), max(d)


def _complete_tables(grid: Grid, goals: Sequence[Coord]) -> List[np.ndarray]:
    free = FreeCells.of(grid)
    rows = GoalDistances(free, free.to_free(goals))
    rows.complete()
    out = []
    for k in range(len(goals)):
        table = np.full(grid.num_cells, UNREACHED, dtype=np.uint16)
        table[free.ids] = rows.table[rows.row_of[k], :free.count]
        out.append(table)
    return out
