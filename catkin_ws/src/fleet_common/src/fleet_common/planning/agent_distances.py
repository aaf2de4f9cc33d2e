"""Each agent's distance to its goal, as PIBT's inner loop reads it: complete lists or lazy rows.

Rows are indexed by free cell (`free_cells`). While goals x free cells stays
under `LIST_ENTRIES` they are complete: Python lists (fastest to index),
unreachable cells reading F+1, or, for the C step, views of the table. Above
that they are memoryviews of the lazy rows of `goal_distances`: `cover` keeps
each agent's row exact `MARGIN` levels past its cell (a step reads distances
only there: the agent's moves, and a move further for the swap rule), growing
it by `GROW_AT_LEAST` levels at a time; reads further along a corridor go through `far`, which grows a
row on demand. Cells not searched yet read 65535, like unreachable ones.
"""
from __future__ import annotations

from typing import Any, List, Optional, Sequence

import numpy as np

from ..grid import Grid
from .bfs import UNREACHED
from .free_cells import FreeCells
from .goal_distances import COMPLETE, GoalDistances

#: Goals x free cells up to which distances are complete Python lists (about 0.1-0.3 GB).
LIST_ENTRIES = 10_000_000
#: Lazy rows are kept exact this many levels past every agent's distance.
MARGIN = 4
#: A lazy row that must grow grows by at least this many levels, so it grows rarely.
GROW_AT_LEAST = 16


class AgentDistances:
    """`dist[i][cell]`: agent i's distance from free cell `cell` to its goal (exact where `cover` says)."""

    def __init__(self, grid: Grid, goals: Sequence[int], lists: bool = True) -> None:
        """`lists=False`: complete rows are read as views of the table too (for `_native`,
        which reads the table itself; Python's few reads then skip building the lists)."""
        free = FreeCells.of(grid)
        rows = GoalDistances.of(grid, goals)
        n = len(goals)
        #: the uint16 table behind every row (unreachable and not yet searched: 65535)
        self.rows = rows
        self.lazy: Optional[GoalDistances] = None
        if len(rows.searches) * free.count <= LIST_ENTRIES:
            rows.complete()
            if lists:
                f = free.count
                body = rows.table[:, :f].astype(np.int64)
                table = np.where(body == UNREACHED, f + 1, body).tolist()
                self.dist: List[Any] = [table[r] for r in rows.row_of]
            else:
                self.dist = rows.views()
            #: per agent, the largest distance at its cell for which every read of a step is exact
            self.limit = [COMPLETE] * n
        else:
            self.lazy = rows
            self.dist = rows.views()
            self.limit = [rows.radius(i) - MARGIN for i in range(n)]
            # the same, as arrays: which rows to check is one numpy expression over all agents
            self._rows = np.asarray(rows.row_of, dtype=np.int64)
            self._limits = np.asarray(self.limit, dtype=np.int64)

    def cover(self, q: Sequence[int], agents: Optional[Sequence[int]] = None) -> None:
        """Make the agents' rows (default: all) exact around their cells in `q`.

        A no-op for complete tables. Agents resting on their goals need no
        check: everything within MARGIN of the goal is known from the start.
        """
        if self.lazy is None:
            return
        dist, limit = self.dist, self.limit
        cells = np.asarray(q, dtype=np.int64)
        if agents is None:
            late = self.lazy.table[self._rows, cells] > self._limits
            short = np.nonzero(late)[0].tolist()
        else:
            which = np.asarray(agents, dtype=np.int64)
            late = self.lazy.table[self._rows[which], cells[which]] > self._limits[which]
            short = which[late].tolist()
        if short:
            lazy = self.lazy
            lazy.cover(short, [q[i] for i in short], MARGIN)
            grow = [i for i in short if lazy.radius(i) - MARGIN < dist[i][q[i]] + GROW_AT_LEAST]
            if grow:  # a little further than needed now: the agent is heading out
                lazy.cover(grow, [q[i] for i in grow], MARGIN + GROW_AT_LEAST)
            for i in short:
                limit[i] = self._limits[i] = lazy.radius(i) - MARGIN

    def far(self, i: int, cell: int) -> int:
        """Agent i's distance at `cell`, growing its lazy row if it does not reach that far yet."""
        d = self.dist[i][cell]
        if d > self.limit[i] + MARGIN and self.lazy is not None and self.lazy.radius(i) < COMPLETE:
            self.lazy.cover([i], [cell], 0)
            self.limit[i] = self._limits[i] = self.lazy.radius(i) - MARGIN
            d = self.dist[i][cell]
        return d
