"""`fleetctl info`: what is in this file, in a few lines."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable, Dict, List

from .. import filekinds
from ..options import add_legacy_units, add_map_dir, legacy_units, map_dirs

NAME = "info"
HELP = "summarise any supported file (map, instance, solution, scen, legacy XML, robot definitions)"
DESCRIPTION = HELP + "; exit 2 with FILE:LINE: message when it is malformed."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path)
    add_map_dir(parser)
    parser.add_argument("--strict-map", action="store_true",
                        help="maps: the MovingAI rule (W and O block too) instead of mapf-IR's")
    add_legacy_units(parser)


def run(args: argparse.Namespace) -> int:
    kind = filekinds.sniff(args.file)
    lines = _SUMMARIES[kind](args)
    print("{}: {}".format(args.file, lines[0]))
    for line in lines[1:]:
        print("  " + line)
    return 0


def _map(args: argparse.Namespace) -> List[str]:
    from fleet_common.formats.mapfile import read_map

    m = read_map(args.file, strict=args.strict_map)
    g = m.grid
    free = int(g.free.sum())
    return ["map {}x{} (width x height)".format(g.width, g.height),
            "{} free cells, {} blocked ({} rule)".format(
                free, g.num_cells - free, "MovingAI" if args.strict_map else "mapf-IR")]


def _instance(args: argparse.Namespace) -> List[str]:
    from fleet_common.formats.instance import read_instance

    inst = read_instance(args.file, map_dirs=map_dirs(args))
    lines = ["instance: {} agents on {} ({}x{})".format(
        inst.num_agents, inst.map_file, inst.grid.width, inst.grid.height)]
    if inst.random_problem:
        lines.append("random_problem=1: starts and goals are drawn by the solver (seed {})".format(inst.seed))
    for key in ("seed", "max_timestep", "max_comp_time", "well_formed"):
        value = inst.header.get(key)
        if value is not None:
            lines.append("{}={}".format(key, value))
    return lines


def _solution(args: argparse.Namespace) -> List[str]:
    from fleet_common.formats.solution import read_solution

    sol = read_solution(args.file, map_dirs=map_dirs(args))
    state = "solved" if sol.solved else "NOT solved (failed run)"
    lines = ["solution by {}: {}, {} agents on {}".format(sol.solver, state, sol.agents, sol.map_file)]
    lines.append("soc={} (lower bound {}), makespan={} (lower bound {}), comp_time={} ms".format(
        sol.soc, sol.lb_soc, sol.makespan, sol.lb_makespan, sol.comp_time))
    if sol.iterations:
        lines.append("{} refinement iterations recorded".format(len(sol.iterations)))
    if sol.plan is not None and sol.plan.makespan > 0:
        lines.append(_turns(sol.plan))
    if sol.instance:
        lines.append("instance: {}".format(sol.instance))
    return lines


def _turns(plan) -> str:
    """What the plan asks of robots that turn in place (the virtual fleet's, facing +x at the start)."""
    from fleet_common.planning.pibt_turns import moves_and_turns, slowest_need
    from virtual_fleet.kinematics import QUARTER_OF_A_MOVE

    counts = moves_and_turns(plan)
    need = slowest_need(counts, QUARTER_OF_A_MOVE)
    line = "robots turning in place: {:,} quarter turns in {:,} moves; the slowest robot needs {:.1f} moves' " \
           "time with its turns, {:.2f}x the makespan".format(
               sum(q for _, q in counts), sum(m for m, _ in counts), need, need / plan.makespan)
    return line + (": it cannot run as planned on them (fleetctl solve -s pibt-turns plans the turns)"
                   if need > plan.makespan else "")


def _scen(args: argparse.Namespace) -> List[str]:
    from fleet_common.formats.scen import read_scen

    scen = read_scen(args.file)
    maps = sorted({e.map_name for e in scen.entries})
    return ["MovingAI scenario: {} entries".format(len(scen.entries)),
            "map(s): {}".format(", ".join(maps) if maps else "-")]


def _legacy_map(args: argparse.Namespace) -> List[str]:
    from fleet_common.formats.legacy_xml import read_legacy_node_map

    nodes = read_legacy_node_map(args.file)
    kinds: Dict[str, int] = {}
    for node in nodes.nodes:
        kinds[node.kind] = kinds.get(node.kind, 0) + 1
    return ["legacy FleetControl node map: {} nodes".format(len(nodes.nodes)),
            ", ".join("{} {}".format(v, k) for k, v in sorted(kinds.items()))]


def _legacy_plan(args: argparse.Namespace) -> List[str]:
    from fleet_common.errors import NotConvertibleError
    from fleet_common.formats.legacy_convert import legacy_plan_to_plan
    from fleet_common.formats.legacy_xml import read_legacy_plan

    legacy = read_legacy_plan(args.file)
    sections = sum(len(a.sections) for a in legacy.agents)
    lines = ["legacy FleetControl execution plan: {} agents, {} sections".format(len(legacy.agents), sections)]
    try:
        scale, origin = legacy_units(args)
        plan, _, _ = legacy_plan_to_plan(legacy, scale=scale, origin=origin)
        lines.append("converts to a timed grid plan: makespan {}".format(plan.makespan))
    except NotConvertibleError as err:
        lines.append("not convertible to a grid plan: {}".format(err))
    return lines


def _robots(args: argparse.Namespace) -> List[str]:
    from fleet_common.robots import read_robot_definitions, read_robot_size

    robots = read_robot_definitions(args.file)
    lines = ["robot definitions: {} robots; {}".format(len(robots), read_robot_size(args.file).describe())]
    for r in robots:
        lines.append("robot {}: {}:{} ssh {} vicon {} colour {}".format(
            r.id, r.host, r.command_port, r.ssh_user, r.vicon_name, r.colour))
    return lines


_SUMMARIES: Dict[str, Callable[[argparse.Namespace], List[str]]] = {
    filekinds.MAP: _map,
    filekinds.INSTANCE: _instance,
    filekinds.SOLUTION: _solution,
    filekinds.SCEN: _scen,
    filekinds.LEGACY_MAP: _legacy_map,
    filekinds.LEGACY_PLAN: _legacy_plan,
    filekinds.ROBOTS: _robots,
}
