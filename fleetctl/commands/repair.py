"""`fleetctl repair`: a mapf-IR plan with its rotations repaired, so that robots can run it."""
from __future__ import annotations

import argparse
from pathlib import Path

from fleet_common.arg_types import positive
from fleet_common.formats.solution import write_solution
from fleet_common.planning.repair import DEFAULT_TIME_LIMIT, RepairError, repair_rotations

from ..options import add_map_dir
from ..robot_plans import valid_solution

NAME = "repair"
HELP = "repair a solution's rotations (robots cannot perform them); writes the same format"
DESCRIPTION = (
    "Write SOLUTION with its rotations (3 or more agents each entering the cell the next one "
    "leaves in one step, legal in mapf-IR, impossible for robots) repaired: the agents of each "
    "rotation get new paths over a few steps around it, as close to the original as can be, "
    "without rotations. The output has the input's format, orientation and header lines, with soc "
    "and makespan updated, so mapf-IR's visualizer opens it too. One line says what changed. "
    "Exit 0 when OUT is written (also when there was nothing to repair), 1 when the plan is "
    "invalid or a rotation cannot be repaired, 2 for unreadable input."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("solution", type=Path, help="solution file (mapf-IR solver output)")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="OUT",
                        help="where to write the repaired solution (may be SOLUTION itself)")
    add_map_dir(parser)
    parser.add_argument("--time-limit", type=positive, default=DEFAULT_TIME_LIMIT, metavar="S",
                        help="give up after S seconds (default {:g})".format(DEFAULT_TIME_LIMIT))


def run(args: argparse.Namespace) -> int:
    sol = valid_solution(args, "not repaired")
    if sol is None:
        return 1
    name = str(args.solution)
    try:
        result = repair_rotations(sol.plan, sol.grid, deadline=args.time_limit, checked=True)
    except RepairError as err:
        print("{}: {}".format(name, err))
        return 1
    if result.repaired:
        sol.replace_plan(result.plan)
    write_solution(sol, str(args.output))
    print("{}: {} ({:.0f} ms) -> {}".format(name, result.describe(), result.comp_time_ms, args.output))
    return 0
