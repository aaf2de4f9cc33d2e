"""What the manager runs: a plan file, or an instance it plans first, checked and given robots.

PLAN is a mapf-IR solution (a student's solver output, run as it is, but for
its rotations, which robots cannot perform: they are repaired, as `fleetctl
repair` does, unless `repair=False`) or an instance (planned here with a
built-in solver). Either way the plan is validated with the one validator,
and plan agent i becomes the i-th robot of the fleet: of
robot_definitions.txt, or of `--robots` in the order given. A plan for another
number of robots is refused, naming both counts.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, List, Optional, Sequence

from fleet_common.errors import FleetError
from fleet_common.formats.instance import Instance
from fleet_common.formats.problem_file import read_problem
from fleet_common.formats.solution import Solution, format_solution, make_solution
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.planning import solve
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.repair import RepairError, repair_rotations
from fleet_common.robots import RobotDefinition
from fleet_common.validate import validate_plan

__all__ = ["LoadedPlan", "load_plan", "pick_robots", "PlanLoadError"]


class PlanLoadError(FleetError):
    """A plan the manager cannot run (not solved, invalid, the wrong number of robots)."""


@dataclass
class LoadedPlan:
    plan: Plan
    grid: Grid
    starts: List[Coord]
    goals: List[Coord]
    name: str
    solution: Solution           # what is written into the run folder
    show: Callable[[Coord], Coord]  # base cell -> the file's own coordinates, for messages
    note: str = ""               # how it came to be ("planned by lacam in 120 ms")

    def text(self) -> str:
        return format_solution(self.solution)


def pick_robots(robots: Sequence[RobotDefinition], ids: Optional[Sequence[int]],
                path: str) -> List[RobotDefinition]:
    """The fleet of this run: every definition, or those of `ids` in that order."""
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


def load_plan(path: Path, fleet_size: int, fleet_name: str, map_dirs: Sequence[Path],
              solver: Optional[str] = None, time_limit: float = 10.0, seed: int = 0,
              text: Optional[str] = None, repair: bool = True) -> LoadedPlan:
    """The plan in `path` (or `text`, named `path`) for a fleet of `fleet_size` robots."""
    name = str(path)
    problem = read_problem(path, map_dirs, text)
    if isinstance(problem, Solution):
        loaded = _from_solution(problem, name, repair)
    else:
        loaded = _from_instance(problem, name, solver, time_limit, seed)
    agents = loaded.plan.num_agents
    if agents != fleet_size:
        raise PlanLoadError("{} has {} agents but {} has {} robots; plan agent i runs on the "
                            "i-th robot, so the counts must match (choose robots with --robots)".format(
                                name, agents, fleet_name, fleet_size))
    return loaded


def _from_solution(sol: Solution, name: str, repair: bool) -> LoadedPlan:
    if sol.plan is None or not sol.solved:
        raise PlanLoadError("{}: no plan: solver {} did not solve it (solved={})".format(
            name, sol.solver or "?", int(bool(sol.solved))))
    show = sol.grid.flip_y if sol.orientation == "mapf-ir" else _same
    report = validate_plan(sol.plan, sol.grid, starts=sol.starts, goals=sol.goals, show=show)
    if not report.ok:
        raise PlanLoadError("{}: invalid plan ({} problems), first: {} (`fleetctl validate` "
                            "lists them)".format(name, len(report.errors), report.errors[0]))
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


def _from_instance(inst: Instance, path: str, solver: Optional[str], time_limit: float,
                   seed: int) -> LoadedPlan:
    names = [solver] if solver else (["cbs", "lacam"] if inst.num_agents <= 12 else ["lacam"])
    result = None
    for each in names:
        result = solve(each, inst.grid, inst.starts, inst.goals, deadline=Deadline(time_limit),
                       seed=seed, max_timestep=inst.max_timestep)
        if result.solved:
            break
    if result is None or result.plan is None:
        raise PlanLoadError("{}: no plan found by {} in {:g} s: {}".format(
            path, " or ".join(names), time_limit, result.message if result else ""))
    show = inst.grid.flip_y if inst.orientation == "mapf-ir" else _same
    sol = make_solution(inst.grid, inst.map_file or "", result.plan, inst.starts, inst.goals,
                        result.solver, True, round(result.comp_time_ms), instance=path)
    sol.orientation = inst.orientation
    return LoadedPlan(result.plan, inst.grid, list(inst.starts), list(inst.goals), path, sol,
                      show, "planned by {} in {:.0f} ms".format(result.solver, result.comp_time_ms))


def _same(c: Coord) -> Coord:
    return c
