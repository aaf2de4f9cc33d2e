"""The plans of an experiment, made once before the cells run.

A solution file is read and checked; an instance is solved by the built-in
solver named (seed 0), and the plan is written to OUT/plans/NAME.txt so that
a resumed sweep runs on the very same plan instead of solving again. Plans
robots cannot execute (conflicts, rotations) stop the sweep before it starts.
Loading and checking is `fleet_common.plan_loading`'s, as for every command
that runs a plan; a `LoadedPlan` is plain data, so cells take it to other
processes.
"""
from __future__ import annotations

from pathlib import Path
from typing import Dict, List

from fleet_common.formats import default_map_dirs
from fleet_common.formats.instance import read_instance
from fleet_common.formats.solution import read_solution, write_solution
from fleet_common.plan_loading import LoadedPlan, check_valid, from_instance, from_solution

from .spec import PlanSource

__all__ = ["load_plans"]


def load_plans(sources: List[PlanSource], out: Path) -> Dict[str, LoadedPlan]:
    folder = out / "plans"
    folder.mkdir(parents=True, exist_ok=True)
    plans: Dict[str, LoadedPlan] = {}
    for src in sources:
        saved = folder / (src.name + ".txt")
        name = str(src.path)
        if src.solver is None or saved.is_file():
            sol = read_solution(str(src.path if src.solver is None else saved), map_dirs=_dirs(src.path))
            plans[src.name] = from_solution(sol, name, repair=False, strict_rotations=True)
        else:
            inst = read_instance(name, map_dirs=_dirs(src.path))
            loaded = from_instance(inst, name, src.solver, src.time_limit)
            check_valid(loaded.plan, loaded.grid, name, goals=loaded.goals, show=loaded.show,
                        strict_rotations=True)
            write_solution(loaded.solution, str(saved))
            plans[src.name] = loaded
    return plans


def _dirs(path: Path) -> List[Path]:
    return [path.parent] + default_map_dirs()
