"""The free cells of a grid numbered 0..F-1: the id space of PIBT, LaCAM and the distance search.

Large maps are mostly walls (brc202d: 43,151 free cells of 254,930), so
tables and occupancy lists indexed by free cell are 6x smaller than ones
indexed by grid cell (`y * width + x`, as `Grid.index`) and scans touch only
cells a robot can be on. `FreeCells.of(grid)` is computed once per grid.
`neighbours` has one extra row, F, the "no cell" sentinel: a blocked or
off-map neighbour reads F, and F's own neighbours are F.
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import numpy as np

from ..grid import Coord, Grid
from ..plan import Plan

_KEY = "free_cells"
#: Neighbour directions, in the order of `Grid.adjacency` (solvers break ties by this order).
_STEPS = ((-1, 0), (1, 0), (0, -1), (0, 1))


class FreeCells:
    """Free cell k is grid cell `ids[k]`; `index[grid cell]` is k, or -1 for a blocked cell."""

    def __init__(self, grid: Grid, free: Optional[np.ndarray] = None) -> None:
        """The free cells of `grid`, or those of the mask `free` (e.g. with robots as walls)."""
        self.grid = grid
        self.ids = np.flatnonzero((grid.free if free is None else free).ravel())
        self.count = int(self.ids.size)
        self.index = np.full(grid.num_cells, -1, dtype=np.int64)
        self.index[self.ids] = np.arange(self.count)
        w, h = grid.width, grid.height
        x, y = self.ids % w, self.ids // w
        nb = np.full((self.count + 1, 4), self.count, dtype=np.int32)
        for d, (dx, dy) in enumerate(_STEPS):
            nx, ny = x + dx, y + dy
            inside = (nx >= 0) & (nx < w) & (ny >= 0) & (ny < h)
            found = np.full(self.count, -1, dtype=np.int64)
            found[inside] = self.index[(ny * w + nx)[inside]]
            nb[:self.count, d] = np.where(found >= 0, found, self.count)
        self.neighbours = nb
        self._adjacency: List[List[int]] = []

    @staticmethod
    def of(grid: Grid) -> "FreeCells":
        cached = grid.derived.get(_KEY)
        if cached is None:
            cached = grid.derived[_KEY] = FreeCells(grid)
        return cached  # type: ignore[return-value]

    def adjacency(self) -> List[List[int]]:
        """Per free cell, its free neighbours (plain lists: solvers' inner loops index them)."""
        if not self._adjacency:
            f = self.count
            self._adjacency = [[u for u in row if u != f] for row in self.neighbours[:f].tolist()]
        return self._adjacency

    def moves(self) -> List[List[int]]:
        """Per free cell, the cell itself followed by its free neighbours (wait is a move)."""
        return [[v] + nbrs for v, nbrs in enumerate(self.adjacency())]

    def to_free(self, cells: Sequence[Coord]) -> List[int]:
        """Free-cell ids of coordinates (which must be free cells)."""
        w = self.grid.width
        return [int(self.index[int(c[1]) * w + int(c[0])]) for c in cells]

    def plan(self, configs: Sequence[Sequence[int]], num_agents: int) -> Plan:
        """A Plan from per-step lists of free-cell ids (all of length `num_agents`)."""
        if num_agents == 0:
            return Plan(np.zeros((1, 0, 2), dtype=np.int32))
        ids = self.ids[np.asarray(configs, dtype=np.int64).reshape(len(configs), num_agents)]
        w = self.grid.width
        return Plan(np.stack([ids % w, ids // w], axis=2).astype(np.int32))
