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
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

from fleet_common.formats.mapfile import parse_map
from fleet_common.formats.problem_file import map_file_of
from fleet_common.limits import MAX_FILE_BYTES, MAX_PLAN_TEXT, excerpt
from fleet_common.plan_loading import LoadedPlan, PlanLoadError, load_plan
from fleet_common.served_files import ServedFolders

__all__ = ["load_requested"]


def load_requested(plan_dirs: Sequence[Path], map_dirs: Sequence[Path], fleet_size: int,
                   path: Optional[str], text: Optional[str], name: str) -> LoadedPlan:
    """The plan of a console's `load` (`path` inside `plan_dirs`, or `text` named `name`); a
    FleetError (NotServed, PlanLoadError, a format error) saying why not."""
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
    return load_plan(Path(name), fleet_size, "the fleet", [], text=text, grid=grid)
