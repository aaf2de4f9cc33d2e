"""FleetState: where every agent is at one moment, the one thing the views draw.

The plan player computes it from a plan and a clock; the live console will get
it from the manager. Positions are base-frame cell coordinates as floats (the
cell centre of (x, y) is exactly (x, y)), so a robot between two cells, or
anywhere Vicon puts it, is drawn where it is. `time` is in plan steps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from fleet_common.plan import Plan


@dataclass(frozen=True)
class FleetState:
    """A snapshot of the fleet; `positions` is (N, 2) float, base frame."""

    time: float
    positions: np.ndarray
    #: (N,) degrees in the base frame, 0 = +x, counter-clockwise; NaN where unknown; None if no agent has one
    headings: Optional[np.ndarray] = None
    #: increases with every new state (the manager's Lamport version when live)
    version: int = 0

    @property
    def step(self) -> int:
        """The plan step the fleet has last reached."""
        return int(math.floor(self.time))

    @property
    def num_agents(self) -> int:
        return int(self.positions.shape[0])


#: Heading of each `fleet_common.plan.Orientation` value, degrees (X_PLUS, Y_PLUS, X_MINUS, Y_MINUS).
_ANGLES = np.array([0.0, 90.0, 180.0, 270.0])


def state_at(plan: Plan, time: float, version: int = 0) -> FleetState:
    """The plan at `time` (clamped to 0..makespan), moving linearly between steps.

    Headings turn the short way round between steps, as mapf-visualizer shows them.
    """
    time = min(max(float(time), 0.0), float(plan.makespan))
    t0 = int(math.floor(time))
    t1 = min(t0 + 1, plan.makespan)
    frac = time - t0
    p0 = plan.positions[t0].astype(np.float64)
    if frac == 0.0 or t1 == t0:
        positions = p0
    else:
        positions = p0 + (plan.positions[t1] - plan.positions[t0]) * frac
    headings = None
    if plan.orientations is not None:
        o0, o1 = plan.orientations[t0], plan.orientations[t1]
        a0 = np.where(o0 >= 0, _ANGLES[np.clip(o0, 0, 3)], np.nan)
        a1 = np.where(o1 >= 0, _ANGLES[np.clip(o1, 0, 3)], np.nan)
        turn = (a1 - a0 + 180.0) % 360.0 - 180.0
        headings = (a0 + np.where(np.isnan(turn), 0.0, turn) * frac) % 360.0
    return FleetState(time, positions, headings, version)


def state_at_cells(cells: np.ndarray, version: int = 0) -> FleetState:
    """Agents standing on `cells` ((N, 2) ints) at time 0: an instance's starts."""
    return FleetState(0.0, np.asarray(cells, dtype=np.float64).reshape(-1, 2), None, version)
