"""The remaining path of every agent, as the corners a polyline needs.

Drawing "the remaining path" as every future cell would change every agent's
polyline at every time step. Geometrically a path is a few straight runs:
only the cells where the direction changes (and the final cell) are needed,
and the drawn path changes only when an agent passes one of them. For each
agent this keeps those corner cells and the time step the agent reaches
each; `next_index(t)` says, for all agents at once, which corner is next.
Waiting does not make a corner; turning back does.
"""
from __future__ import annotations

from typing import List

import numpy as np

from fleet_common.plan import Plan


class PathCorners:
    """Corners of every agent's path: `cells[i, :count[i]]` reached at `times[i, :count[i]]`."""

    def __init__(self, plan: Plan) -> None:
        n = plan.num_agents
        per_cells: List[np.ndarray] = []
        per_times: List[np.ndarray] = []
        for i in range(n):
            path = plan.positions[:, i]
            arrive = np.concatenate(([0], np.nonzero(np.any(path[1:] != path[:-1], axis=1))[0] + 1))
            cells = path[arrive]
            keep = np.zeros(len(cells), dtype=bool)
            keep[-1] = True  # the final cell always ends the polyline
            if len(cells) > 2:
                d = np.diff(cells, axis=0)
                keep[1:-1] = np.any(d[1:] != d[:-1], axis=1)  # the direction changes there
            per_cells.append(cells[keep])
            per_times.append(arrive[keep].astype(np.float64))
        width = max((len(c) for c in per_cells), default=1)
        self.count = np.array([len(c) for c in per_cells], dtype=np.int64)
        self.cells = np.zeros((n, width, 2), dtype=np.int64)
        self.times = np.full((n, width), np.inf)
        for i, (c, t) in enumerate(zip(per_cells, per_times)):
            self.cells[i, :len(c)] = c
            self.times[i, :len(t)] = t

    def next_index(self, time: float) -> np.ndarray:
        """(N,) index of each agent's next corner strictly ahead of `time` (count: none left)."""
        return (self.times <= time + 1e-9).sum(axis=1)

    def targets(self, index: np.ndarray) -> np.ndarray:
        """(N, 2) the cell each agent heads for in a straight line: its next corner, or its last cell."""
        k = np.minimum(index, self.count - 1)
        return self.cells[np.arange(len(k)), k]

    def ahead(self, agent: int, index: int, limit: int) -> np.ndarray:
        """The next `limit` corners of `agent` from `index` on, (L, 2)."""
        return self.cells[agent, index:min(int(self.count[agent]), index + limit)]
