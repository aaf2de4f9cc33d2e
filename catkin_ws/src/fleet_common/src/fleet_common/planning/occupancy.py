"""Who is where at each step of a plan under repair, looked up one step at a time.

The plan is a numpy array of cell ids, shape (steps, agents) (cell id = y *
width + x), changed in place by the repair. The searches of a repair ask
about a few steps at a time: which agent stands on a cell (`at`), where an
agent stands (`row`). Those lookups are Python dicts and lists built for a
step the first time it is asked about and kept up to date by `put`, so a
repair costs what its searches touch, not the plan's size. An agent taken
off the board for a search stands on `AWAY` (no cell). After the plan's last
step everyone stays where they are: `row(t)` and `at(t)` for a later t are
those of the last step.
"""
from __future__ import annotations

from typing import Dict, List, Sequence

import numpy as np

#: The cell of an agent taken off the board while it is re-planned.
AWAY = -1


class Occupancy:
    """A plan's cell ids (`ids`, shape (steps, agents), changed in place) and per-step lookups."""

    __slots__ = ("ids", "_rows", "_at")

    def __init__(self, ids: np.ndarray) -> None:
        self.ids = ids
        self._rows: Dict[int, List[int]] = {}
        self._at: Dict[int, Dict[int, int]] = {}

    @property
    def last(self) -> int:
        """The plan's last step."""
        return self.ids.shape[0] - 1

    def row(self, t: int) -> List[int]:
        """Each agent's cell at step t (`AWAY` for an agent off the board)."""
        if t > self.last:
            t = self.last
        found = self._rows.get(t)
        if found is None:
            found = self._rows[t] = self.ids[t].tolist()
        return found

    def at(self, t: int) -> Dict[int, int]:
        """cell -> the agent on it at step t."""
        if t > self.last:
            t = self.last
        found = self._at.get(t)
        if found is None:
            row = self.row(t)
            found = self._at[t] = {c: a for a, c in enumerate(row) if c != AWAY}
        return found

    def put(self, agent: int, t0: int, cells: Sequence[int]) -> None:
        """Agent `agent` on `cells[k]` at step t0 + k (`AWAY`: off the board); within the plan's steps."""
        end = t0 + len(cells)
        self.ids[t0:end, agent] = cells
        for t in range(t0, end):
            row = self._rows.get(t)
            if row is None:
                continue  # never looked at: built from `ids` when it is
            old, new = row[agent], cells[t - t0]
            if old == new:
                continue
            row[agent] = new
            at = self._at.get(t)
            if at is not None:
                if old != AWAY and at.get(old) == agent:
                    del at[old]
                if new != AWAY:
                    at[new] = agent

    def replace_from(self, t0: int, tail: np.ndarray) -> None:
        """Everything from step t0 on becomes `tail` (shape (steps, agents))."""
        self.ids = np.concatenate([self.ids[:t0], tail])
        self.forget(t0)

    def forget(self, t0: int) -> None:
        """Drop the lookups of steps t0 and later (the plan changed there behind their back)."""
        for cache in (self._rows, self._at):
            for t in [t for t in cache if t >= t0]:
                del cache[t]

    def is_rotation(self, t: int, cycle: Sequence[int]) -> bool:
        """Do `cycle`'s agents, from step t to t + 1, each enter the cell the next one leaves?"""
        here, there = self.row(t), self.row(t + 1)
        k = len(cycle)
        return all(there[cycle[i]] == here[cycle[(i + 1) % k]] != here[cycle[i]] for i in range(k))
