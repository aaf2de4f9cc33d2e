"""`fleetctl demo`: the lab scenario end to end, as far as the product goes today.

Loads the embedded lab (the thesis's 13 x 14 marker grid, its node ids), the
fleet from robot_definitions.txt and the lab's default instance, checks that
they agree, plans the run with a built-in solver, validates the plan with the
one validator and prints what each robot will do. Later issues turn this into
the virtual run.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import List

from fleet_common.errors import FleetError

NAME = "demo"
HELP = "check and plan the embedded lab scenario and print a summary"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robots", type=Path, default=None,
                        help="robot definitions (default: the repository's robot_definitions.txt)")
    parser.add_argument("--instance", type=Path, default=None,
                        help="instance on the lab map (default: the lab's own)")
    parser.add_argument("-s", "--solver", default=None,
                        help="built-in solver (default: cbs, the optimal plan, falling back to "
                             "lacam if cbs runs out of time)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--time-limit", type=float, default=10.0, metavar="S")


def run(args: argparse.Namespace) -> int:
    from fleet_common.formats.instance import read_instance
    from fleet_common.lab import lab_instance_path, lab_map_path, node_table
    from fleet_common.planning import solve
    from fleet_common.planning.deadline import Deadline
    from fleet_common.robots import default_definitions_path, read_robot_definitions
    from fleet_common.validate import validate_plan

    robots_path = args.robots or default_definitions_path()
    robots = read_robot_definitions(robots_path)
    inst_path = args.instance or lab_instance_path()
    inst = read_instance(inst_path, map_dirs=[lab_map_path().parent])
    grid = inst.grid
    nodes = node_table()
    free = int(grid.free.sum())
    print("lab: {}x{} marker grid, {} nodes ({} cells without a marker)".format(
        grid.width, grid.height, free, grid.num_cells - free))
    print("fleet: {} robots from {}".format(len(robots), robots_path))
    if len(inst.starts) > len(robots):
        raise FleetError("{} has {} agents but {} defines only {} robots".format(
            inst_path, len(inst.starts), robots_path, len(robots)))

    # a demo should show the best plan: CBS is optimal and quick for a handful of robots
    for name in [args.solver] if args.solver else ["cbs", "lacam"]:
        result = solve(name, grid, inst.starts, inst.goals,
                       deadline=Deadline(args.time_limit), seed=args.seed)
        if result.solved:
            break
    if not result.solved or result.plan is None:
        print("plan: {} found no plan: {}".format(result.solver, result.message))
        return 3
    plan = result.plan
    report = validate_plan(plan, grid, starts=inst.starts, goals=inst.goals)
    print("plan: {} in {:.0f} ms, soc={}, makespan={}, {}".format(
        result.solver, result.comp_time_ms, plan.soc, plan.makespan,
        "valid" if report.ok else "INVALID: " + report.errors[0].message))
    for line in _robot_lines(robots, plan, nodes):
        print("  " + line)
    return 0 if report.ok else 1


def _robot_lines(robots, plan, nodes) -> List[str]:
    costs = plan.path_costs()
    lines = []
    for i in range(plan.num_agents):
        r = robots[i]
        start, goal = plan.path(i)[0], plan.goals[i]
        lines.append("robot {} ({}): node {} {} -> node {} {}, {} steps".format(
            r.id, r.colour, nodes.node_at(start), start, nodes.node_at(goal), goal, int(costs[i])))
    return lines
