"""A plan a console asks the manager to load: its text sent in the request, or a file named inside
a folder the manager serves.

Neither way reaches anything else on the manager's machine
(`fleet_common.served_files`): a name is looked up only in the folders given
with `--plans DIR`, the plan's map (`map_file=`) only in those and in the
manager's map folders (--map-dir, $FLEETCONTROL_MAP_PATH, the shipped maps),
each file opened without blocking and only if it is a regular file inside
them. Both are limited to `MAX_PLAN_TEXT`. A refusal says what is wrong with
the request or the plan; it quotes the console's own text or a served file,
nothing else.

A solution is checked and loaded while the console waits for its answer. An
instance must be solved first, which takes up to the solver's time limit: the
manager's loop would stand still that long (no robot served, no State sent),
so `read_requested` gives back the instance, and `solve_requested` (run in a
worker thread, a `LoadJob`) plans it.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple, Optional, Sequence, Union

from fleet_common.formats.mapfile import parse_map
from fleet_common.formats.instance import Instance
from fleet_common.formats.problem_file import map_file_of, read_problem
from fleet_common.limits import MAX_FILE_BYTES, MAX_PLAN_TEXT, excerpt
from fleet_common.plan_loading import LoadedPlan, PlanLoadError, fit_fleet, from_instance, from_solution
from fleet_common.served_files import ServedFolders

__all__ = ["read_requested", "solve_requested", "Requested", "SOLVE_LIMIT"]

#: Seconds the built-in solver may take for an instance a console asks to load.
SOLVE_LIMIT = 10.0


class Requested(NamedTuple):
    """An instance a console asked to load, to be solved off the loop."""

    instance: Instance
    name: str
    fleet_size: int


def read_requested(plan_dirs: Sequence[Path], map_dirs: Sequence[Path], fleet_size: int,
                   path: Optional[str], text: Optional[str], name: str) -> Union[LoadedPlan, Requested]:
    """The plan of a console's `load` (`path` inside `plan_dirs`, or `text` named `name`), or, for an
    instance, the instance still to solve; a FleetError (NotServed, PlanLoadError, a format error)
    saying why not."""
    plans = ServedFolders(plan_dirs, MAX_PLAN_TEXT, "plan")
    if path is not None:
        real, text = plans.read(path)
        name, first = path, [real.parent]
    else:
        assert text is not None  # check_args: the one or the other
        if len(text) > MAX_PLAN_TEXT:
            raise PlanLoadError("{:,} characters of plan text; at most {:,}".format(len(text), MAX_PLAN_TEXT))
        first = []
    map_file = map_file_of(text)
    grid = None
    if map_file:
        maps = ServedFolders(list(first) + list(plan_dirs) + list(map_dirs), MAX_FILE_BYTES, "map")
        found = maps.find(map_file)
        if found is None:
            raise PlanLoadError("{}: map_file {} is not in the folders this manager serves maps from "
                                "(--plans, --map-dir)".format(name, excerpt(map_file)))
        real_map, map_text = found
        grid = parse_map(map_text, str(real_map)).grid
    problem = read_problem(Path(name), [], text, grid)
    if isinstance(problem, Instance):
        if len(problem.starts) != fleet_size:  # said now, not after the solver's time
            raise PlanLoadError("{} has {} agents but the fleet has {} robots; plan agent i runs on the "
                                "i-th robot, so the counts must match".format(name, len(problem.starts), fleet_size))
        return Requested(problem, name, fleet_size)
    return fit_fleet(from_solution(problem, name), fleet_size, "the fleet")


def solve_requested(requested: Requested, time_limit: float = SOLVE_LIMIT) -> LoadedPlan:
    """The plan of a requested instance (what a `LoadJob`'s worker runs)."""
    return fit_fleet(from_instance(requested.instance, requested.name, None, time_limit),
                     requested.fleet_size, "the fleet")
