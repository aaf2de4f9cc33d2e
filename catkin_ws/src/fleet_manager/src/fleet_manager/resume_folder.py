"""Finding and reading the run folder `fleetctl manager --resume` continues (the files; `resume.py`
decides from the records).

`--resume RUNDIR` names the folder; `--resume` alone takes the newest folder
in the --log folder whose run was of PLAN on the same robots, or drove them
to PLAN's starts (a way to the starts: PLAN is then the plan file of the
newest run of PLAN beside it, as it was loaded). A run that
ended with every robot home (`done`) has nothing to resume. The plans are
the folder's own (plan-1.txt, and the last replan's plan-N.txt), read with
the map folders plus the folder the plan first came from; the robots are
the run's, from the definitions given.
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

from fleet_common.errors import FleetError
from fleet_common.limits import loads_frame
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan, load_plan, pick_robots
from fleet_common.robots import RobotDefinition, read_robot_definitions
from fleet_common.runlog import read_run
from fleet_common.runlog.reader import RunFolder
from fleet_common.runlog.records import EVENTS_FILE, plan_file

from .resume import ResumePoint, read_resume

__all__ = ["load_resume", "last_run"]

Resumed = Tuple[List[RobotDefinition], LoadedPlan, Tuple[ResumePoint, Plan]]


def load_resume(args: argparse.Namespace, definitions: Path, map_dirs: Sequence[Path],
                log_dir: Optional[Path], last: bool) -> Resumed:
    """The fleet, the run's first plan and where the run stood, for `fleetctl manager --resume`
    (`last`: the newest run of args.plan in `log_dir`, else the folder args.resume)."""
    robots = read_robot_definitions(definitions)
    if last:
        if log_dir is None:
            raise FleetError("--resume without a folder looks in the --log folder; --no-log has none")
        fleet = pick_robots(robots, args.robots, str(definitions))
        folder = last_run(log_dir, str(args.plan), [r.id for r in fleet])
    else:
        folder = Path(args.resume)
    run = read_run(folder)
    if run.run.get("source") != "manager":
        raise FleetError("{}: a run of `fleetctl {}`, not of the manager: nothing to resume".format(
            folder, run.run.get("source")))
    point = read_resume(run)
    if point.phase == "done":
        raise FleetError("{}: that run is done (every robot reached its goal): nothing to resume; "
                         "start a new run without --resume".format(folder))
    way = point.for_plan is not None
    name = point.for_plan or str(run.run.get("plan_name") or run.run.get("plan"))
    if args.plan is not None and not last and not _same(args.plan, name):
        raise FleetError("{} ran {}{}, not {}: leave PLAN out to resume it".format(
            folder, "the way to the starts of " if way else "", name, args.plan))
    if args.robots is not None and list(args.robots) != point.robots:
        raise FleetError("{} ran on robots {}, not {}: leave --robots out to resume it".format(
            folder, ",".join(map(str, point.robots)), ",".join(map(str, args.robots))))
    fleet = pick_robots(robots, point.robots, str(definitions))
    dirs = [Path(name).parent, *map_dirs]
    first = load_plan(folder / str(run.run["plan"]), len(fleet), "the run's robots", dirs, repair=False)
    current = first.plan
    if way:  # the run goes on with the plan the way was for (`Run` drives the way first)
        first = _way_target(folder, name, point.robots, len(fleet), dirs)
    loaded = dataclasses.replace(first, name=name, note="resumed from {}".format(folder))
    if point.plan != run.run["plan"]:
        if not (folder / point.plan).is_file():
            raise FleetError("cannot resume {}: {} is missing, the plan its records run since {}; Go to starts "
                             "and run the plan again".format(folder, point.plan, _since(run, point.plan)))
        current = load_plan(folder / point.plan, len(fleet), "the run's robots", dirs, repair=False).plan
    unrecorded = folder / plan_file(point.plan_number + 1)
    if unrecorded.is_file():
        # written just before its `plan` record, which never reached the file (or was torn): the
        # hand-over to it was cut off, and the records cannot tell what it left
        raise FleetError("cannot resume {}: {} was written but the run log has no complete `plan` record for "
                         "it{}: the change to it was cut off; Go to starts and run the plan again".format(
                             folder, unrecorded.name, " (its last line is torn)" if run.torn else ""))
    return fleet, loaded, (point, current)


def _way_target(way: Path, name: str, robots: List[int], size: int, dirs: Sequence[Path]) -> LoadedPlan:
    """The plan the way to the starts in folder `way` was for (`name`), as it was loaded: the
    first plan file of the newest run folder of it beside and before `way`."""
    for folder in _run_folders(way.parent):
        if folder.name >= way.name:
            continue
        run = _first_record(folder / EVENTS_FILE)
        if _of(run, name, robots) and (folder / plan_file(1)).is_file():
            return load_plan(folder / plan_file(1), size, "the run's robots", dirs, repair=False)
    raise FleetError("cannot resume {}: it drove the robots to the starts of {}, whose run folder is not beside "
                     "it; start the manager on that plan and press Go to starts".format(way, name))


def _since(run: RunFolder, name: str) -> str:
    """When the run changed to plan file `name`, and why, in words."""
    record = next((r for r in run.of("plan") if r.get("file") == name), {})
    t = record.get("t")
    return "the {} at {:.1f} s".format(record.get("reason") or "change", t) if isinstance(t, (int, float)) \
        else "a change of plan"


def last_run(log_dir: Path, plan: str, robots: List[int]) -> Path:
    """The newest run folder in `log_dir` of `plan` on `robots` (FleetError naming what was
    looked for when there is none)."""
    for folder in _run_folders(log_dir):
        run = _first_record(folder / EVENTS_FILE)
        if _of(run, plan, robots) or _of(run, plan, robots, "to-starts"):
            return folder
    raise FleetError("no run of {} on robots {} in {} to resume (give the run folder: --resume RUNDIR)".format(
        plan, ",".join(map(str, robots)), log_dir))


def _run_folders(log_dir: Path) -> List[Path]:
    """The run folders in `log_dir`, newest first (their names begin with the time)."""
    return sorted((p for p in log_dir.iterdir() if (p / EVENTS_FILE).is_file()), reverse=True) \
        if log_dir.is_dir() else []


def _of(run: Optional[dict], plan: str, robots: List[int], purpose: str = "plan") -> bool:
    """`run` (a folder's first record) is the manager's run of `plan` on `robots` (`purpose`
    "to-starts": the way to its starts)."""
    named = "for_plan" if purpose == "to-starts" else "plan_name"
    return run is not None and run.get("k") == "run" and run.get("source") == "manager" \
        and run.get("purpose", "plan") == purpose and _same(Path(plan), str(run.get(named))) \
        and list(run.get("robots") or []) == robots


def _first_record(path: Path) -> Optional[dict]:
    try:
        with open(path, "rb") as f:
            line = f.readline(1024 * 1024)
        record = loads_frame(line.rstrip(b"\n"), max_bytes=1024 * 1024)
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def _same(path: Path, name: str) -> bool:
    """`path` names the plan the run recorded as `name` (as given, or the same file)."""
    if str(path) == name:
        return True
    try:
        return Path(path).resolve() == Path(name).resolve()
    except OSError:
        return False
