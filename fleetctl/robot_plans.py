"""What every command that executes a plan does first: know the fleet, repair rotations.

`fleetctl simulate` and `fleetctl demo` (and the manager) run plans on robots;
reading and checking a plan is `fleet_common.plan_loading`'s, this module says
what it found the way a command line does. Robots cannot perform a rotation, so a
plan's rotations are repaired first (`fleet_common.planning.repair`), saying
so in one line; `--no-repair` keeps the plan as it is, and the execution
engine then refuses it. On the lab fleet (`fleet_common.lab.fleet`) agents
are named by their robot ids.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import List, Optional

from fleet_common.formats.solution import Solution, read_solution
from fleet_common.grid import Grid
from fleet_common.lab.fleet import lab_fleet, robot_ids
from fleet_common.plan import Plan
from fleet_common.plan_loading import InvalidPlan, PlanLoadError, check_solved, check_valid, file_coordinates
from fleet_common.planning.repair import repair_rotations

from .options import map_dirs
from .report import print_findings


class Names:
    """What people call agent i: the robot id on the lab fleet, else the agent index."""

    def __init__(self, ids: Optional[List[int]] = None) -> None:
        self.ids = ids

    @classmethod
    def of(cls, grid: Grid, num_agents: int, definitions: Optional[Path] = None) -> "Names":
        return cls(robot_ids(lab_fleet(grid, num_agents, definitions)))

    @property
    def lab(self) -> bool:
        return self.ids is not None

    def __call__(self, agent: int) -> str:
        return str(self.ids[agent] if self.ids is not None else agent)

    def all(self, agents: List[int]) -> str:
        return ", ".join(self(a) for a in agents)

    def index(self, name: int) -> Optional[int]:
        """The agent called `name`, None if there is none."""
        if self.ids is None:
            return None if name < 0 else name
        return self.ids.index(name) if name in self.ids else None

    def describe(self) -> str:
        if self.ids is None:
            return "simulated robots, numbered by agent index from 0"
        return "the lab's robots, named by their ids in the robot definitions"


def valid_solution(args: argparse.Namespace, not_done: str) -> Optional[Solution]:
    """`args.solution` read, if it holds a plan valid apart from rotations; else None, having said why
    (`not_done`: what is then not done, "not simulated")."""
    sol = read_solution(args.solution, map_dirs=map_dirs(args))
    name = str(args.solution)
    try:
        plan = check_solved(sol, name)
        check_valid(plan, sol.grid, name, sol.starts, sol.goals, file_coordinates(sol))
    except InvalidPlan as err:
        print_findings(name, err.report)
        print("{}: INVALID: {} problem(s); {} (`fleetctl validate` explains)".format(
            name, len(err.report.errors), not_done))
        return None
    except PlanLoadError as err:
        print(err)
        return None
    return sol


def add_repair_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--no-repair", action="store_true",
                        help="do not repair rotations (robots cannot perform them): refuse such a plan")


def for_robots(plan: Plan, grid: Grid, name: str, args: argparse.Namespace, names: Names,
               checked: bool = False) -> Plan:
    """`plan` with its rotations repaired (one line says so), unless --no-repair.

    `checked`: `plan` is known valid apart from rotations (`valid_solution`).
    Raises `RepairError` when a rotation cannot be repaired.
    """
    if args.no_repair:
        return plan
    result = repair_rotations(plan, grid, names=names.ids, checked=checked)
    if result.repaired:
        print("{}: {}".format(name, result.describe("robots" if names.lab else "agents", names.ids)))
    return result.plan
