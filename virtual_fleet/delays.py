"""The delay model (fleet_common.delays) in the virtual fleet's own seconds.

The model speaks in nominal moves; the fleet's nominal move is one cell at its
driving speed (`nominal_s` seconds, 2 s at the default 0.5 cells/s). A virtual
robot draws the fate of each move as it starts it, from its own
`random.Random` (so a `--seed` makes a run repeatable), with the same draw the
simulator uses for a whole plan at once. Per-robot terms (`robot=R:F`, BTPG's
delay-prone robots) go by the robot's index in the definitions, as plan agents do.

Paired with the simulator (`paired_with`): robot i's k-th drive takes the
uniform variates the simulator (`delays.simulator_fates`, same model and seed)
gives plan agent i's k-th move, so its fate is that move's fate, in seconds;
drives past the plan's moves draw from the robot's own generator. An engine
run and a run through the real chain then meet the same delays, move by move.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from fleet_common.delays import DelayModel, draw_fates, robot_profile
from fleet_common.delays.draw import COLUMNS

__all__ = ["FleetDelays", "MoveFate"]


@dataclass(frozen=True)
class MoveFate:
    """What happens to one move: extra wait, speed factor, a stall, a dropout (seconds)."""

    start_delay: float = 0.0
    slowdown: float = 1.0
    stall: float = 0.0              # seconds of stall, 0: none
    stall_at: float = 0.5           # where, as a fraction of the move
    dropout_at: Optional[float] = None  # fraction of the move, None: no dropout


class FleetDelays:
    """`model` for a fleet of `num_robots` whose nominal move takes `nominal_s` seconds;
    `for_robot(i)` gives robot i its own view (its profile)."""

    def __init__(self, model: Optional[DelayModel] = None, nominal_s: float = 2.0, seed: int = 0,
                 num_robots: int = 0, index: int = 0, paired: Optional[Sequence[int]] = None) -> None:
        self.model = model or DelayModel()
        self.nominal_s = nominal_s
        self.seed = seed
        self.num_robots = num_robots
        self.index = index
        #: moves per plan agent, for drawing as the simulator does (`paired_with`); None: own draws
        self.paired = None if paired is None else list(paired)
        factor, prone = robot_profile(self.model, seed, max(num_robots, index + 1))
        self._factor, self._prone = factor[index:index + 1], prone[index:index + 1]
        self._rows: Optional[np.ndarray] = None
        if self.paired is not None and index < len(self.paired):
            first = sum(self.paired[:index])
            u = np.random.default_rng(seed).random((sum(self.paired), COLUMNS))  # as simulator_fates
            self._rows = u[first:first + self.paired[index]]
        self._drawn = 0

    def paired_with(self, moves: Sequence[int]) -> "FleetDelays":
        """This model drawing as the simulator does for a plan whose agent i makes `moves[i]` moves
        (robot index i is agent i)."""
        return FleetDelays(self.model, self.nominal_s, self.seed, self.num_robots, self.index, moves)

    @property
    def dropout_p(self) -> float:
        return self.model.dropout_p

    @property
    def dropout_s(self) -> float:
        """Seconds a robot that drops out stays away."""
        return self.model.dropout_moves * self.nominal_s

    def for_robot(self, index: int) -> "FleetDelays":
        return FleetDelays(self.model, self.nominal_s, self.seed, self.num_robots, index, self.paired)

    def draw(self, rng: random.Random) -> MoveFate:
        """The fate of this robot's next move."""
        rows, k = self._rows, self._drawn
        self._drawn += 1
        if rows is not None and k < len(rows):
            u = rows[k:k + 1]
        else:
            u = np.array([[rng.random() for _ in range(COLUMNS)]])
        f = draw_fates(self.model, u, self._factor, self._prone)
        s = self.nominal_s
        return MoveFate(float(f.wait[0]) * s, float(f.slowdown[0]), float(f.stall[0]) * s,
                        float(f.stall_at[0]), float(f.dropout_at[0]) if f.dropout[0] > 0 else None)
