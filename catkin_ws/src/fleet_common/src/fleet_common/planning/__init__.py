"""Planning inside FleetControl: built-in MAPF solvers behind one interface.

Every solver is a pure function `solver(grid, starts, goals, deadline, seed,
rotations=False, **options) -> SolveResult`: base-frame cells in, a `Plan` (or the reason there
is none) out; no printing, no files, no global random state, so a fixed seed
gives the same plan. `solve` is the one entry point for callers: it rejects
unusable problems before any search (`InvalidProblemError`, naming the agent),
times the run, and checks every plan with the foundation validator, so a
solver bug surfaces as a `SolverError`, never as a bad plan.

The solvers plan for robots: their plans have no rotations (3 or more agents
each entering the cell the next one leaves, which robots occupying both cells
of a move cannot perform) unless `rotations=True` asks for mapf-IR's
semantics, where rotations are legal.

    pibt   PIBT: fast, hundreds of agents; incomplete
    lacam  LaCAM with PIBT as configuration generator: complete, not optimal
    cbs    Conflict-Based Search: optimal sum of costs, small instances
    pp     prioritized planning with space-time A*: also the replanning engine
"""
from __future__ import annotations

import time
from typing import Any, Callable, Dict, Optional, Sequence, Union

from ..errors import FleetError
from ..grid import Coord, Grid
from ..validate import validate_plan
from .cbs import cbs
from .deadline import Deadline, as_deadline
from .lacam import lacam
from .pibt import pibt
from .prioritized import plan_with_reservations, pp
from .problem import InvalidProblemError, ProblemTooLargeError, check_problem, check_size
from .result import NO_SOLUTION, SOLVED, TIMEOUT, SolveResult, SolverError

Solver = Callable[..., SolveResult]

#: The built-in solvers by the name `solve` and `fleetctl solve -s` accept.
SOLVERS: Dict[str, Solver] = {"pibt": pibt, "lacam": lacam, "cbs": cbs, "pp": pp}
SOLVER_NAMES = tuple(SOLVERS)


class UnknownSolverError(FleetError, ValueError):
    """A solver name that is not built in."""


def solve(name: str, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
          deadline: Union[None, float, Deadline] = None, seed: int = 0, rotations: bool = False,
          **options: Any) -> SolveResult:
    """Run built-in solver `name`; see the module docstring for what is guaranteed.

    `rotations` (default False: plans robots can execute) and `options` go to the solver.
    """
    solver = SOLVERS.get(name)
    if solver is None:
        raise UnknownSolverError("unknown solver '{}'; built-in solvers are: {}".format(
            name, ", ".join(SOLVER_NAMES)))
    starts = [(int(c[0]), int(c[1])) for c in starts]
    goals = [(int(c[0]), int(c[1])) for c in goals]
    check_problem(grid, starts, goals)
    check_size(grid, len(set(goals)))
    budget = as_deadline(deadline)
    began = time.perf_counter()
    result = solver(grid, starts, goals, budget, seed, rotations=rotations, **options)
    result.comp_time_ms = (time.perf_counter() - began) * 1000.0
    if result.plan is not None:
        check_plan(result, grid, starts, goals, rotations=rotations)
    return result


def check_plan(result: SolveResult, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
               label: Optional[str] = None, rotations: bool = False) -> None:
    """Raise `SolverError` unless `result.plan` is valid and goes from `starts` to `goals`.

    With `rotations` False, a rotation in the plan is an error too.
    """
    report = validate_plan(result.plan, grid, starts=starts, goals=goals,  # type: ignore[arg-type]
                           strict_rotations=not rotations)
    if not report.ok:
        errors = report.errors
        raise SolverError("solver '{}' returned an invalid plan ({} problems), first: {}".format(
            label or result.solver, len(errors), errors[0]))


__all__ = [
    "SOLVERS", "SOLVER_NAMES", "solve", "check_plan", "Deadline", "SolveResult", "SolverError",
    "InvalidProblemError", "ProblemTooLargeError", "UnknownSolverError", "check_problem", "plan_with_reservations",
    "pibt", "lacam", "cbs", "pp", "SOLVED", "TIMEOUT", "NO_SOLUTION",
]
