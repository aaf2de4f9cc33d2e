"""What the execution engine refuses, and why.

`PlanError`: the plan cannot be executed safely by real robots (two robots in
one cell, a swap, a rotation, a jump); raised before anything runs.
`EventError`: a progress report contradicts what the engine knows (a robot
completing an action it was never sent); raised and nothing changes, like
h11's protocol errors. `UnknownStrategyError` lists the valid names.
"""
from __future__ import annotations

from typing import Optional, Sequence, Tuple

from ..errors import FleetError
from ..grid import Coord

#: PlanError kinds, stable strings that tests and tools may match on.
VERTEX = "vertex-conflict"
SWAP = "swap"
ROTATION = "rotation"
JUMP = "non-adjacent-move"


class PlanError(FleetError, ValueError):
    """A plan the engine will not execute; names the step, the agents and the cells."""

    def __init__(self, message: str, kind: str, step: int, agents: Sequence[int],
                 cells: Sequence[Coord] = ()) -> None:
        super().__init__(message)
        self.kind = kind
        self.step = step
        self.agents: Tuple[int, ...] = tuple(agents)
        self.cells: Tuple[Coord, ...] = tuple(cells)


class EventError(FleetError, ValueError):
    """A progress event the engine cannot accept in its current state (it is ignored)."""

    def __init__(self, message: str, agent: Optional[int] = None) -> None:
        super().__init__(message)
        self.agent = agent


class UnknownStrategyError(FleetError, ValueError):
    """A strategy name (or setting) that is not registered."""
