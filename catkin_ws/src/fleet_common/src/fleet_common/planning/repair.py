"""Rotation repair: the closest plan robots can execute to a mapf-IR plan with rotations.

mapf-IR allows rotations (3 or more agents each entering the cell the next one
leaves, in one step; see `rotations`); robots, which hold both cells of a move,
cannot perform one. `repair_rotations(plan, grid)` returns a plan without any:

    result = repair_rotations(plan, grid)   # RepairError if it cannot
    result.plan                             # valid, no rotations, same starts and goals
    print(result.describe())                # "3 rotations repaired: agents 4, 7, 9; soc +4, makespan +1"

Theory of operation. Rotations are taken in time order. For one from step t
the agents of the cycle get new paths over a short window around it, steps
t - w .. t + 1 + w, starting and ending where they were (`detour`), by
space-time A* around every other agent's moves, which forbids closing a
rotation. Only when that fails are the agents widened (to linked rotations,
then to neighbours) and then the window; when no window works (a crowd
turning round at full speed) LaCAM re-plans everyone from the rotation's
step on (`repair_one` has the order). Outside its window a repair changes
nothing, and no new move closes a rotation, so each repair removes one
rotation for good, and a rotation whose agents a repair re-planned is gone.
The plan is edited in place and read through per-step lookups built only
for the steps a search looks at (`occupancy`), so a repair costs what it
searches, not the size of the plan. The finished plan is checked by the
validator with strict rotations before it is returned.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from ..grid import Grid
from ..plan import NO_ORIENTATION, Plan
from ..rotations import step_cycles
from ..validate import validate_plan
from .cells import moves
from .deadline import Deadline, as_deadline
from .occupancy import Occupancy
from .repair_one import RepairError, repair_one

#: Time budget of one repair unless the caller gives one (seconds): mapf-IR's largest outputs
#: repair in a fraction of it (3,000 agents on ost000a, 2,557 rotations: 14-18 s; bench/README.md).
DEFAULT_TIME_LIMIT = 120.0
#: Agents named by `describe` before it only counts the rest.
MAX_NAMED = 12

Cycle = Tuple[int, Tuple[int, ...]]


@dataclass
class RepairResult:
    """The repaired plan and what the repair changed."""

    plan: Plan
    #: the input's rotations, (t, agents) for a rotation from step t to t + 1
    rotations: List[Cycle] = field(default_factory=list)
    #: agents whose paths changed, ascending
    agents: List[int] = field(default_factory=list)
    extra_soc: int = 0
    extra_makespan: int = 0
    comp_time_ms: float = 0.0

    @property
    def repaired(self) -> bool:
        """Whether there was anything to repair (False: `plan` is the input)."""
        return bool(self.rotations)

    def describe(self, who: str = "agents", ids: Optional[Sequence[int]] = None) -> str:
        """One line for people; `ids[i]` names agent i (robot ids), `who` says what they are."""
        if not self.rotations:
            return "no rotations to repair"
        names = [str(ids[a] if ids is not None else a) for a in self.agents]
        shown = ", ".join(names[:MAX_NAMED])
        if len(names) > MAX_NAMED:
            shown += ", ... ({} in all)".format(len(names))
        count = len(self.rotations)
        return "{} rotation{} repaired: {} {}; soc {:+d}, makespan {:+d}".format(
            count, "" if count == 1 else "s", who, shown, self.extra_soc, self.extra_makespan)


def repair_rotations(plan: Plan, grid: Grid, deadline: Union[None, float, Deadline] = DEFAULT_TIME_LIMIT,
                     names: Optional[Sequence[int]] = None, checked: bool = False) -> RepairResult:
    """`plan` (valid on `grid` apart from rotations) without rotations; see the module docstring.

    `deadline`: seconds, a `Deadline`, or None for no limit. Raises
    `RepairError` naming the rotation (step, agents) and why when it cannot;
    `names[i]`, when given, is agent i's robot id in that message.
    `checked`: the caller has validated `plan` already (it is not checked
    again; the repaired plan always is).
    """
    began = time.perf_counter()
    budget = as_deadline(deadline)
    report = None if checked else validate_plan(plan, grid, max_findings_per_kind=1)
    if report is not None and not report.ok:
        raise RepairError("the plan has {} problem(s) besides rotations, first: {}; only a valid plan "
                          "can be repaired".format(len(report.errors), report.errors[0].message))
    w = grid.width
    ids = plan.positions[:, :, 1].astype(np.int64) * w + plan.positions[:, :, 0]
    found = step_cycles(ids)
    if not found:
        return RepairResult(plan, comp_time_ms=(time.perf_counter() - began) * 1000.0)
    mv = moves(grid)
    occ = Occupancy(ids)
    pending = deque(found)
    while pending:  # no repair adds a rotation: each pass takes one away
        t, cycle = pending.popleft()
        if not occ.is_rotation(t, cycle):
            continue  # a repair before re-planned some of its agents (and closed no rotation doing so)
        repair_one(grid, mv, occ, t, cycle, budget, names)
    ids = occ.ids
    fixed = Plan(np.stack([ids % w, ids // w], axis=2), _headings(plan, ids, w))
    check = validate_plan(fixed, grid, starts=plan.starts, goals=plan.goals, strict_rotations=True,
                          max_findings_per_kind=1)
    if not check.ok:
        raise RepairError("the repaired plan is invalid (a bug): {}".format(check.errors[0].message))
    return RepairResult(fixed, found, _touched(plan.positions, fixed.positions), fixed.soc - plan.soc,
                        fixed.makespan - plan.makespan, (time.perf_counter() - began) * 1000.0)


def _touched(before: np.ndarray, after: np.ndarray) -> List[int]:
    """Agents whose cells differ at some step (the shorter plan's agents wait at their goals)."""
    steps = max(before.shape[0], after.shape[0])
    a, b = (np.concatenate([p, np.repeat(p[-1:], steps - p.shape[0], axis=0)]) for p in (before, after))
    return np.nonzero((a != b).any(axis=(0, 2)))[0].tolist()


#: Heading (`plan.Orientation`) of a move by dx + 3 * dy (base frame): +x, +y, -x, -y.
_HEADING = np.array([NO_ORIENTATION, 3, NO_ORIENTATION, 2, NO_ORIENTATION, 0, NO_ORIENTATION, 1, NO_ORIENTATION],
                    dtype=np.int8)


def _headings(plan: Plan, ids: np.ndarray, w: int) -> Optional[np.ndarray]:
    """Headings for the repaired plan: the input's where nothing changed, else the last move's direction."""
    old = plan.orientations
    if old is None:
        return None
    steps = ids.shape[0]
    common = min(steps, old.shape[0])
    out = np.concatenate([old[:common], np.repeat(old[-1:], steps - common, axis=0)])
    same = np.zeros(ids.shape, dtype=bool)
    same[:common] = plan.positions[:common, :, 1].astype(np.int64) * w + plan.positions[:common, :, 0] == ids[:common]
    for t in range(1, steps):
        redo = ~same[t] | ~same[t - 1]  # a cell kept but entered from elsewhere gets a new heading too
        if not redo.any():
            continue
        d = (ids[t] % w - ids[t - 1] % w) + 3 * (ids[t] // w - ids[t - 1] // w) + 4
        heading = np.where(ids[t] != ids[t - 1], _HEADING[d], out[t - 1])
        out[t, redo] = heading[redo]
    return out
