"""`fleetctl trace RUNDIR`: a run folder as a mapf-IR solution, and the run's summary from the log alone.

Writes where the robots really were, one row per --dt seconds of the run, as
a solution file in the orientation of the run's plan (so the player and
mapf-IR's visualizer play it beside the plan), and prints the figures the
manager printed at the end, computed again from events.jsonl: arrivals,
executed makespan, sum of costs, waits, collisions, the closest two robots
came. A run that did not end cleanly (a crash) is traced as far as it got.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from fleet_common.arg_types import positive

NAME = "trace"
HELP = "a run folder as a mapf-IR solution (where robots really were) and its summary"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", type=Path, metavar="RUNDIR", help="a run folder (manager or simulate --log)")
    parser.add_argument("-o", "--output", type=Path, default=None, metavar="FILE",
                        help="solution file to write (default RUNDIR/executed.txt)")
    parser.add_argument("--dt", type=positive, default=None, metavar="S",
                        help="run time per row (default: short enough that no robot moves more "
                             "than one cell from row to row)")


def run(args: argparse.Namespace) -> int:
    from fleet_common.formats.solution import make_solution, read_solution, write_solution
    from fleet_common.runlog import read_run
    from fleet_common.runlog.executed import traced_plan
    from fleet_common.runlog.summary import SummaryBuilder

    from ..options import map_dirs

    folder = read_run(args.run)
    builder = SummaryBuilder()
    for record in folder.records:
        builder.feed(record)
    plan_path = folder.plan_files()[0]
    planned = read_solution(str(plan_path), map_dirs=[Path(plan_path).parent] + map_dirs(
        argparse.Namespace(map_dir=[])))
    starts = [tuple(c) for c in folder.run.get("starts") or planned.starts]
    executed, dt = traced_plan(folder, starts, args.dt)
    ends = [tuple(int(v) for v in c) for c in executed.positions[-1]]
    sol = make_solution(planned.grid, planned.map_file or "", executed, starts, ends,
                        "fleetcontrol-executed-{:g}s".format(dt), True, 0)
    sol.orientation = planned.orientation
    out = args.output or args.run / "executed.txt"
    write_solution(sol, str(out))
    print("{}: {} robots, {} rows of {:g} s{}".format(
        out, executed.num_agents, executed.makespan + 1, dt,
        " (the log ends early: the run did not end cleanly)" if folder.torn or not folder.ended else ""))
    for line in builder.summary().lines():
        print(line)
    return 0

