"""A plan as what robots actually do: per robot, a sequence of moves.

A `Plan` says where every agent is at every step; a robot only needs its
moves. Action k of robot r is its k-th move, from `src` to the adjacent `dst`,
made in plan step `step` (from `positions[step]` to `positions[step + 1]`).
Waits are not actions: a robot that waits in the plan simply has no action
for that step, and the strategy decides how long it really waits.

The table keeps every action in flat numpy arrays, robot-major and in plan
order (robot r's actions are `first[r] .. first[r + 1] - 1`), so that a
1,500-robot, 1,000-step plan becomes actions in a few vectorised operations.
Cells are numbered `(y - y0) * width + (x - x0)` over the plan's bounding box:
the engine needs no grid, only the cells the plan uses.
"""
from __future__ import annotations

from typing import Callable, List, NamedTuple

import numpy as np

from ..grid import Coord
from ..plan import Plan
from .errors import JUMP, PlanError


def _identity(c: Coord) -> Coord:
    return c


class Action(NamedTuple):
    """One move of one robot: its `index`-th action, made in plan step `step`."""

    agent: int
    index: int
    step: int
    src: Coord
    dst: Coord


class ActionTable:
    """Every robot's moves in a plan, as flat arrays (see the module docstring)."""

    __slots__ = ("agent", "step", "src", "dst", "first", "start_cell", "x0", "y0", "width",
                 "makespan")

    def __init__(self, agent: np.ndarray, step: np.ndarray, src: np.ndarray, dst: np.ndarray,
                 first: np.ndarray, start_cell: np.ndarray, x0: int, y0: int, width: int,
                 makespan: int) -> None:
        self.agent = agent
        self.step = step
        self.src = src
        self.dst = dst
        self.first = first
        self.start_cell = start_cell
        self.x0 = x0
        self.y0 = y0
        self.width = width
        self.makespan = makespan

    @classmethod
    def from_plan(cls, plan: Plan, show: Callable[[Coord], Coord] = _identity) -> "ActionTable":
        """The moves of `plan`; a move to a non-adjacent cell raises `PlanError`.

        `show` turns base cells into the coordinates messages should use (give
        `grid.flip_y` to speak in a mapf-IR file's own frame).
        """
        pos = plan.positions.astype(np.int64)
        steps, n = pos.shape[0], pos.shape[1]
        if n == 0:
            empty = np.zeros(0, dtype=np.int64)
            return cls(empty, empty, empty, empty, np.zeros(1, dtype=np.int64), empty, 0, 0, 1,
                       plan.makespan)
        x0, y0 = int(pos[:, :, 0].min()), int(pos[:, :, 1].min())
        width = int(pos[:, :, 0].max()) - x0 + 1
        ids = (pos[:, :, 1] - y0) * width + (pos[:, :, 0] - x0)  # (steps, n)
        moving = ids[1:] != ids[:-1]  # (steps - 1, n)
        agent, step = np.nonzero(moving.T)  # robot-major, steps ascending within a robot
        dist = np.abs(pos[step + 1, agent] - pos[step, agent]).sum(axis=1)
        bad = np.nonzero(dist != 1)[0]
        if bad.size:
            a = int(bad[0])
            r, t = int(agent[a]), int(step[a])
            here = (int(pos[t, r, 0]), int(pos[t, r, 1]))
            there = (int(pos[t + 1, r, 0]), int(pos[t + 1, r, 1]))
            raise PlanError("agent {} jumps from {} at t={} to {} at t={}: robots move between "
                            "neighbouring cells only".format(r, show(here), t, show(there), t + 1),
                            JUMP, t, (r,), (here, there))
        first = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(moving.sum(axis=0), out=first[1:])
        return cls(agent.astype(np.int64), step.astype(np.int64), ids[step, agent],
                   ids[step + 1, agent], first, ids[0].copy(), x0, y0, width, steps - 1)

    @property
    def num_agents(self) -> int:
        return int(self.first.shape[0]) - 1

    @property
    def num_actions(self) -> int:
        return int(self.agent.shape[0])

    def coord(self, cell: int) -> Coord:
        """The base-grid cell of cell id `cell`."""
        y, x = divmod(int(cell), self.width)
        return (x + self.x0, y + self.y0)

    def count(self, agent: int) -> int:
        """How many actions robot `robot` has."""
        return int(self.first[agent + 1] - self.first[agent])

    def action(self, agent: int, index: int) -> Action:
        a = int(self.first[agent]) + index
        if not 0 <= index < self.count(agent):
            raise IndexError("agent {} has no action {} (it has {})".format(
                agent, index, self.count(agent)))
        return self.action_at(a)

    def action_at(self, a: int) -> Action:
        """The action with flat index `a`."""
        r = int(self.agent[a])
        return Action(r, a - int(self.first[r]), int(self.step[a]), self.coord(self.src[a]),
                      self.coord(self.dst[a]))

    def actions_of(self, agent: int) -> List[Action]:
        return [self.action_at(a) for a in range(int(self.first[agent]), int(self.first[agent + 1]))]

    def start(self, agent: int) -> Coord:
        return self.coord(self.start_cell[agent])

    def goal(self, agent: int) -> Coord:
        """Where the robot ends: the target of its last action, else its start."""
        end = int(self.first[agent + 1])
        return self.coord(self.dst[end - 1]) if end > int(self.first[agent]) else self.start(agent)
