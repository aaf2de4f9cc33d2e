"""`fleetctl convert`: between mapf-IR and lab orientation, and from the other formats."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Optional

from fleet_common.arg_types import count
from fleet_common.errors import FleetError, NotConvertibleError

from .. import filekinds
from ..options import add_legacy_units, add_map_dir, legacy_units, map_dirs

NAME = "convert"
HELP = "convert between mapf-IR and lab orientation; scen -> instance; legacy XML -> mapf-IR"
DESCRIPTION = (
    "Convert IN to OUT. Instances and solutions are rewritten in mapf-IR orientation (origin "
    "top-left, as mapf-IR and its visualizer expect) or in lab orientation ('base': origin "
    "bottom-left, marked by an orientation=base header line); --to mapf-ir on a mapf-IR file "
    "reproduces it byte for byte. A MovingAI .scen becomes an instance (give --map or let its "
    "map name be found on the map path; --agents N takes the first N). A legacy FleetControl "
    "XML plan becomes a mapf-IR solution on --map (default: the lab map) when its sections "
    "run between grid nodes; a legacy node map becomes a .map grid."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, metavar="IN")
    parser.add_argument("output", type=Path, metavar="OUT")
    parser.add_argument("--to", choices=("mapf-ir", "base"), default="mapf-ir",
                        help="orientation of OUT (default: mapf-ir)")
    add_map_dir(parser)
    parser.add_argument("--map", type=Path, help="map for a .scen or a legacy plan")
    parser.add_argument("--agents", type=count, help="scen: number of agents (default: all entries)")
    add_legacy_units(parser)


def run(args: argparse.Namespace) -> int:
    kind = filekinds.sniff(args.input)
    if args.input.resolve() == args.output.resolve():
        raise FleetError("IN and OUT are the same file; write to another file")
    handler = {
        filekinds.MAP: _map,
        filekinds.INSTANCE: _instance,
        filekinds.SOLUTION: _solution,
        filekinds.SCEN: _scen,
        filekinds.LEGACY_PLAN: _legacy_plan,
        filekinds.LEGACY_MAP: _legacy_map,
    }.get(kind)
    if handler is None:
        raise NotConvertibleError("{} is a {} file; there is nothing to convert it to".format(args.input, kind))
    note = handler(args)
    print("{} -> {} ({}){}".format(args.input, args.output, kind, ": " + note if note else ""))
    return 0


def _map(args: argparse.Namespace) -> Optional[str]:
    from fleet_common.formats.mapfile import read_map, write_map

    write_map(read_map(args.input), args.output)
    return "maps carry no coordinates: the grid is the same in both orientations"


def _instance(args: argparse.Namespace) -> Optional[str]:
    from fleet_common.formats.instance import read_instance, write_instance

    write_instance(read_instance(args.input, map_dirs=map_dirs(args)), args.output, orientation=args.to)
    return "{} orientation".format(args.to)


def _solution(args: argparse.Namespace) -> Optional[str]:
    from fleet_common.formats.solution import read_solution, write_solution

    write_solution(read_solution(args.input, map_dirs=map_dirs(args)), args.output, orientation=args.to)
    return "{} orientation".format(args.to)


def _scen(args: argparse.Namespace) -> Optional[str]:
    from fleet_common.formats.instance import write_instance
    from fleet_common.formats.mapfile import read_map
    from fleet_common.formats.mapsearch import resolve_map
    from fleet_common.formats.scen import read_scen, scen_to_instance

    scen = read_scen(args.input)
    if args.map is not None:
        map_path = args.map
    else:
        if not scen.entries:
            raise NotConvertibleError("{} has no entries".format(args.input))
        map_path = resolve_map(scen.entries[0].map_name, args.input.parent, map_dirs(args))
    grid = read_map(map_path).grid
    inst = scen_to_instance(scen, grid, map_file=map_path.name, agents=args.agents)
    write_instance(inst, args.output, orientation=args.to)
    return "{} agents on {}".format(len(inst.starts), map_path.name)


def _lab_or_given_map(args: argparse.Namespace):
    from fleet_common.formats.mapfile import read_map
    from fleet_common.lab import lab_map_path

    path = args.map if args.map is not None else lab_map_path()
    return path, read_map(path).grid


def _legacy_plan(args: argparse.Namespace) -> Optional[str]:
    from fleet_common.formats.legacy_convert import legacy_plan_to_plan
    from fleet_common.formats.legacy_xml import read_legacy_plan
    from fleet_common.formats.solution import make_solution, write_solution
    from fleet_common.validate import validate_plan

    legacy = read_legacy_plan(args.input)
    map_path, grid = _lab_or_given_map(args)
    scale, origin = legacy_units(args)
    plan, starts, goals = legacy_plan_to_plan(legacy, scale=scale, origin=origin)
    report = validate_plan(plan, grid, starts=starts, goals=goals)
    sol = make_solution(grid, map_path.name, plan, starts, goals, solver="legacy-xml",
                        solved=report.ok, comp_time=0, instance=str(args.input))
    write_solution(sol, args.output, orientation=args.to)
    if not report.ok:
        return "WARNING: the converted plan is not valid on {}: {}".format(
            map_path.name, "; ".join(f.message for f in report.errors[:3]))
    return "{} agents, makespan {}, on {}".format(plan.num_agents, plan.makespan, map_path.name)


def _legacy_map(args: argparse.Namespace) -> Optional[str]:
    from fleet_common.formats.legacy_convert import legacy_nodes_to_grid
    from fleet_common.formats.legacy_xml import read_legacy_node_map
    from fleet_common.formats.mapfile import map_from_grid, write_map

    grid, ids = legacy_nodes_to_grid(read_legacy_node_map(args.input))
    write_map(map_from_grid(grid), args.output)
    return "{} nodes on a {}x{} grid".format(len(ids), grid.width, grid.height)
