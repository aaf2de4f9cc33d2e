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
    ecbs   Enhanced CBS (focal search): sum of costs within a factor `w` of the optimum
    pp     prioritized planning with space-time A*: also the replanning engine
    pibt-turns  PIBT for robots that turn in place: a quarter turn takes a step (`pibt_turns`)
"""
from __future__ import annotations

import importlib
from typing import Any, Callable, Dict, Optional, Sequence, Union

from ..errors import FleetError
from ..formats.instance import DEFAULT_MAX_TIMESTEP
from ..grid import Coord, Grid
from ..validate import ROTATION, validate_plan
from .deadline import Deadline, as_deadline
from .problem import InvalidProblemError, ProblemTooLargeError, check_problem, check_size
from .result import NO_SOLUTION, SOLVED, TIMEOUT, SolveResult, SolverError

Solver = Callable[..., SolveResult]

#: Solvers that stop by themselves at `max_timestep`; for the others `solve` checks the plan.
_STEP_LIMITED = ("pibt", "pibt-turns")
#: Solvers whose distance tables cover the free cells only (`goal_distances`); the others' cover every cell.
_FREE_CELL_TABLES = ("pibt", "pibt-turns", "lacam")


def _lazy(module: str, function: str) -> Solver:
    """A solver imported when first called, so that a caller pays only for the solver it runs."""
    def run(*args: Any, **kwargs: Any) -> SolveResult:
        return getattr(importlib.import_module("." + module, __name__), function)(*args, **kwargs)
    run.__name__ = function
    return run


#: The built-in solvers by the name `solve` and `fleetctl solve -s` accept.
SOLVERS: Dict[str, Solver] = {
    "pibt": _lazy("pibt", "pibt"),
    "lacam": _lazy("lacam", "lacam"),
    "cbs": _lazy("cbs", "cbs"),
    "ecbs": _lazy("cbs", "ecbs"),
    "pp": _lazy("prioritized", "pp"),
    "pibt-turns": _lazy("pibt_turns", "pibt_turns"),
}
SOLVER_NAMES = tuple(SOLVERS)
_EXPORTED = {"pibt": "pibt", "pibt_turns": "pibt_turns", "lacam": "lacam", "cbs": "cbs", "ecbs": "cbs", "pp": "prioritized",
             "plan_with_reservations": "prioritized"}


def __getattr__(name: str) -> Any:
    # `from fleet_common.planning import lacam` still works, importing that solver only then
    if name in _EXPORTED:
        return getattr(importlib.import_module("." + _EXPORTED[name], __name__), name)
    raise AttributeError("module {!r} has no attribute {!r}".format(__name__, name))


class UnknownSolverError(FleetError, ValueError):
    """A solver name that is not built in."""


def solve(name: str, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
          deadline: Union[None, float, Deadline] = None, seed: int = 0, rotations: bool = False,
          max_timestep: Optional[int] = None, **options: Any) -> SolveResult:
    """Run built-in solver `name`; see the module docstring for what is guaranteed.

    `rotations` (default False: plans robots can execute) and `options` go to the solver.
    A plan longer than `max_timestep` steps (default: mapf-IR's 5000) is not
    a solution: the result is then "timeout", as in mapf-IR. `comp_time_ms`
    is read on the deadline's clock and covers all the solver did, its
    distance tables included (unless the grid already had them cached).
    """
    solver = SOLVERS.get(name)
    if solver is None:
        raise UnknownSolverError("unknown solver '{}'; built-in solvers are: {}".format(
            name, ", ".join(SOLVER_NAMES)))
    budget = as_deadline(deadline)
    began = budget.elapsed()
    starts = [(int(c[0]), int(c[1])) for c in starts]
    goals = [(int(c[0]), int(c[1])) for c in goals]
    check_problem(grid, starts, goals)
    check_size(grid, len(set(goals)), free_cells_only=name in _FREE_CELL_TABLES)
    limit = DEFAULT_MAX_TIMESTEP if max_timestep is None else int(max_timestep)
    if name in _STEP_LIMITED:
        options["max_timestep"] = limit
    result = solver(grid, starts, goals, budget, seed, rotations=rotations, **options)
    result.comp_time_ms = (budget.elapsed() - began) * 1000.0
    if result.plan is not None and result.plan.makespan > limit:
        result = SolveResult(None, result.solver, TIMEOUT, result.comp_time_ms,
                             "its plan takes {} steps, more than max_timestep={}".format(
                                 result.plan.makespan, limit), result.stats)
    if result.plan is not None:
        check_plan(result, grid, starts, goals, rotations=rotations)
    return result


def check_plan(result: SolveResult, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
               label: Optional[str] = None, rotations: bool = False) -> None:
    """Raise `SolverError` unless `result.plan` is valid and goes from `starts` to `goals`.

    With `rotations` False, a rotation in the plan is an error too; with it
    True, `result.stats["rotations"]` says how many the plan has.
    """
    # only the first problem is shown: listing a few of each kind (e.g. a plan's many following
    # moves, which are notes) costs a millisecond per hundred; the counts stay complete
    report = validate_plan(result.plan, grid, starts=starts, goals=goals,  # type: ignore[arg-type]
                           strict_rotations=not rotations, max_findings_per_kind=5)
    result.stats["rotations"] = report.count(ROTATION)
    if not report.ok:
        errors = report.errors
        problems = sum(report.count(kind) for kind in {e.kind for e in errors})
        raise SolverError("solver '{}' returned an invalid plan ({} problems), first: {}".format(
            label or result.solver, problems, errors[0]))


__all__ = [
    "SOLVERS", "SOLVER_NAMES", "solve", "check_plan", "Deadline", "SolveResult", "SolverError",
    "InvalidProblemError", "ProblemTooLargeError", "UnknownSolverError", "check_problem", "plan_with_reservations",
    "pibt", "pibt_turns", "lacam", "cbs", "ecbs", "pp", "SOLVED", "TIMEOUT", "NO_SOLUTION",
]
