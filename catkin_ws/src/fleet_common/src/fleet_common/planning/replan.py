"""Replanning when robots drop out: a new plan from where every robot is now.

The execution manager calls `replan` with each agent's current cell, the
agents that are out (a dead battery, a robot taken off the floor) and the
goals. Out agents stay where they are for the whole new plan: obstacles.
Agents whose goal can no longer be reached (an out robot sits on it, the
map's cells blocked round a robot standing between two cells cover it, or
walls off the only corridor) are found before any search, by connected components
of the map with the stationary robots as walls, repeated until nothing
changes (a stranded robot is a wall for the others too); they stay put and
are reported in `unreachable`. The others are planned from their current
cells, by prioritized planning around the stationary robots ("pp", fast;
when it gives up, LaCAM, complete) or by LaCAM directly ("lacam"). Like
every built-in solver, replanning makes no rotations unless `rotations` is set.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Set, Union

import numpy as np

from ..grid import Coord, Grid
from ..plan import Plan
from ..validate import validate_plan
from .components import component_labels
from .deadline import Deadline, as_deadline
from .lacam import lacam
from .prioritized import plan_with_reservations
from .problem import InvalidProblemError, cell_problem, duplicate_problems
from .result import SOLVED, TIMEOUT, SolveResult, SolverError

METHODS = ("pp", "lacam")


@dataclass
class ReplanResult:
    """A plan over all agents (None if none was found), and who cannot reach its goal."""

    plan: Optional[Plan]
    unreachable: Set[int] = field(default_factory=set)
    message: str = ""
    status: str = SOLVED
    comp_time_ms: float = 0.0

    @property
    def solved(self) -> bool:
        return self.plan is not None


def replan(grid: Grid, current: Sequence[Coord], goals: Sequence[Coord], out: Set[int],
           deadline: Union[None, float, Deadline] = None, seed: int = 0,
           method: str = "pp", rotations: bool = False) -> ReplanResult:
    """Plan every agent that is not out from `current` to its goal; see the module docstring."""
    began = time.perf_counter()
    if method not in METHODS:
        raise ValueError("unknown replanning method '{}'; use one of: {}".format(method, ", ".join(METHODS)))
    current = [(int(c[0]), int(c[1])) for c in current]
    goals = [(int(c[0]), int(c[1])) for c in goals]
    _check(grid, current, goals, out)
    budget = as_deadline(deadline)
    still = set(out)
    unreachable = _stranded(grid, current, goals, still)
    still |= unreachable
    active = [i for i in range(len(current)) if i not in still]
    sub = _plan_active(grid, current, goals, active, sorted(still), budget, seed, method, rotations)
    ms = (time.perf_counter() - began) * 1000.0
    note = _describe(unreachable)
    if sub.plan is None:
        return ReplanResult(None, unreachable, (sub.message + note).strip(), sub.status, ms)
    plan = _merge(sub.plan, current, active)
    targets = [goals[i] if i in set(active) else current[i] for i in range(len(current))]
    report = validate_plan(plan, grid, starts=current, goals=targets, strict_rotations=not rotations)
    if not report.ok:
        raise SolverError("replanning ({}) produced an invalid plan: {}".format(sub.solver, report.errors[0]))
    return ReplanResult(plan, unreachable, ("planned by {}".format(sub.solver) + note + sub.message).strip(),
                        SOLVED, ms)


def _check(grid: Grid, current: List[Coord], goals: List[Coord], out: Set[int]) -> None:
    n = len(current)
    if len(goals) != n:
        raise InvalidProblemError(["{} current cells but {} goals: every agent needs both".format(n, len(goals))])
    problems = ["agent {} is marked out but there are only {} agents".format(i, n)
                for i in sorted(out) if not 0 <= i < n]
    for i, c in enumerate(current):
        msg = cell_problem(grid, c, "current cell", i)
        if msg is not None:
            problems.append(msg)
    problems += duplicate_problems(current, "current cell")
    active = [i for i in range(n) if i not in out]
    for i in active:  # a goal on a blocked cell is unreachable (`_stranded`), outside the map wrong
        msg = cell_problem(grid, goals[i], "goal", i) if not grid.in_bounds(goals[i]) else None
        if msg is not None:
            problems.append(msg)
    problems += duplicate_problems([goals[i] for i in active], "goal", agents=active)
    if problems:
        raise InvalidProblemError(problems)


def _stranded(grid: Grid, current: List[Coord], goals: List[Coord], still: Set[int]) -> Set[int]:
    """Agents that cannot reach their goals around the stationary ones (to a fixed point)."""
    stranded: Set[int] = set()
    walls = set(still)
    while True:
        blocked = np.zeros(grid.free.shape, dtype=bool)
        for j in walls:
            blocked[current[j][1], current[j][0]] = True
        labels = component_labels(grid, blocked)
        w = grid.width
        new = {i for i in range(len(current)) if i not in walls and (
            blocked[goals[i][1], goals[i][0]] or not grid.free[goals[i][1], goals[i][0]]
            or labels[current[i][1] * w + current[i][0]] != labels[goals[i][1] * w + goals[i][0]])}
        if not new:
            return stranded
        stranded |= new
        walls |= new


def _plan_active(grid: Grid, current: List[Coord], goals: List[Coord], active: List[int],
                 still: List[int], deadline: Deadline, seed: int, method: str,
                 rotations: bool) -> SolveResult:
    starts = [current[i] for i in active]
    ends = [goals[i] for i in active]
    if method == "pp":
        result = plan_with_reservations(grid, starts, ends, [[current[j]] for j in still], deadline, seed,
                                        rotations=rotations)
        if result.solved or result.status == TIMEOUT:
            return result
        fallback = "; prioritized planning gave up ({}), LaCAM used".format(result.message)
    else:
        fallback = ""
    walled = grid.free.copy()
    for j in still:
        walled[current[j][1], current[j][0]] = False
    result = lacam(Grid(walled, name=grid.name), starts, ends, deadline, seed, rotations=rotations)
    result.message = (result.message + fallback).strip("; ")
    return result


def _merge(sub: Plan, current: List[Coord], active: List[int]) -> Plan:
    steps = sub.positions.shape[0]
    pos = np.empty((steps, len(current), 2), dtype=np.int32)
    pos[:] = np.asarray(current, dtype=np.int32).reshape(1, len(current), 2)
    if active:
        pos[:, active] = sub.positions
    return Plan(pos)


def _describe(unreachable: Set[int]) -> str:
    if not unreachable:
        return ""
    return "; agents {} cannot reach their goals and stay where they are".format(
        ", ".join(str(i) for i in sorted(unreachable)))
