"""`fleetctl solve`: plan an instance with a built-in solver or mapf-IR, write mapf-IR's output."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import List, Tuple

from fleet_common.arg_types import at_least_one, count, positive, seed
from fleet_common.errors import FleetError
from fleet_common.formats.instance import DEFAULT_MAX_TIMESTEP, Instance, read_instance
from fleet_common.formats.solution import format_solution, make_solution, write_solution
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.planning import SOLVER_NAMES, solve
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.dist_table import lower_bounds
from fleet_common.planning.result import SolveResult

from .. import filekinds
from ..options import add_map_dir, map_dirs

NAME = "solve"
#: what follows `--` reaches us unparsed, as args.passthrough (options for mapf-IR)
PASSTHROUGH = True
HELP = "plan an instance (or a .scen) with pibt, lacam, cbs, ecbs, pp, pibt-turns or mapf-IR; write a solution"
#: mapf-IR's variable naming its binary (fleet_common.planning.mapf_ir.APP_ENV; that module is
#: imported only when a mapf-IR solver runs)
APP_ENV = "MAPF_IR_APP"
MAPF_IR_PREFIX = "mapf-ir:"
DEFAULT_SOLVER = "lacam"
#: Time limit when neither --time-limit nor the instance's max_comp_time gives one.
DEFAULT_TIME_LIMIT_S = 60.0
DESCRIPTION = (
    "Plan INSTANCE (a mapf-IR instance, or a MovingAI .scen with --map and --agents) and write "
    "the plan as a mapf-IR solution file (mapf-IR orientation, every header key mapf-IR writes, "
    "comp_time in ms) that mapf-IR's visualizer and `fleetctl validate` read. Default output: "
    "<instance stem>.<solver>.txt in the current folder, e.g. arena_300agents_1.lacam.txt "
    "(`-o -` writes to stdout). Prints one summary line. Solvers: pibt (fast, may get stuck), "
    "lacam (default; complete, PIBT-guided; --anytime keeps improving it until the time limit, "
    "or until --memory-limit, since it keeps every configuration it reaches), "
    "cbs (optimal sum of costs, dozens of agents), ecbs (sum of costs within --w times the optimum), "
    "pp (prioritized planning), or mapf-ir:NAME to run mapf-IR's solver NAME (PIBT, CBS, ECBS, "
    "IR_HYBRID, ...) with the binary from --mapf-ir or ${}; options after `--` go to it "
    "unchanged, e.g. `-s mapf-ir:ECBS -- -w 1.2`. The time limit defaults to the instance's "
    "max_comp_time, else {:.0f} s; the step limit (a longer plan is no solution) to its "
    "max_timestep, else {}; the seed to the instance's seed, else 0. comp_time counts all the "
    "solver did for the instance, distance tables included, as mapf-IR's does. The built-in solvers "
    "plan for robots: no rotations (3 or more agents each entering the cell the next one leaves, "
    "which robots cannot execute) unless --allow-rotations asks for mapf-IR's semantics; a plan "
    "with rotations (from mapf-IR) says how many in the summary. Exit 0 with a plan; "
    "3 when no plan was found within the limit (a failed output, solved=0 and makespan=-1, is "
    "still written); 1 when mapf-IR failed; 2 for unreadable input (FILE:LINE: message), an "
    "invalid problem (the agent named) or a wrong command line."
).format(APP_ENV, DEFAULT_TIME_LIMIT_S, DEFAULT_MAX_TIMESTEP)


def solver_name(text: str) -> str:
    if text.startswith(MAPF_IR_PREFIX) and len(text) > len(MAPF_IR_PREFIX):
        return text
    if text in SOLVER_NAMES:
        return text
    raise argparse.ArgumentTypeError("unknown solver {!r}; choose from {} or mapf-ir:NAME".format(
        text, ", ".join(SOLVER_NAMES)))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("instance", type=Path, metavar="INSTANCE", help="mapf-IR instance or .scen file")
    parser.add_argument("-s", "--solver", type=solver_name, default=DEFAULT_SOLVER, metavar="SOLVER",
                        help="{} or mapf-ir:NAME (default: {})".format("|".join(SOLVER_NAMES), DEFAULT_SOLVER))
    parser.add_argument("-o", "--output", metavar="OUT",
                        help="solution file to write; '-' for stdout (default: <instance stem>.<solver>.txt)")
    parser.add_argument("--time-limit", type=positive, metavar="S",
                        help="seconds (default: the instance's max_comp_time, else {:.0f})".format(
                            DEFAULT_TIME_LIMIT_S))
    parser.add_argument("--max-timestep", type=count, metavar="T",
                        help="longest plan accepted, in steps (default: the instance's max_timestep, else {})".format(
                            DEFAULT_MAX_TIMESTEP))
    parser.add_argument("--seed", type=seed, metavar="N", help="random seed (default: the instance's seed, else 0)")
    parser.add_argument("--anytime", action="store_true",
                        help="lacam: keep improving the plan until the time limit (LaCAM*); prints the sum of "
                             "costs at each improvement")
    parser.add_argument("--memory-limit", type=positive, metavar="MB",
                        help="lacam: stop searching when this process's memory reaches MB, keeping the best plan "
                             "so far (it keeps every configuration it reaches; default: half of the memory the "
                             "process may use)")
    parser.add_argument("--w", type=at_least_one, metavar="W",
                        help="ecbs: suboptimality bound, the plan's sum of costs is at most W x the optimum "
                             "(default: 1.1)")
    parser.add_argument("--allow-rotations", action="store_true",
                        help="built-in solvers: allow rotations, as mapf-IR does (robots cannot execute "
                             "them; default: rotation-free plans)")
    add_map_dir(parser)
    parser.add_argument("--map", type=Path, metavar="MAP", help=".scen input: the map (default: the scen's map name, searched)")
    parser.add_argument("--agents", type=count, metavar="N", help=".scen input: use the first N entries (default: all)")
    parser.add_argument("--mapf-ir", type=Path, metavar="PATH", dest="mapf_ir",
                        help="mapf-IR's `app` binary (default: ${})".format(APP_ENV))
    parser.add_argument("--mapf-ir-map-dir", type=Path, metavar="D",
                        help="the map folder mapf-IR was compiled with (default: <app's folder>/../map)")
    parser.usage = "fleetctl solve INSTANCE [options] [-- MAPF-IR-OPTION ...]"


def run(args: argparse.Namespace) -> int:
    inst, map_file = _load(args)
    if inst.is_random:
        raise FleetError("{}: random_problem=1 lets mapf-IR draw starts and goals itself; list them "
                         "in the file (mapf-IR's `app -P` writes such a file)".format(args.instance))
    limit = args.time_limit
    if limit is None:
        limit = inst.max_comp_time / 1000.0 if inst.max_comp_time else DEFAULT_TIME_LIMIT_S
    seed = args.seed if args.seed is not None else (inst.seed or 0)
    steps = args.max_timestep if args.max_timestep is not None else (inst.max_timestep or DEFAULT_MAX_TIMESTEP)
    grid, starts, goals = inst.grid, inst.starts, inst.goals
    try:
        result = _solve(args, inst, limit, seed, steps)
    except FleetError as err:
        if not _mapf_ir_failed(err):
            raise
        print("fleetctl solve: {}".format(err), file=sys.stderr)
        return 1
    # after the solve: its distance tables (which comp_time counted) give the bounds
    lb_soc, lb_makespan = lower_bounds(grid, starts, goals)
    # mapf-IR's IR solvers log their refinement as iter= lines; keep them
    extra: List[Tuple[str, object]] = [("iter", v) for v in result.stats.get("iter_lines", [])]
    sol = make_solution(grid, map_file, result.plan, starts, goals, solver=result.solver,
                        solved=result.solved, comp_time=int(round(result.comp_time_ms)), lb_soc=lb_soc,
                        lb_makespan=lb_makespan, instance=str(args.instance), extra=extra)
    out = args.output or "{}.{}.txt".format(args.instance.stem, args.solver.replace(":", "-"))
    to_stdout = out == "-"
    if to_stdout:
        sys.stdout.write(format_solution(sol))
        sys.stdout.flush()
    else:
        write_solution(sol, out)
    where = "stdout" if to_stdout else out
    if not result.solved:
        print("fleetctl solve: no plan: {}; wrote the failed output to {}".format(_why_no_plan(result), where),
              file=sys.stderr)
        return 3
    report = sys.stderr if to_stdout else sys.stdout
    for ms, soc in result.stats.get("anytime", []):
        print("  soc {} at {:.0f} ms".format(soc, ms), file=report)
    if result.stats.get("stopped") == "memory":
        print("  stopped at the memory limit ({:.0f} MB, --memory-limit) after {} configurations: the plan "
              "is the best found by then".format(result.stats["memory_limit_mb"], result.stats["explored"]),
              file=report)
    print(_summary(result, result.plan, grid, lb_soc, lb_makespan, where), file=report)
    return 0


def _why_no_plan(result: SolveResult) -> str:
    if result.stats.get("stopped") == "memory":
        return "{} reached the memory limit of {:.0f} MB (--memory-limit) after {} configurations and {:.0f} ms".format(
            result.solver, result.stats["memory_limit_mb"], result.stats["explored"], result.comp_time_ms)
    return "{} {} after {:.0f} ms{}".format(
        result.solver, "ran out of time" if result.status == "timeout" else "found no solution",
        result.comp_time_ms, " ({})".format(result.message) if result.message else "")


def _mapf_ir_failed(err: FleetError) -> bool:
    """Did mapf-IR run and fail? (Its module is imported only when a mapf-IR solver ran.)"""
    mapf_ir = sys.modules.get("fleet_common.planning.mapf_ir")
    return mapf_ir is not None and isinstance(err, mapf_ir.MapfIrFailed)


def _load(args: argparse.Namespace) -> Tuple[Instance, str]:
    """The instance and the map_file= to write; a .scen is turned into an instance."""
    kind = filekinds.sniff(args.instance)
    if kind == filekinds.INSTANCE:
        if args.map is not None or args.agents is not None:
            raise FleetError("--map and --agents are for .scen input; {} is an instance".format(args.instance))
        inst = read_instance(args.instance, map_dirs=map_dirs(args))
        return inst, inst.map_file
    if kind == filekinds.SCEN:
        from fleet_common.formats.mapfile import read_map
        from fleet_common.formats.mapsearch import resolve_map
        from fleet_common.formats.scen import read_scen, scen_to_instance

        scen = read_scen(args.instance)
        if args.map is not None:
            map_path = args.map
        elif scen.entries:
            map_path = resolve_map(scen.entries[0].map_name, args.instance.parent, map_dirs(args))
        else:
            raise FleetError("{} has no entries".format(args.instance))
        inst = scen_to_instance(scen, read_map(map_path).grid, map_file=map_path.name, agents=args.agents)
        return inst, map_path.name
    raise FleetError("{} is a {} file; solve takes a mapf-IR instance or a .scen".format(args.instance, kind))


def _solve(args: argparse.Namespace, inst: Instance, limit: float, seed: int, steps: int) -> SolveResult:
    if args.solver.startswith(MAPF_IR_PREFIX):
        from fleet_common.planning.mapf_ir import MapfIrSolver

        if args.allow_rotations:
            raise FleetError("--allow-rotations is for the built-in solvers; mapf-IR's solvers always "
                             "allow rotations")
        ours = [o for o, v in (("--anytime", args.anytime), ("--memory-limit", args.memory_limit),
                               ("--w", args.w)) if v]
        if ours:  # mapf-IR would never see them: say so rather than ignore them
            raise FleetError("{} {} for the built-in solvers; give mapf-IR's own options after `--` "
                             "(e.g. `-- -w 1.2`)".format(", ".join(ours), "is" if len(ours) == 1 else "are"))
        adapter = MapfIrSolver(args.mapf_ir, map_dir=args.mapf_ir_map_dir, timeout_s=limit)
        return adapter.solve(inst.grid, inst.starts, inst.goals, args.solver[len(MAPF_IR_PREFIX):],
                             options=args.passthrough, deadline=Deadline(limit), seed=seed,
                             max_timestep=steps)
    if args.passthrough:
        raise FleetError("options after `--` ({}) are for mapf-IR solvers; {} takes none".format(
            " ".join(args.passthrough), args.solver))
    options = {}
    if args.anytime:
        if args.solver != "lacam":
            raise FleetError("--anytime is for lacam, not {}".format(args.solver))
        options["anytime"] = True
    if args.memory_limit is not None:
        if args.solver != "lacam":
            raise FleetError("--memory-limit is for lacam, not {}".format(args.solver))
        options["memory_limit_mb"] = args.memory_limit
    if args.w is not None:
        if args.solver != "ecbs":
            raise FleetError("--w is for ecbs, not {}".format(args.solver))
        options["w"] = args.w
    return solve(args.solver, inst.grid, inst.starts, inst.goals, deadline=Deadline(limit), seed=seed,
                 rotations=args.allow_rotations, max_timestep=steps, **options)


def _summary(result: SolveResult, plan: Plan, grid: Grid, lb_soc: int, lb_makespan: int, where: str) -> str:
    rotations = result.stats.get("rotations")
    if rotations is None:  # mapf-IR's plans: count them (built-in solvers' are counted by solve)
        from fleet_common.validate import ROTATION, validate_plan

        rotations = validate_plan(plan, grid).count(ROTATION)
    note = ", {} rotations (robots cannot execute these)".format(rotations) if rotations else ""
    return "solved=1, solver={}, comp_time(ms)={:.0f}, soc={} (LB={}), makespan={} (LB={}){} -> {}".format(
        result.solver, result.comp_time_ms, plan.soc, lb_soc, plan.makespan, lb_makespan, note, where)
