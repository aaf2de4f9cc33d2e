"""A plan from a cut, trimmed: its robots cut to the fewest moves that arrive no later (`planning.trim`).

A plan a reroute or a replan makes from a cut (`cut.Cut`) starts each robot with
its moves sent (made or on their way), which it keeps: a robot drives the move it
was sent whatever plan it belongs to (`Engine.adopt` refuses a plan that changes
one). The cell each move sent enters stays nobody else's until its robot is in:
that robot may be on its way there, or (a follower that completed its move into
the cell its leader was leaving, `Cut.base`) there already, ahead of the plan's
steps. After that, a robot's path is trimmed as any plan's (`planning.trim`:
never where another robot is at the step, the step before or the step after; at
its goal no later). Not while a robot is out or halfway in a move: cells stay
reserved for it past any step the plan shows (`reroute_plan._hold_targets`).
Pure: a plan, its cut and the map in, a plan out.
"""
from __future__ import annotations

from typing import Iterable, List, Optional, Sequence, Tuple

import numpy as np

from ..grid import Grid
from ..plan import Plan
from ..planning.deadline import Deadline
from ..planning.trim import trim_moves
from .cut import Cut

__all__ = ["trim_from_cut", "sent_moves_in"]


def trim_from_cut(plan: Plan, cut: Cut, grid: Grid, robots: Iterable[int], out: Sequence[Optional[str]],
                  halfway: Sequence[bool], deadline: Optional[Deadline] = None) -> Plan:
    """`plan` (from `cut`) with `robots` trimmed after their moves sent (see the module docstring);
    `plan` itself while a robot is `out` or `halfway` in a move, or when nobody has a move to spare."""
    if any(o is not None for o in out) or any(halfway):
        return plan
    sent = sent_moves_in(plan, cut, grid)
    keep = [max([0] + [step for _, step in moves]) for moves in sent]
    reserved = [move for moves in sent for move in moves]
    return trim_moves(plan, grid, robots, keep, deadline=deadline, reserved=reserved).plan


def sent_moves_in(plan: Plan, cut: Cut, grid: Grid) -> List[List[Tuple[int, int]]]:
    """Per robot, its moves sent at the cut in `plan` (a plan from `cut`: they are its first moves
    there), each as (the cell it enters, the step it is in)."""
    pos = plan.positions
    moved = (pos[1:] != pos[:-1]).any(axis=2)  # (steps, robots)
    out: List[List[Tuple[int, int]]] = []
    for r in range(plan.num_agents):
        count = cut.completed[r] + cut.committed[r] - cut.base[r]
        steps = np.nonzero(moved[:, r])[0][:max(count, 0)] + 1
        out.append([(grid.index((int(pos[s, r, 0]), int(pos[s, r, 1]))), int(s)) for s in steps])
    return out
