"""`fleetctl validate`: is this solver output a plan the robots can execute?"""
from __future__ import annotations

import argparse
from pathlib import Path

from fleet_common.formats.solution import read_solution
from fleet_common.plan_loading import file_coordinates
from fleet_common.validate import FOLLOWING, ROTATION, validate_plan

from ..options import add_map_dir, map_dirs
from ..report import print_findings

NAME = "validate"
HELP = "check a mapf-IR solution: cells, moves, vertex and swap conflicts, rotations, header claims"
DESCRIPTION = (
    "Check a solution file against its map. Exit 0 and a summary with soc and makespan when "
    "the plan is valid; exit 1 listing what is wrong (or when the file records a failed run); "
    "exit 2 with FILE:LINE: message when the file cannot be read. Following moves and rotations "
    "(3 or more agents each entering the cell the next one leaves) are legal in mapf-IR and "
    "counted in the summary; robots cannot execute a rotation: `fleetctl repair` writes the plan "
    "without them (`fleetctl simulate` repairs them itself). "
    "Coordinates in messages are the file's own (mapf-IR files: origin top-left)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("solution", type=Path, help="solution file (mapf-IR solver output)")
    add_map_dir(parser)
    parser.add_argument("--strict-following", action="store_true",
                        help="treat following moves (entering a cell another agent leaves in the "
                             "same step) as errors, rotations included; mapf-IR allows them")
    parser.add_argument("--strict-rotations", action="store_true",
                        help="treat rotations (3 or more agents each entering the cell the next one "
                             "leaves, which robots cannot execute) as errors; mapf-IR allows them")
    parser.add_argument("-q", "--quiet", action="store_true", help="print only the summary line")


def run(args: argparse.Namespace) -> int:
    sol = read_solution(args.solution, map_dirs=map_dirs(args))
    name = str(args.solution)
    if sol.plan is None or not sol.solved:
        print("{}: no plan: solver {} did not solve it (solved={}, makespan={})".format(
            name, sol.solver or "?", int(bool(sol.solved)), sol.makespan))
        return 1
    show = file_coordinates(sol)
    report = validate_plan(sol.plan, sol.grid, starts=sol.starts, goals=sol.goals,
                           soc=sol.soc, makespan=sol.makespan,
                           strict_following=args.strict_following,
                           strict_rotations=args.strict_rotations, show=show)
    if not args.quiet:
        print_findings(name, report)
    plan = sol.plan
    if report.ok:
        notes = []
        following, rotations = report.count(FOLLOWING), report.count(ROTATION)
        if following:
            notes.append("{} following moves, legal in mapf-IR".format(following))
        if rotations:
            notes.append("{} rotations: robots cannot execute these".format(rotations))
        print("{}: valid: {} agents, soc={}, makespan={}{}".format(
            name, plan.num_agents, plan.soc, plan.makespan, " ({})".format("; ".join(notes)) if notes else ""))
        if rotations:
            print(_REPAIR_HINT.format(name))
        return 0
    print("{}: INVALID: {} problem(s) in a plan of {} agents, makespan {}".format(
        name, len(report.errors), plan.num_agents, plan.makespan))
    if report.count(ROTATION) and all(f.kind == ROTATION for f in report.errors):
        print(_REPAIR_HINT.format(name))
    return 1


_REPAIR_HINT = ("{0}: `fleetctl repair {0} -o OUT` makes it executable by robots (repairs the rotations; "
                "`fleetctl simulate` does so by itself)")
