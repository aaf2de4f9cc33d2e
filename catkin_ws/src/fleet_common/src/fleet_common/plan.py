"""A plan: one timed grid path per agent, all of the same length.

`positions[t, i]` is agent i's cell `(x, y)` (base frame, see `grid`) at time
step t, for t = 0..makespan, exactly as mapf-IR lists configurations: an agent
that arrived early is repeated at its goal. Stored as one int32 array so that
plans of thousands of agents and steps validate with numpy, not Python loops.
"""
from __future__ import annotations

import enum
from typing import List, Optional, Sequence

import numpy as np

from .grid import Coord


class Orientation(enum.IntEnum):
    """Heading at a cell, as mapf-visualizer's `(x,y,X_PLUS)` suffix (base frame)."""

    X_PLUS = 0
    Y_PLUS = 1
    X_MINUS = 2
    Y_MINUS = 3

    def flipped_y(self) -> "Orientation":
        """The same heading seen in a frame whose y axis points the other way."""
        if self is Orientation.Y_PLUS:
            return Orientation.Y_MINUS
        if self is Orientation.Y_MINUS:
            return Orientation.Y_PLUS
        return self


#: `orientations` value for "no heading given".
NO_ORIENTATION = -1


class Plan:
    """Timed grid paths per agent (base frame)."""

    __slots__ = ("positions", "orientations")

    def __init__(self, positions: np.ndarray, orientations: Optional[np.ndarray] = None) -> None:
        positions = np.asarray(positions, dtype=np.int32)
        if positions.ndim != 3 or positions.shape[2] != 2 or positions.shape[0] < 1:
            raise ValueError(
                "positions must have shape (steps >= 1, agents, 2), got {}".format(positions.shape)
            )
        if orientations is not None:
            orientations = np.asarray(orientations, dtype=np.int8)
            if orientations.shape != positions.shape[:2]:
                raise ValueError("orientations must have shape {}".format(positions.shape[:2]))
        self.positions = positions
        self.orientations = orientations

    @classmethod
    def from_paths(cls, paths: Sequence[Sequence[Coord]]) -> "Plan":
        """From per-agent paths of any lengths; shorter ones wait at their last cell."""
        if not paths:
            return cls(np.zeros((1, 0, 2), dtype=np.int32))
        if any(len(p) == 0 for p in paths):
            raise ValueError("every path needs at least its start cell")
        steps = max(len(p) for p in paths)
        arr = np.empty((steps, len(paths), 2), dtype=np.int32)
        for i, path in enumerate(paths):
            arr[: len(path), i] = path
            arr[len(path):, i] = path[-1]
        return cls(arr)

    @classmethod
    def from_configs(cls, configs: Sequence[Sequence[Coord]], num_agents: int = 0) -> "Plan":
        """From configurations (one list of cells per time step)."""
        if not configs:
            raise ValueError("a plan needs at least one configuration")
        arr = np.asarray(configs, dtype=np.int32).reshape(len(configs), -1, 2)
        return cls(arr)

    @property
    def makespan(self) -> int:
        return int(self.positions.shape[0]) - 1

    @property
    def num_agents(self) -> int:
        return int(self.positions.shape[1])

    def config(self, t: int) -> List[Coord]:
        """Every agent's cell at step t (clamped to the last step, agents rest at goals)."""
        t = min(max(t, 0), self.makespan)
        return [(int(x), int(y)) for x, y in self.positions[t].tolist()]

    def path(self, agent: int) -> List[Coord]:
        return [(int(x), int(y)) for x, y in self.positions[:, agent].tolist()]

    @property
    def starts(self) -> List[Coord]:
        return self.config(0)

    @property
    def goals(self) -> List[Coord]:
        return self.config(self.makespan)

    def move_counts(self) -> np.ndarray:
        """Per agent, its moves (steps at which it changes cells)."""
        pos = self.positions
        return (pos[1:] != pos[:-1]).any(axis=2).sum(axis=0).astype(np.int64)

    def path_costs(self) -> np.ndarray:
        """Per agent, the step from which it stays at its final cell (mapf-IR's count)."""
        n = self.num_agents
        if self.makespan <= 0 or n == 0:
            return np.zeros(n, dtype=np.int64)
        final = self.positions[-1]
        away = np.any(self.positions != final[None, :, :], axis=2)  # (T+1, N)
        # last step at which the agent is not at its final cell, plus one
        rev = away[::-1]
        has_away = rev.any(axis=0)
        last_away = self.makespan - np.argmax(rev, axis=0)
        return np.where(has_away, last_away + 1, 0).astype(np.int64)

    @property
    def soc(self) -> int:
        """Sum of costs as mapf-IR counts it (0 when makespan <= 0)."""
        return int(self.path_costs().sum())

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Plan):
            return NotImplemented
        if not np.array_equal(self.positions, other.positions):
            return False
        a, b = self.orientations, other.orientations
        if a is None or b is None:
            return a is None and b is None
        return bool(np.array_equal(a, b))

    def __repr__(self) -> str:
        return "Plan(agents={}, makespan={})".format(self.num_agents, self.makespan)
