"""`fleetctl simulate`: run a plan against simulated robots before booking the lab."""
from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Dict, List

from fleet_common.arg_types import ROBOT_SIZE_HELP, count, robot_size, seed
from fleet_common.errors import FleetError
from fleet_common.execution import STRATEGIES, PlanError
from fleet_common.delays import FORMS, parse_delay_model
from fleet_common.execution.reroute import SCOPES, RerouteRule
from fleet_common.execution.simulate import SimResult, simulate
from fleet_common.execution.trace import SWAP, VERTEX
from fleet_common.plan_loading import file_coordinates
from fleet_common.planning.repair import RepairError
from fleet_common.robots import read_robot_size

from ..options import add_map_dir
from ..robot_plans import Names, add_repair_options, for_robots, valid_solution

NAME = "simulate"
HELP = "run a solution on simulated robots with delays: metrics, collisions, who waited for whom"
DESCRIPTION = (
    "Execute a mapf-IR solution with the execution engine against simulated robots in one "
    "process. Every move takes a nominal time of 1 (one plan step) times a random factor, "
    "with random stalls, as the delay model says. Prints the executed makespan and sum of "
    "costs, the waits, the number of collisions in the executed trace (vertex and swap, from "
    "the executed positions over continuous time) and whether every enabled robot reached its "
    "goal. Rotations (3 or more agents each entering the cell the next one leaves in one step), "
    "which robots cannot perform, are repaired first, in one line (--no-repair refuses the plan "
    "instead). The plan runs on the lab fleet, its robots named by their robot_definitions.txt "
    "ids, when --definitions is given or when it is on the embedded lab map with no more agents "
    "than the default definitions have robots; otherwise robots are numbered by agent index "
    "from 0. Exit 0 when there was no collision and every enabled robot reached its goal, 1 "
    "otherwise (also for invalid plans and plans robots cannot execute), 2 for unreadable input."
)


class SimulateOptionError(FleetError):
    """A command-line value that does not fit the plan."""


def _disable(text: str) -> tuple:
    m = re.fullmatch(r"(\d+)@(\d+)", text.strip())
    if not m:
        raise argparse.ArgumentTypeError("expected ROBOT@STEP (e.g. 3@10), got '{}'".format(text))
    return int(m.group(1)), int(m.group(2))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("solution", type=Path, help="solution file (mapf-IR solver output)")
    add_map_dir(parser)
    parser.add_argument("--strategy", choices=list(STRATEGIES), default="adg",
                        help="synchronization strategy: " + "; ".join(
                            "{}: {}".format(name, cls.summary) for name, cls in STRATEGIES.items())
                        + " (default adg)")
    parser.add_argument("--lookahead", type=count, default=None, metavar="K",
                        help="adg: actions a robot may be sent ahead (default 1)")
    parser.add_argument("--delay-model", action="append", default=[], metavar="SPEC",
                        help="how long moves take, the same language as virtual-fleet's (repeatable, "
                             "they combine): " + FORMS + "; default moderate (factor=0.8-1.5,stall=0.02:3)")
    parser.add_argument("--seed", type=seed, default=None,
                        help="random seed of the delays (default: the model's seed=, else 0)")
    parser.add_argument("--disable", action="append", default=[], type=_disable, metavar="ROBOT@STEP",
                        help="robot ROBOT (its id on the lab fleet, else the 0-based agent index) stops "
                             "for good where the plan has it at step STEP, like a dead battery (repeatable)")
    parser.add_argument("--per-robot", action="store_true",
                        help="also print a line per robot: moves, arrival, waits, who it waited for")
    parser.add_argument("--log", type=Path, default=None, metavar="DIR",
                        help="also write the run as a run folder DIR/<timestamp>/ (plan, events.jsonl "
                             "in plan steps) for `fleetctl report`")
    parser.add_argument("--definitions", type=Path, default=None, metavar="FILE",
                        help="run on the fleet of this robot definitions file (agent i is the robot on "
                             "its line i, named by its id); by default a plan on the lab map with at most "
                             "as many agents as robot_definitions.txt has robots runs on the lab fleet")
    parser.add_argument("--robot-size", type=robot_size, default=None, metavar="D:M|cell",
                        help=ROBOT_SIZE_HELP)
    parser.add_argument("--reroute", choices=["none", "auto"], default="none",
                        help="auto: give robots that a late robot holds up new paths around it, mid-run, "
                             "when the rule of fleet_common.execution.reroute says it pays (default none)")
    parser.add_argument("--reroute-scope", choices=list(SCOPES), default="held",
                        help="whom a reroute may give new paths: held (the robots a late robot holds up, "
                             "default) or all (every robot replanned from where it is by PIBT, when the "
                             "predicted makespan drops: fleet_common.execution.reroute_all)")
    parser.add_argument("--trim", action="store_true",
                        help="trim each robot's path to the fewest moves that bring it in no later, around "
                             "the others, before the run, and the held scope's reroutes' plans before their "
                             "hand-over (fleet_common.planning.trim; --reroute-scope all trims its own plans "
                             "whatever this says); each robot's k-th move keeps the delay drawn for its k-th "
                             "move untrimmed, so runs with and without compare on one seed")
    add_repair_options(parser)


def run(args: argparse.Namespace) -> int:
    sol = valid_solution(args, "not simulated")
    if sol is None:
        return 1
    name, plan = str(args.solution), sol.plan
    show = file_coordinates(sol)
    names = Names.of(sol.grid, plan.num_agents, args.definitions)
    try:
        plan = for_robots(plan, sol.grid, name, args, names, checked=True)
    except RepairError as err:
        print("{}: cannot be executed by robots: {}".format(name, err))
        return 1
    delays = parse_delay_model(args.delay_model, default="moderate")
    delays.check_robots(plan.num_agents)
    seed = args.seed if args.seed is not None else (delays.seed or 0)
    disable: Dict[int, int] = {}
    for robot, step in args.disable:
        agent = names.index(robot)
        if agent is None or agent >= plan.num_agents:
            raise SimulateOptionError("--disable {}@{}: the plan has robots {}".format(
                robot, step, _robots(names, plan.num_agents)))
        disable[agent] = step
    settings = {} if args.lookahead is None else {"lookahead": args.lookahead}
    size = args.robot_size or read_robot_size(args.definitions)
    if args.reroute_scope != "held" and args.reroute == "none":
        raise SimulateOptionError("--reroute-scope {} needs --reroute auto (it says whom a reroute may give "
                                  "new paths)".format(args.reroute_scope))
    if args.reroute != "none" and args.log is not None:
        raise SimulateOptionError("--log with --reroute {}: a run folder records one plan, and a rerouted run "
                                  "changes plans (run without --log, or with --reroute none)".format(args.reroute))
    try:
        result = simulate(plan, args.strategy, delays, seed=seed, disable=disable, show=show,
                          journal=args.log is not None, size=size, grid=sol.grid, trim=args.trim,
                          reroute=RerouteRule(scope=args.reroute_scope, trim=args.trim)
                          if args.reroute == "auto" else None, **settings)
    except PlanError as err:
        print("{}: cannot be executed by robots: {}".format(name, err))
        return 1
    lines = _summary(result, plan.makespan, plan.soc, delays.describe(), seed, names)
    if result.trimmed is not None:
        lines.insert(1, result.trimmed.describe())
        plan = result.trimmed.plan  # the plan that ran
    for line in lines:
        print(line)
    if args.per_robot:
        for line in _per_robot(result, names):
            print(line)
    if args.log is not None:
        print("run log: {}".format(_log(args.log, sol, plan, result, delays.spec(), seed, lines)))
    return 0 if not result.collisions and not result.unfinished() else 1


def _log(parent: Path, sol, plan, result: SimResult, delays: str, seed: int, lines: List[str]) -> Path:
    """The run folder, with the plan that ran (the repaired one, if it was repaired)."""
    import tempfile

    from fleet_common.formats.solution import write_solution
    from fleet_common.runlog.simulated import write_simulation

    if plan is sol.plan:
        return write_simulation(parent, plan, result, sol.path, delays, seed, lines)
    with tempfile.TemporaryDirectory() as tmp:
        sol.replace_plan(plan)
        write_solution(sol, str(Path(tmp) / Path(sol.path).name))
        return write_simulation(parent, plan, result, Path(tmp) / Path(sol.path).name, delays, seed, lines)


def _robots(names: Names, n: int) -> str:
    return names.all(list(range(n))) if names.lab else "0..{}".format(n - 1)


def _summary(result: SimResult, makespan: int, soc: int, delays: str, seed: int, names: Names) -> List[str]:
    engine, m = result.engine, result.metrics
    n = engine.run.num_agents
    missing = result.unfinished()
    partial = "" if not missing else " (robots that reached their goals only)"
    lines = [
        "robots: {}, moves: {}, plan makespan {}, plan soc {}".format(
            n, len(result.durations), makespan, soc),  # the moves of the plan given (fates)
        "fleet: " + names.describe(),
        "strategy: {}; delays: {}; seed {}".format(engine.strategy.describe(), delays, seed),
        "executed makespan: {:.2f} (time unit: one nominal move, one plan step){}".format(
            m.makespan, partial),
        "sum of costs: {:.2f}{}".format(m.soc, partial),
        "waits: {} by {} robots, {:.2f} in total: forced {:.2f} (the robot ahead was in or on its way "
        "into the cell, or it was the robot's goal), avoidable {:.2f}".format(
            m.total_waits, sum(1 for r in m.agents if r.waits), m.total_wait_time, m.total_forced_time,
            m.total_avoidable_time) + ("" if not m.total_held_time else
                                       ", held by the operator {:.2f}".format(m.total_held_time)),
        "lower bound: {:.2f} (every robot alone, with its own delays); executed makespan {:.2f}x it".format(
            result.lower_bound, m.makespan / result.lower_bound if result.lower_bound > 0 else 1.0),
    ]
    if result.rerouter is not None:
        lines.append(_reroutes(result, names))
    if engine.run.passes:
        lines.append("passes: {} (a robot went into a cell before a late one that was due first)".format(
            len(engine.run.passes)))
    pairs = m.blocking_pairs()[:5]
    if pairs:
        lines.append("longest waits: " + "; ".join(
            "robot {} waited {:.2f} for robot {}".format(names(r), t, names(q)) for t, r, q in pairs))
    for robot, when in sorted(result.disabled_at.items()):
        lines.append("disabled: robot {} at t={:.2f}".format(names(robot), when))
    for robot, blocked in sorted(engine.blocked_by().items()):
        if blocked:
            lines.append("robot {} is out; waiting for it, directly or behind others: robot{} {}".format(
                names(robot), "s" if len(blocked) > 1 else "", names.all(blocked)))
    lines += _safety(result, names)
    enabled = n - len(engine.out_agents())
    reached = "reached goal: {} of {} enabled robots".format(enabled - len(missing), enabled)
    if missing:
        reached += "; not reached: robot{} {}".format("s" if len(missing) > 1 else "", names.all(missing))
    lines.append(reached)
    return lines


def _reroutes(result: SimResult, names: Names) -> str:
    """How many reroutes happened, how many robots they moved, and the first few."""
    done = result.reroutes
    if not done:
        if result.rerouter is not None and result.rerouter.rule.scope == "all":
            return "reroutes: none (no late robot where a new plan for every robot paid)"
        return "reroutes: none (no robot held up by a late one where a new path paid)"
    moved = sorted({r for _, rr in done for r in rr.agents})
    line = "reroutes: {}, {} robot{} given new paths ({} different: {})".format(
        len(done), sum(len(rr.agents) for _, rr in done), "" if sum(len(rr.agents) for _, rr in done) == 1 else "s",
        len(moved), names.all(moved[:8]) + (" and {} more".format(len(moved) - 8) if len(moved) > 8 else ""))
    return line + "; first: " + "; ".join("t={:.2f} {}".format(t, rr.describe(names)) for t, rr in done[:3])


def _safety(result: SimResult, names: Names) -> List[str]:
    """The robots' size, how close they came, and what broke the rule (cell or metres)."""
    size = result.size
    assert size is not None and result.safety is not None
    lines = ["robot size: " + size.describe()]
    c = result.closest
    if c is None:
        lines.append("closest approach: no two robots within a cell ({:.3f} m) of each other".format(size.cell))
    else:
        lines.append("closest approach: {:.3f} m ({:.2f} cells), robots {} and {} at t={:.2f} near ({:.2f}, "
                     "{:.2f})".format(c.distance * size.cell, c.distance, names(c.agents[0]),
                                      names(c.agents[1]), c.time, c.place[0], c.place[1]))
    if size.cell_sized:
        vertex = sum(1 for c in result.collisions if c.kind == VERTEX)
        swap = sum(1 for c in result.collisions if c.kind == SWAP)
        lines.append("collisions: {} (vertex {}, swap {})".format(len(result.collisions), vertex, swap))
    else:
        lines.append("collisions: {} (pairs of robots closer than {:.3f} m)".format(
            len(result.collisions), size.safe))
    return lines


def _per_robot(result: SimResult, names: Names) -> List[str]:
    lines = ["robot  moves  arrival  waits  wait time  waited for robot (time)"]
    for r, rm in enumerate(result.metrics.agents):
        arrival = "-" if rm.arrival is None else "{:.2f}".format(rm.arrival)
        who = ", ".join("{} ({:.2f})".format(names(q), t) for q, t in sorted(
            rm.blocked_by.items(), key=lambda kv: -kv[1]))
        lines.append("{:>5}  {:>5}  {:>7}  {:>5}  {:>9.2f}  {}".format(
            names(r), rm.moves, arrival, rm.waits, rm.wait_time, who or "-"))
    return lines
