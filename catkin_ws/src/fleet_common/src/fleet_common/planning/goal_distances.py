"""Distances from every free cell to each agent's goal, searched only as far as solvers ask.

PIBT and LaCAM read an agent's distances only around where the agent is:
its cell's neighbours, and corridors ahead of it. So each goal's breadth-first
search (`bfs`) stops a few levels past the agent's start, and is resumed when
an agent comes near the edge of what is known (`cover`). On brc202d with
1,500 agents that is half the (goal, cell) pairs of complete tables, and
the table is indexed by free cell (`free_cells`), 130 MB instead of 765 MB.

Cells not searched yet read `UNREACHED`, like cells that cannot reach the
goal; `radius(agent)` says how far a row is exact. Tables are cached per grid
and goal set, so the lower bounds after a solve reuse them.
"""
from __future__ import annotations

from typing import Dict, List, Sequence, Tuple

import numpy as np

from ..grid import Grid
from .bfs import UNREACHED, Search, grow
from .free_cells import FreeCells

#: "Searched to the end": the radius of a complete row.
COMPLETE = 1 << 30


class GoalDistances:
    """One uint16 row per distinct goal over the free cells (+ the sentinel column)."""

    def __init__(self, free: FreeCells, goals: Sequence[int]) -> None:
        self.free = free
        rows: Dict[int, int] = {}
        for g in goals:
            rows.setdefault(g, len(rows))
        self.row_of = [rows[g] for g in goals]
        self.table = np.full((len(rows), free.count + 1), UNREACHED, dtype=np.uint16)
        self.table[:, free.count] = 0  # the sentinel never looks unreached
        self.searches: List[Search] = []
        self.goal_cells = list(rows)  # per row, its goal
        for g, r in rows.items():
            if g < 0:  # a blocked goal (not a free cell) reaches nothing
                self.searches.append(Search(np.zeros(0, dtype=np.int64)))
                continue
            self.table[r, g] = 0
            self.searches.append(Search(np.array([g], dtype=np.int64)))

    @staticmethod
    def of(grid: Grid, goals: Sequence[int]) -> "GoalDistances":
        """The cached tables of `grid` for these goals (free-cell ids, one per agent)."""
        key: Tuple[str, Tuple[int, ...]] = ("goal_distances", tuple(goals))
        found = grid.derived.get(key)
        if found is None:
            found = grid.derived[key] = GoalDistances(FreeCells.of(grid), goals)
        return found  # type: ignore[return-value]

    def views(self) -> List[memoryview]:
        """Per agent its row, indexed by free cell; reads follow the row as it grows."""
        return [memoryview(self.table[r]) for r in self.row_of]

    def radius(self, agent: int) -> int:
        """Distances up to this are exact in the agent's row (`COMPLETE` once searched to the end)."""
        s = self.searches[self.row_of[agent]]
        return COMPLETE if s.done else s.level

    def cover(self, agents: Sequence[int], cells: Sequence[int], margin: int) -> None:
        """Grow each agent's row until it is exact `margin` levels past its distance at `cells[k]`."""
        wanted: Dict[int, int] = {}
        for a, c in zip(agents, cells):
            r = self.row_of[a]
            if r not in wanted and not self._covers(r, c, margin):
                wanted[r] = c
        if not wanted:  # every row already reaches that far (e.g. the lower bounds after a solve)
            return
        # searches of one batch advance together: put those that will stop at similar levels
        # side by side (by their Manhattan distance, a lower bound of where they stop)
        w = self.free.grid.width
        ids, goal = self.free.ids, self.goal_cells
        rows = sorted(wanted, key=lambda r: abs(ids[wanted[r]] % w - ids[goal[r]] % w)
                      + abs(ids[wanted[r]] // w - ids[goal[r]] // w))
        grow(self.table, self.free, [self.searches[r] for r in rows], rows,
             [COMPLETE] * len(rows), targets=[wanted[r] for r in rows], margin=margin)
        rest = [(a, c) for a, c in zip(agents, cells) if not self._covers(self.row_of[a], c, margin)]
        if rest:  # agents sharing a goal asked for more than the first of them
            self.cover([a for a, _ in rest], [c for _, c in rest], margin)

    def _covers(self, row: int, cell: int, margin: int) -> bool:
        """Is `row` exact `margin` levels past its distance at `cell` (or searched to the end)?"""
        search = self.searches[row]
        if search.done:
            return True
        d = int(self.table[row, cell])
        return d != UNREACHED and search.level >= d + margin

    def complete(self) -> None:
        """Search every row to the end."""
        rows = list(range(len(self.searches)))
        grow(self.table, self.free, self.searches, rows, [COMPLETE] * len(rows))

    def distances(self, agents: Sequence[int], cells: Sequence[int]) -> List[int]:
        """Exact distance of each agent's cell to its goal (`UNREACHED` when it cannot reach it)."""
        self.cover(agents, cells, 0)
        return [int(self.table[self.row_of[a], c]) for a, c in zip(agents, cells)]
