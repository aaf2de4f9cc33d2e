"""Options shared by several subcommands, defined once."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple


def add_map_dir(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--map-dir", metavar="D", action="append", default=[], type=Path,
        help="folder to search for map_file= (repeatable); searched after the file's own "
             "folder and before the defaults ($FLEETCONTROL_MAP_PATH, the shared mapf-IR maps, the lab)",
    )


def map_dirs(args: argparse.Namespace) -> List[Path]:
    from fleet_common.formats.mapsearch import default_map_dirs  # (numpy: not for --help)

    return list(args.map_dir) + default_map_dirs()


def add_legacy_units(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--legacy-scale", type=float, default=None, metavar="S",
                        help="legacy XML plan: plan units per grid cell (default: the lab robot "
                             "frame's 0.7 m; 1 when a --map is given)")
    parser.add_argument("--legacy-origin", type=float, nargs=2, default=None, metavar=("X", "Y"),
                        help="legacy XML plan: plan coordinates of cell (0, 0) (default: the lab "
                             "robot frame's 0.7 2.1; 0 0 when a --map is given)")


def legacy_units(args: argparse.Namespace) -> Tuple[float, Tuple[float, float]]:
    """(scale, origin) of a legacy plan: the lab's robot-frame metres unless told otherwise."""
    if getattr(args, "map", None) is None:
        from fleet_common.lab import base_to_robot

        to_robot = base_to_robot()
        ox, oy = to_robot.apply((0.0, 0.0))
        scale, origin = float(to_robot.apply((1.0, 0.0))[0] - ox), (float(ox), float(oy))
    else:
        scale, origin = 1.0, (0.0, 0.0)
    if args.legacy_scale is not None:
        scale = args.legacy_scale
    if args.legacy_origin is not None:
        origin = (args.legacy_origin[0], args.legacy_origin[1])
    return scale, origin


def start_poses(instance: Optional[Path], robots: Sequence) -> Optional[Dict]:
    """robot id -> Pose at agent i's start of `instance` (an instance or a solution; default:
    the lab instance) for robot i; None when the lab instance has fewer agents than robots."""
    from fleet_common.errors import FleetError
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.formats.problem_file import read_problem
    from fleet_common.lab import lab_instance_path, lab_map_path
    from fleet_common.wire.messages import Pose

    path = instance or lab_instance_path()
    inst = read_problem(path, [lab_map_path().parent, *default_map_dirs()])
    if len(inst.starts) < len(robots):
        if instance is not None:
            raise FleetError("{} has {} agents, fewer than the {} robots".format(
                instance, len(inst.starts), len(robots)))
        return None  # rows from (0, 0)
    return {r.id: Pose(float(s[0]), float(s[1]), 0.0) for r, s in zip(robots, inst.starts)}
