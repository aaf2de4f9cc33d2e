"""`fleetctl demo`: the lab scenario end to end, as far as the product goes today.

Loads the embedded lab (the thesis's 13 x 14 marker grid, its node ids), the
fleet from robot_definitions.txt and the lab's default instance, checks that
they agree, plans the run with a built-in solver (or takes a given plan, such
as a student's mapf-IR output on the lab map), validates the plan with the
one validator, prints what each robot will do, and executes the plan on
simulated robots with moderate random delays under both synchronization
strategies (the execution engine the manager uses), reporting collisions;
rotations, which robots cannot perform, are repaired first.
Later issues turn this into the virtual run on the robots' own ports.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import List

from fleet_common.errors import FleetError

from ..robot_plans import Names, add_repair_options, for_robots

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
    parser.add_argument("--delay-model", action="append", default=[], metavar="SPEC",
                        help="delays for the simulated execution, as `fleetctl simulate` takes "
                             "them (default: moderate random delays)")
    parser.add_argument("--log", type=Path, default=None, metavar="DIR",
                        help="also write each strategy's simulated run as a run folder in DIR "
                             "(for `fleetctl report`)")
    parser.add_argument("--plan", type=Path, default=None, metavar="SOLUTION",
                        help="run this mapf-IR solution on the lab map instead of planning one")
    add_repair_options(parser)


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

    if args.plan is not None:
        result = _given_plan(args.plan, grid)
    else:
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
    if plan.num_agents > len(robots):
        raise FleetError("the plan has {} agents but {} defines only {} robots".format(
            plan.num_agents, robots_path, len(robots)))
    starts, goals = (plan.starts, plan.goals) if args.plan is not None else (inst.starts, inst.goals)
    report = validate_plan(plan, grid, starts=starts, goals=goals)
    print("plan: {} in {:.0f} ms, soc={}, makespan={}, {}".format(
        result.solver, result.comp_time_ms, plan.soc, plan.makespan,
        "valid" if report.ok else "INVALID: " + report.errors[0].message))
    for line in _robot_lines(robots, plan, nodes):
        print("  " + line)
    if not report.ok:
        return 1
    from fleet_common.execution import PlanError
    from fleet_common.planning.repair import RepairError

    try:
        plan = for_robots(plan, grid, "plan", args, Names([r.id for r in robots[:plan.num_agents]]))
        return _execute(plan, args, result.solver, grid, inst)
    except (RepairError, PlanError) as err:
        print("plan: cannot be executed by robots: {}".format(err))
        return 1


def _given_plan(path: Path, grid):
    """A solution file on the lab map, as a solver's result."""
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.formats.solution import read_solution
    from fleet_common.lab import lab_map_path
    from fleet_common.planning import NO_SOLUTION, SOLVED, SolveResult

    sol = read_solution(path, map_dirs=[lab_map_path().parent] + default_map_dirs())
    if sol.grid != grid:
        raise FleetError("{}: its map {} is not the lab's map".format(path, sol.map_file))
    solver = "{} ({})".format(sol.solver or "?", path)
    if sol.plan is None or not sol.solved:
        return SolveResult(None, solver, NO_SOLUTION, message="the file records a failed run")
    return SolveResult(sol.plan, solver, SOLVED, comp_time_ms=float(sol.comp_time or 0))


def _execute(plan, args: argparse.Namespace, solver: str, grid, inst) -> int:
    """The plan on simulated robots under each strategy: what delays do to it."""
    from fleet_common.execution import STRATEGIES
    from fleet_common.delays import parse_delay_model
    from fleet_common.execution.simulate import simulate

    delays = parse_delay_model(args.delay_model, default="moderate")
    print("execution on simulated robots ({}; seed {}):".format(delays.describe(), args.seed))
    clean = True
    for name in sorted(STRATEGIES):
        result = simulate(plan, name, delays, seed=args.seed, journal=args.log is not None)
        missing = result.unfinished()
        clean = clean and not result.collisions and not missing
        print("  {}: executed makespan {:.1f} (plan {}), {} waits, collisions: {}, "
              "robots at goal: {} of {}".format(
                  name, result.metrics.makespan, plan.makespan, result.metrics.total_waits,
                  len(result.collisions), plan.num_agents - len(missing), plan.num_agents))
        if args.log is not None:
            print("    run log: {}".format(_log(args.log, plan, result, solver, grid, inst, delays, args.seed)))
    return 0 if clean else 1


def _log(parent: Path, plan, result, solver: str, grid, inst, delays, seed: int) -> Path:
    """A run folder for one strategy's run, with the plan written as a mapf-IR solution."""
    import tempfile

    from fleet_common.formats.solution import make_solution, write_solution
    from fleet_common.runlog.simulated import write_simulation

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "plan.txt"
        write_solution(make_solution(grid, inst.map_file, plan, plan.starts, plan.goals, solver, True, 0), str(path))
        lines = ["executed makespan {:.2f} (plan {}), sum of costs {:.2f}, collisions {}".format(
            result.metrics.makespan, plan.makespan, result.metrics.soc, len(result.collisions))]
        return write_simulation(parent, plan, result, path, delays.spec(), seed, lines)


def _robot_lines(robots, plan, nodes) -> List[str]:
    costs = plan.path_costs()
    lines = []
    for i in range(plan.num_agents):
        r = robots[i]
        start, goal = plan.path(i)[0], plan.goals[i]
        lines.append("robot {} ({}): node {} {} -> node {} {}, {} steps".format(
            r.id, r.colour, nodes.node_at(start), start, nodes.node_at(goal), goal, int(costs[i])))
    return lines
