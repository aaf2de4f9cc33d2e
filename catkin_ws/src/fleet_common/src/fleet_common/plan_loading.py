"""Loading a plan to run: read it, check it is solved and valid, fit it to the robots.

Every command that executes a plan starts here: the manager (`fleetctl manager`, and a
plan a console loads), `fleetctl simulate`, `fleetctl demo` and the sweeps of `fleetctl
experiment`. A plan is a mapf-IR solution (a student's solver output, run as it is, but
for its rotations, which robots cannot perform: they are repaired, as `fleetctl repair`
does, unless `repair=False`) or an instance, planned with a built-in solver (CBS for a
few agents, optimal, falling back to LaCAM). A solution is validated with the one
validator, in the file's own coordinates (`file_coordinates`). Pure: values in, a
`LoadedPlan` or a `PlanLoadError` saying what is wrong out; it prints nothing.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, replace
from pathlib import Path, PurePath
from typing import Any, Callable, List, Optional, Sequence, Tuple

from .errors import FleetError
from .formats.instance import Instance
from .formats.problem_file import read_problem
from .formats.solution import Solution, format_solution, make_solution
from .grid import Coord, Grid
from .plan import Plan
from .planning import SolveResult, solve
from .planning.deadline import Deadline
from .planning.repair import RepairError, repair_rotations
from .planning.trim import Trimmed, trim_moves
from .robots import RobotDefinition
from .validate import Report, validate_plan

__all__ = ["LoadedPlan", "PlanLoadError", "InvalidPlan", "load_plan", "fit_fleet", "from_solution", "from_instance",
           "solve_instance", "check_solved", "check_valid", "file_coordinates", "pick_robots",
           "CBS_MAX_AGENTS"]

#: Instances of at most this many agents are planned with CBS first (optimal, and quick for a
#: handful of robots), then with LaCAM if CBS runs out of time; larger ones with LaCAM.
CBS_MAX_AGENTS = 12


class PlanLoadError(FleetError):
    """A plan that cannot be run: not solved, invalid, not for robots, the wrong fleet size."""


class InvalidPlan(PlanLoadError):
    """A plan the validator refuses; `report` holds every finding."""

    def __init__(self, message: str, report: Report) -> None:
        super().__init__(message)
        self.report = report


@dataclass
class LoadedPlan:
    """A plan ready to run, and where it came from."""

    plan: Plan
    grid: Grid
    starts: List[Coord]
    goals: List[Coord]
    name: str
    solution: Solution              # the plan as a mapf-IR solution (what a run folder records)
    show: Callable[[Coord], Coord]  # base cell -> the file's own coordinates, for messages
    note: str = ""                  # how it came to be ("planned by lacam in 120 ms")

    @property
    def title(self) -> str:
        """The name as an operator reads it: the file name of the path it was loaded from (the
        run folder keeps the whole `name`)."""
        return PurePath(self.name).name or self.name

    @property
    def solver(self) -> str:
        return self.solution.solver or "?"

    @property
    def agents(self) -> int:
        return self.plan.num_agents

    def text(self) -> str:
        return format_solution(self.solution)


def file_coordinates(problem: Any) -> Callable[[Coord], Coord]:
    """Base cell -> the cell as `problem`'s file (a Solution or Instance) writes it: mapf-IR
    files count rows from the top, so that messages about a file use its own coordinates."""
    return problem.grid.flip_y if problem.orientation == "mapf-ir" else _same


def check_solved(sol: Solution, name: str) -> Plan:
    """The plan `sol` records; PlanLoadError if its solver did not solve the instance."""
    if sol.plan is None or not sol.solved:
        raise PlanLoadError("{}: no plan: solver {} did not solve it (solved={})".format(
            name, sol.solver or "?", int(bool(sol.solved))))
    return sol.plan


def check_valid(plan: Plan, grid: Grid, name: str, starts: Optional[Sequence[Coord]] = None,
                goals: Optional[Sequence[Coord]] = None, show: Optional[Callable[[Coord], Coord]] = None,
                strict_rotations: bool = False) -> Report:
    """The validator's report on `plan`; InvalidPlan (with the report) if it has errors."""
    report = validate_plan(plan, grid, starts=starts, goals=goals, show=show or _same,
                           strict_rotations=strict_rotations)
    if not report.ok:
        raise InvalidPlan("{}: invalid plan ({} problems), first: {} (`fleetctl validate` lists "
                          "them)".format(name, len(report.errors), report.errors[0]), report)
    return report


def solve_instance(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], solver: Optional[str] = None,
                   time_limit: float = 10.0, seed: int = 0, max_timestep: Optional[int] = None) -> SolveResult:
    """A plan by `solver`, or (None) by CBS then LaCAM for at most CBS_MAX_AGENTS agents, else by
    LaCAM; the last result tried (solved or not)."""
    names = [solver] if solver else (["cbs", "lacam"] if len(starts) <= CBS_MAX_AGENTS else ["lacam"])
    result = None
    for each in names:
        result = solve(each, grid, starts, goals, deadline=Deadline(time_limit), seed=seed,
                       max_timestep=max_timestep)
        if result.solved:
            break
    assert result is not None  # names is never empty
    return result


def from_solution(sol: Solution, name: str, repair: bool = True, strict_rotations: bool = False) -> LoadedPlan:
    """The plan of solution `sol` (read from `name`): solved, valid, rotations repaired unless
    `repair` is False (then, with `strict_rotations`, a rotation makes it invalid)."""
    check_solved(sol, name)
    show = file_coordinates(sol)
    check_valid(sol.plan, sol.grid, name, sol.starts, sol.goals, show, strict_rotations)
    note = "solution by {}".format(sol.solver or "?")
    if repair:
        try:
            result = repair_rotations(sol.plan, sol.grid)
        except RepairError as err:
            raise PlanLoadError("{}: robots cannot execute it: {}".format(name, err)) from None
        if result.repaired:  # the run folder records the plan the robots run
            sol.replace_plan(result.plan)
            note += "; " + result.describe()
    return LoadedPlan(sol.plan, sol.grid, list(sol.starts), list(sol.goals), name, sol, show, note)


def from_instance(inst: Instance, name: str, solver: Optional[str] = None, time_limit: float = 10.0,
                  seed: int = 0) -> LoadedPlan:
    """A plan for instance `inst` (read from `name`) by the built-in `solver` (see `solve_instance`)."""
    result = solve_instance(inst.grid, inst.starts, inst.goals, solver, time_limit, seed, inst.max_timestep)
    if result.plan is None:
        tried = solver or ("cbs or lacam" if len(inst.starts) <= CBS_MAX_AGENTS else "lacam")
        raise PlanLoadError("{}: no plan found by {} in {:g} s: {}".format(name, tried, time_limit, result.message))
    sol = make_solution(inst.grid, inst.map_file or "", result.plan, inst.starts, inst.goals,
                        result.solver, True, round(result.comp_time_ms), instance=name)
    sol.orientation = inst.orientation
    return LoadedPlan(result.plan, inst.grid, list(inst.starts), list(inst.goals), name, sol,
                      file_coordinates(inst), "planned by {} in {:.0f} ms".format(result.solver, result.comp_time_ms))


def load_plan(path: Path, fleet_size: int, fleet_name: str, map_dirs: Sequence[Path],
              solver: Optional[str] = None, time_limit: float = 10.0, seed: int = 0,
              text: Optional[str] = None, repair: bool = True, grid: Optional[Grid] = None) -> LoadedPlan:
    """The plan in `path` (or `text`, named `path`), a solution or an instance, for a fleet of
    `fleet_size` robots (`fleet_name`, for the message when the counts differ); on `grid` if
    given (the map found already: its map_file= is not looked up)."""
    name = str(path)
    problem = read_problem(path, map_dirs, text, grid)
    if isinstance(problem, Solution):
        loaded = from_solution(problem, name, repair)
    else:
        loaded = from_instance(problem, name, solver, time_limit, seed)
    return fit_fleet(loaded, fleet_size, fleet_name)


def trim_loaded(loaded: LoadedPlan, seconds: Optional[float] = None) -> Tuple[LoadedPlan, Trimmed]:
    """`loaded` with its robots trimmed of the moves that do not bring them in sooner
    (`planning.trim`, the robots with the most to spare first, for at most `seconds`: those not
    reached by then keep their paths), recorded in its solution (what a run folder keeps: the plan
    the robots run) and told in its note; and the trim (its plan the one given when nobody had a
    move to spare)."""
    result = trim_moves(loaded.plan, loaded.grid, deadline=Deadline(seconds))
    if not result.robots:
        return replace(loaded, note=loaded.note + "; " + result.describe()), result
    solution = copy.deepcopy(loaded.solution)  # the plan given stays as it was, where else it is held
    solution.replace_plan(result.plan)
    return replace(loaded, plan=result.plan, solution=solution,
                   note=loaded.note + "; " + result.describe()), result


def fit_fleet(loaded: LoadedPlan, fleet_size: int, fleet_name: str) -> LoadedPlan:
    """`loaded`, if it has as many agents as the fleet (`fleet_name`) has robots."""
    if loaded.agents != fleet_size:
        raise PlanLoadError("{} has {} agents but {} has {} robots; plan agent i runs on the "
                            "i-th robot, so the counts must match (choose robots with --robots)".format(
                                loaded.name, loaded.agents, fleet_name, fleet_size))
    return loaded


def pick_robots(robots: Sequence[RobotDefinition], ids: Optional[Sequence[int]],
                path: str) -> List[RobotDefinition]:
    """The fleet of a run: every definition (of file `path`), or those of `ids` in that order;
    plan agent i runs on the i-th."""
    if ids is None:
        return list(robots)
    by_id = {r.id: r for r in robots}
    missing = [i for i in ids if i not in by_id]
    if missing:
        raise FleetError("--robots names {} not in {} (it defines {})".format(
            ", ".join(map(str, missing)), path, ", ".join(str(r.id) for r in robots)))
    if len(set(ids)) != len(ids):
        raise FleetError("--robots names a robot twice")
    return [by_id[i] for i in ids]


def _same(c: Coord) -> Coord:
    return c
