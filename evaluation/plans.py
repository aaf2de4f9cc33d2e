"""The plans of an experiment, made once before the cells run.

A solution file is read and checked; an instance is solved by the built-in
solver named (seed 0), and the plan is written to OUT/plans/NAME.txt so that
a resumed sweep runs on the very same plan instead of solving again. Plans
robots cannot execute (conflicts, rotations) stop the sweep before it starts.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List

import numpy as np

from fleet_common.errors import FleetError
from fleet_common.formats import default_map_dirs
from fleet_common.formats.instance import read_instance
from fleet_common.formats.solution import make_solution, read_solution, write_solution
from fleet_common.grid import Coord
from fleet_common.planning import solve
from fleet_common.planning.deadline import Deadline
from fleet_common.validate import validate_plan

from .spec import PlanSource


@dataclass
class LoadedPlan:
    """What a cell needs of a plan (plain data: cells travel to other processes)."""

    name: str
    solver: str
    positions: np.ndarray
    free: np.ndarray
    goals: List[Coord]

    @property
    def agents(self) -> int:
        return int(self.positions.shape[1])


def load_plans(sources: List[PlanSource], out: Path) -> Dict[str, LoadedPlan]:
    folder = out / "plans"
    folder.mkdir(parents=True, exist_ok=True)
    plans: Dict[str, LoadedPlan] = {}
    for src in sources:
        saved = folder / (src.name + ".txt")
        if src.solver is None or saved.is_file():
            sol = read_solution(str(src.path if src.solver is None else saved), map_dirs=_dirs(src.path))
            if sol.plan is None or not sol.solved:
                raise FleetError("{}: no plan in it (solved=0)".format(src.path))
            plan, grid, goals, solver = sol.plan, sol.grid, sol.goals, sol.solver or "?"
        else:
            inst = read_instance(str(src.path), map_dirs=_dirs(src.path))
            result = solve(src.solver, inst.grid, inst.starts, inst.goals, deadline=Deadline(src.time_limit))
            if result.plan is None:
                raise FleetError("{}: {} found no plan: {}".format(src.path, src.solver, result.message))
            plan, grid, goals, solver = result.plan, inst.grid, inst.goals, src.solver
            write_solution(make_solution(grid, inst.map_file, plan, inst.starts, inst.goals, src.solver, True,
                                         round(result.comp_time_ms), instance=src.path.name), str(saved))
        report = validate_plan(plan, grid, goals=goals, strict_rotations=True)
        if not report.ok:
            raise FleetError("{}: robots cannot execute this plan: {}".format(src.path, report.errors[0].message))
        plans[src.name] = LoadedPlan(src.name, solver, plan.positions, grid.free, list(goals))
    return plans


def _dirs(path: Path) -> List[Path]:
    return [path.parent] + default_map_dirs()
