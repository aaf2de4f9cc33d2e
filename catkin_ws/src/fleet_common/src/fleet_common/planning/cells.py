"""Cell ids for solvers' inner loops, and plans built back from them.

Solvers work on integer cell ids (`y * width + x`, as `Grid.index`) held in
plain Python lists: list indexing beats numpy on single elements by an order
of magnitude. Only the finished plan goes back to coordinates, in one numpy
operation.
"""
from __future__ import annotations

from typing import List, Sequence

import numpy as np

from ..grid import Coord, Grid
from ..plan import Plan

#: "No cell" in id lists (next positions not chosen yet, empty reservation slots).
NIL = -1


def to_ids(grid: Grid, cells: Sequence[Coord]) -> List[int]:
    w = grid.width
    return [int(c[1]) * w + int(c[0]) for c in cells]


def moves(grid: Grid) -> List[List[int]]:
    """Per cell id, the cell itself followed by its free neighbours (wait is a move)."""
    return [[v] + nbrs if nbrs or grid.free.flat[v] else [] for v, nbrs in enumerate(grid.adjacency())]


def plan_from_configs(grid: Grid, configs: Sequence[Sequence[int]], num_agents: int) -> Plan:
    """A Plan from per-step lists of cell ids (all of length `num_agents`)."""
    if num_agents == 0:
        return Plan(np.zeros((1, 0, 2), dtype=np.int32))
    ids = np.asarray(configs, dtype=np.int64).reshape(len(configs), num_agents)
    pos = np.stack([ids % grid.width, ids // grid.width], axis=2)
    return Plan(pos.astype(np.int32))


def plan_from_paths(grid: Grid, paths: Sequence[Sequence[int]]) -> Plan:
    """A Plan from per-agent id paths of any length; short ones wait at their end."""
    if not paths:
        return Plan(np.zeros((1, 0, 2), dtype=np.int32))
    steps = max(len(p) for p in paths)
    ids = np.empty((steps, len(paths)), dtype=np.int64)
    for i, p in enumerate(paths):
        ids[: len(p), i] = p
        ids[len(p):, i] = p[-1]
    return plan_from_configs(grid, ids, len(paths))
