"""One rotation repaired: which windows and which agents are re-planned, in what order.

For the rotation from step t to t + 1, tried in turn until one works:

1. windows with a fixed end, t - w .. t + 1 + w for w = 1, 2, 4, 8 (`detour`):
   the agents re-planned arrive where they were, so nobody else changes;
   the agents are, in turn, those of the cycle; with the agents of every
   rotation in the window linked to it by shared agents (rotations come in
   swirls in crowded places, and a kept rotation pins its agents' moves);
   then with the neighbours of all of them too;
2. every agent re-planned from the configuration at step t, t - 8, t - 32,
   ..., 0 by LaCAM (`replan`, complete): the plan before that step is kept,
   and no rotation is left after it.

1 repairs most rotations in a few milliseconds. 2 is for crowds that turn
round at full speed, where nobody has a step to spare in any window: there,
going round one another means some agents arriving later, and those waiting
behind them later still, and so on to the plan's end; LaCAM re-plans that
whole future at once, in C, instead of agent by agent in Python (see
bench/README.md, "Rotation repair"). Only 2 says "no" for good: a
configuration from which no rotation-free plan exists.
"""
from __future__ import annotations

from typing import Iterator, List, Optional, Sequence, Set

import numpy as np

from ..errors import FleetError
from ..grid import Grid
from ..rotations import step_cycles
from .deadline import Deadline
from .detour import replan_window
from .occupancy import Occupancy
from .replan import replan
from .st_astar import DeadlineReached

#: Half-widths of the windows with a fixed end, tried in turn.
FIXED_WINDOWS = (1, 2, 4, 8)
#: LaCAM starts this far back, then 4 times as far each time ...
FIRST_BACK = 8
#: ... each time with this share of the time left (the last time, from step 0, with all of it).
LACAM_SHARE = 0.5
#: Neighbours join a cycle's agents when within this many cells of one of its cells.
NEIGHBOUR_REACH = 2


class RepairError(FleetError):
    """A rotation that could not be repaired (`step`: its move leaves step t), or a plan that is not
    valid apart from its rotations (`step` None)."""

    def __init__(self, message: str, step: Optional[int] = None, agents: Sequence[int] = ()) -> None:
        super().__init__(message)
        self.step = step
        self.agents = tuple(agents)


def repair_one(grid: Grid, moves: List[List[int]], occ: Occupancy, t: int, cycle: Sequence[int],
               budget: Deadline, names: Optional[Sequence[int]] = None) -> None:
    """Re-plan `occ` (in place) without the rotation from step t, closing no other rotation.

    `moves` is `cells.moves(grid)`. Raises `RepairError` naming the rotation
    (its agents as `names[i]`, robots, when given).
    """
    what = "the rotation at t={}->{} ({} {})".format(t, t + 1, "agents" if names is None else "robots",
                                                    ", ".join(str(a if names is None else names[a]) for a in cycle))
    try:
        for w in FIXED_WINDOWS:
            if t + 1 + w > occ.last:
                break
            if _window(grid, moves, occ, max(0, t - w), t + 1 + w, t, cycle, budget):
                return
        last = occ.last
        for t0 in _backwards(t):
            # LaCAM's time varies with the configuration: an earlier one may be quicker
            left = budget.remaining()
            share = budget if t0 == 0 or left is None else Deadline(left * LACAM_SHARE)
            ids = occ.ids
            result = replan(grid, [grid.coord(c) for c in ids[t0].tolist()],
                            [grid.coord(c) for c in ids[last].tolist()], set(), share, method="lacam")
            if budget.expired():
                raise DeadlineReached()
            if result.plan is not None:
                pos = result.plan.positions
                occ.replace_from(t0, pos[:, :, 1].astype(np.int64) * grid.width + pos[:, :, 0])
                return
    except DeadlineReached:
        raise RepairError("time limit of {:g} s reached while repairing {}".format(
            budget.seconds or 0, what), t, cycle) from None
    raise RepairError("cannot repair {}: no plan without rotations exists from its starts (LaCAM, which is "
                      "complete, searched every configuration)".format(what), t, cycle)


def _window(grid: Grid, moves: List[List[int]], occ: Occupancy, t0: int, t1: int, t: int, cycle: Sequence[int],
            budget: Deadline) -> bool:
    """Re-plan steps t0..t1 around the rotation from step t for each group of agents in turn, until one works."""
    for agents in _groups(grid, occ.ids, t0, t1, t, cycle):
        if budget.expired():  # small searches never look at the clock themselves
            raise DeadlineReached()
        if replan_window(moves, occ, t0, t1, agents, budget):
            return True
    return False


def _backwards(t: int) -> Iterator[int]:
    """t, then FIRST_BACK steps before t, then 4 times as far back each time, down to 0."""
    back = 0
    while True:
        yield max(0, t - back)
        if t - back <= 0:
            return
        back = max(back * 4, FIRST_BACK)


def _groups(grid: Grid, ids: np.ndarray, t0: int, t1: int, t: int, cycle: Sequence[int]) -> List[List[int]]:
    """The agents to re-plan, in turn: the cycle's; with those of every rotation in steps t0..t1 linked
    to it by shared agents; then with their neighbours too."""
    group = set(cycle)
    linked = [set(a) for _, a in step_cycles(ids[t0:t1 + 1])]
    grown = True
    while grown:
        grown = False
        for agents in linked:
            if agents & group and not agents <= group:
                group |= agents
                grown = True
    wider = group | _neighbours(grid, ids, t, sorted(group))
    out: List[List[int]] = []
    for agents in (set(cycle), group, wider):
        if not out or len(agents) > len(out[-1]):
            out.append(sorted(agents))
    return out


def _neighbours(grid: Grid, ids: np.ndarray, t: int, agents: Sequence[int]) -> Set[int]:
    """Agents within NEIGHBOUR_REACH cells of one of `agents`' cells at step t (at t or t + 1)."""
    w = grid.width
    cells = ids[t, list(agents)]
    near = np.zeros(ids.shape[1], dtype=bool)
    for step in (t, t + 1):
        row = ids[step]
        for c in cells.tolist():
            near |= (np.abs(row % w - c % w) + np.abs(row // w - c // w)) <= NEIGHBOUR_REACH
    return set(np.nonzero(near)[0].tolist())
