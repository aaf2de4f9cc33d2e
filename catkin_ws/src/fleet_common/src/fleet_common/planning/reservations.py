"""What one agent's space-time search must avoid: cells and moves taken at given steps.

Prioritized planning fills it with the paths of agents planned before; CBS
with one agent's constraints. Keys are plain ints for fast set lookups:
`t * V + cell` for a cell at step t, `(t * V + a) * V + b` for the move a->b
arriving at step t (V = number of cells). An agent that has finished its path
is *parked*: it holds its last cell from then on, forever.

Unless `rotations` is set, the reserved paths' moves are kept as chains:
`follow[t * V + a] = b` when the agent at `a` at step t is at `b` at step t + 1.
A new move a->b in that step closes a rotation exactly when following the
chain from b (b's occupant moves to c, c's occupant moves to ...) leads back
to a: `closes_cycle` says so, for space-time A*.
"""
from __future__ import annotations

from typing import Dict, List, Sequence, Set

#: `parked` value of a cell nobody parks on.
NEVER = 1 << 62


class Reservations:
    """Forbidden cells and moves over time, for one space-time search."""

    __slots__ = ("num_cells", "vertex", "edge", "parked", "last", "horizon", "follow", "rotations")

    def __init__(self, num_cells: int, rotations: bool = False) -> None:
        self.num_cells = num_cells
        self.rotations = rotations
        #: t * V + cell -> the cell its reserved occupant moves to at step t + 1 (moves only)
        self.follow: Dict[int, int] = {}
        self.vertex: Set[int] = set()
        self.edge: Set[int] = set()
        #: per cell, the first step from which an agent stays there for good (NEVER: none)
        self.parked: List[int] = [NEVER] * num_cells
        #: cell -> last step at which the cell is reserved (a goal reached earlier cannot be kept)
        self.last: Dict[int, int] = {}
        #: last step with any reservation; after it only parked agents matter
        self.horizon = -1

    def block_cell(self, cell: int, t: int) -> None:
        self.vertex.add(t * self.num_cells + cell)
        if self.last.get(cell, -1) < t:
            self.last[cell] = t
        if t > self.horizon:
            self.horizon = t

    def block_move(self, frm: int, to: int, t: int) -> None:
        """Forbid moving from `frm` to `to` between steps t-1 and t."""
        v = self.num_cells
        self.edge.add((t * v + frm) * v + to)
        if t > self.horizon:
            self.horizon = t

    def park(self, cell: int, t: int) -> None:
        if t < self.parked[cell]:
            self.parked[cell] = t

    def add_path(self, path: Sequence[int]) -> None:
        """Reserve an agent's path (cell ids per step); it parks at its last cell."""
        end = len(path) - 1
        chains = not self.rotations
        for t in range(end):
            self.block_cell(path[t], t)
            if t > 0 and path[t] != path[t - 1]:
                self.block_move(path[t], path[t - 1], t)  # the reverse move would be a swap
            if chains and path[t + 1] != path[t]:
                self.follow[t * self.num_cells + path[t]] = path[t + 1]
        if end > 0 and path[end] != path[end - 1]:
            self.block_move(path[end], path[end - 1], end)
        self.park(path[end], end)

    def closes_cycle(self, frm: int, to: int, t: int) -> bool:
        """Would moving `frm` -> `to` from step t to t + 1 close a rotation with reserved moves?"""
        base = t * self.num_cells
        follow = self.follow
        cell = follow.get(base + to)
        for _ in range(len(follow)):  # reserved moves have no cycle of their own: the chain ends
            if cell is None:
                return False
            if cell == frm:
                return True
            cell = follow.get(base + cell)
        return False
