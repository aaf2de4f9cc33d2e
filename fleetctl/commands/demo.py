"""`fleetctl demo`: the lab scenario end to end, on virtual robots, in the live console.

Loads the embedded lab (the thesis's 13 x 14 marker grid, its node ids), the
fleet from robot_definitions.txt and the lab's default instance, checks that
they agree, plans the run with a built-in solver (or takes a given plan, such
as a student's mapf-IR output on the lab map, its rotations repaired first),
validates the plan with the one validator, prints what each robot will do and
what the execution engine predicts under both synchronization strategies with
random delays. Then the live run (`fleetctl.live_demo`): the virtual fleet, the manager with ADG and
the live console, a window on a display or headless on a private Xvfb
recording frames; the run folder gets the run log, the frames and a summary.
`--plan-only` stops after the predictions.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import List

from fleet_common.arg_types import non_negative, positive, seed
from fleet_common.errors import FleetError

from ..robot_plans import Names, add_repair_options, for_robots

NAME = "demo"
HELP = "the lab scenario on virtual robots, steered by the manager, watched in the live console"
DESCRIPTION = (
    "Check and plan the embedded lab scenario, then run it: five virtual robots on 127.0.0.1 "
    "(moderate delays, one robot stalls so that another visibly waits for it), the manager with "
    "ADG and the live console, which presses Start and closes when the run is done (under two "
    "minutes). With a display the console is a window; without one it runs on a private Xvfb "
    "and records a frame per plan step. Prints where the run folder (run log, summary, frames) "
    "is. Ctrl-C stops every process it started.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robots", type=Path, default=None,
                        help="robot definitions (default: the repository's robot_definitions.txt)")
    parser.add_argument("--instance", type=Path, default=None,
                        help="instance on the lab map (default: the lab's own)")
    parser.add_argument("-s", "--solver", default=None,
                        help="built-in solver (default: whichever of cbs (the optimal plan, lacam if "
                             "cbs runs out of time) and pibt-turns (turns counted) the robots drive and "
                             "turn through sooner)")
    parser.add_argument("--seed", type=seed, default=0)
    parser.add_argument("--time-limit", type=positive, default=10.0, metavar="S")
    parser.add_argument("--delay-model", action="append", default=[], metavar="SPEC",
                        help="delays for the predicted execution, as `fleetctl simulate` takes "
                             "them (default: moderate random delays)")
    parser.add_argument("--log", type=Path, default=None, metavar="DIR",
                        help="run folders go in DIR: the live run's, and each predicted strategy's "
                             "simulated run (for `fleetctl report`); default: the live run's where "
                             "`fleetctl manager` puts them, none for the predictions")
    parser.add_argument("--plan", type=Path, default=None, metavar="SOLUTION",
                        help="run this mapf-IR solution on the lab map instead of planning one")
    add_repair_options(parser)
    parser.add_argument("--plan-only", action="store_true",
                        help="check, plan and predict; no live run")
    live = parser.add_argument_group("the live run")
    live.add_argument("--time-scale", type=positive, default=1.5, metavar="K",
                      help="the virtual robots run K times faster than real ones (default 1.5)")
    live.add_argument("--fleet-delays", default=None, metavar="SPEC",
                      help="the virtual fleet's --delay-model (default: moderate start delays "
                           "and slow moves)")
    live.add_argument("--stall", default="auto", metavar="auto|none|R:K:S",
                      help="the stall: auto (a move another robot soon depends on), none, or "
                           "robot R halts S s in its K-th move (default auto)")
    live.add_argument("--switch", default=None, metavar="STRATEGY",
                      help="the console switches the run to STRATEGY once a robot waits for the stalled "
                           "one, as an operator would; the automatic stall is then one STRATEGY can get "
                           "around (e.g. reorder: the waiting robot goes first)")
    live.add_argument("--reroute", choices=("off", "propose", "auto"), default="off",
                      help="the manager's reroute mode: robots a late robot holds up get new paths "
                           "(auto) or are proposed them in the console (propose); default off. Not off: "
                           "the automatic stall is one the manager reroutes around")
    live.add_argument("--headless", action="store_true",
                      help="no window even with a display: a private Xvfb, frames recorded")
    live.add_argument("--record", action="store_true",
                      help="record frames with a window too (the window must stay uncovered)")
    live.add_argument("--linger", type=non_negative, default=3.0, metavar="S",
                      help="seconds the window stays open after the run is done (default 3)")


def run(args: argparse.Namespace) -> int:
    from fleet_common.formats.instance import read_instance
    from fleet_common.lab import lab_instance_path, lab_map_path, node_table
    from fleet_common.plan_loading import solve_instance
    from fleet_common.robots import default_definitions_path, read_robot_definitions
    from fleet_common.plan_loading import file_coordinates
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

    show = file_coordinates(inst)  # what the robots' lines say: the file's own coordinates
    if args.plan is not None:
        result, show = _given_plan(args.plan, grid)
    elif args.solver is not None:
        result = solve_instance(grid, inst.starts, inst.goals, args.solver, args.time_limit, args.seed)
    else:
        result = _quickest_plan(grid, inst, args)
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
    for line in _robot_lines(robots, plan, nodes, show):
        print("  " + line)
    if not report.ok:
        return 1
    from fleet_common.execution import PlanError
    from fleet_common.planning.repair import RepairError

    try:
        plan = for_robots(plan, grid, "plan", args, Names([r.id for r in robots[:plan.num_agents]]))
        predicted = _execute(plan, args, result.solver, grid, inst)
    except (RepairError, PlanError) as err:
        print("plan: cannot be executed by robots: {}".format(err))
        return 1
    if args.plan_only or predicted != 0:
        return predicted
    return _live(inst, plan, result, robots, args)


def _quickest_plan(grid, inst, args: argparse.Namespace):
    """The plan the lab's robots finish soonest: CBS's, optimal in steps (LaCAM's if CBS runs out of
    time), or pibt-turns', which counts the turns the robots make in place; judged by the time its
    slowest robot needs for its own drives and turns (the virtual robots' pace, facing +x at the
    start as they do), CBS's on a tie."""
    from fleet_common.planning.pibt_turns import moves_and_turns, slowest_need
    from fleet_common.plan_loading import solve_instance
    from virtual_fleet.kinematics import QUARTER_OF_A_MOVE

    optimal = solve_instance(grid, inst.starts, inst.goals, None, args.time_limit, args.seed)
    turning = solve_instance(grid, inst.starts, inst.goals, "pibt-turns", args.time_limit, args.seed)
    solved = [r for r in (optimal, turning) if r.solved]
    if len(solved) < 2:
        return solved[0] if solved else optimal
    needs = [slowest_need(moves_and_turns(r.plan), QUARTER_OF_A_MOVE) for r in solved]
    best = 1 if needs[1] < needs[0] else 0
    print("plan chosen: {} over {}: its slowest robot drives and turns for {:.1f} moves' time, against "
          "{:.1f}".format(solved[best].solver, solved[1 - best].solver, needs[best], needs[1 - best]))
    return solved[best]


def _given_plan(path: Path, grid):
    """A solution file on the lab map, as a solver's result, and its own coordinates."""
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.formats.solution import read_solution
    from fleet_common.lab import lab_map_path
    from fleet_common.plan_loading import file_coordinates
    from fleet_common.planning import NO_SOLUTION, SOLVED, SolveResult

    sol = read_solution(path, map_dirs=[lab_map_path().parent] + default_map_dirs())
    show = file_coordinates(sol)
    if sol.grid != grid:
        raise FleetError("{}: its map {} is not the lab's map".format(path, sol.map_file))
    solver = "{} ({})".format(sol.solver or "?", path)
    if sol.plan is None or not sol.solved:
        return SolveResult(None, solver, NO_SOLUTION, message="the file records a failed run"), show
    return SolveResult(sol.plan, solver, SOLVED, comp_time_ms=float(sol.comp_time or 0)), show


def _live(inst, plan, result, robots, args: argparse.Namespace) -> int:
    import tempfile

    from fleet_common.formats.solution import make_solution, write_solution

    from ..live_demo import DemoSettings, run_live_demo

    if not args.time_scale > 0 or args.linger < 0:
        raise FleetError("--time-scale must be positive and --linger not negative")
    from fleet_common.execution import STRATEGIES

    if args.switch is not None and args.switch not in STRATEGIES:
        raise FleetError("--switch {}: expected one of {}".format(args.switch, ", ".join(sorted(STRATEGIES))))
    settings = DemoSettings(log_dir=args.log, time_scale=args.time_scale,
                            seed=args.seed, stall=args.stall, headless=args.headless,
                            record=args.record, linger=args.linger, switch=args.switch, reroute=args.reroute)
    if args.fleet_delays is not None:
        settings.delay_model = args.fleet_delays
    with tempfile.TemporaryDirectory(prefix="fleetcontrol-plan-") as folder:
        solution = Path(folder) / "lab_plan.txt"
        write_solution(make_solution(inst.grid, inst.map_file or "lab.map", plan, plan.starts, plan.goals,
                                     result.solver, True, int(result.comp_time_ms)), str(solution))
        return run_live_demo(solution, plan, robots, settings, grid=inst.grid)


def _execute(plan, args: argparse.Namespace, solver: str, grid, inst) -> int:
    """The plan on simulated robots under each strategy: what delays do to it."""
    from fleet_common.execution import STRATEGIES
    from fleet_common.delays import parse_delay_model
    from fleet_common.execution.simulate import simulate

    delays = parse_delay_model(args.delay_model, default="moderate")
    print("predicted execution on simulated robots ({}; seed {}):".format(delays.describe(), args.seed))
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


def _robot_lines(robots, plan, nodes, show) -> List[str]:
    """Each robot's way, its cells in the instance file's own coordinates (`show`)."""
    costs = plan.path_costs()
    lines = []
    for i in range(plan.num_agents):
        r = robots[i]
        start, goal = plan.path(i)[0], plan.goals[i]
        lines.append("robot {} ({}): node {} {} -> node {} {}, {} steps".format(
            r.id, r.colour, nodes.node_at(start), show(start), nodes.node_at(goal), show(goal), int(costs[i])))
    return lines
