"""`fleetctl console`: the operator console; today the plan player (`--replay`)."""
from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Optional, Tuple

from fleet_common.errors import FleetError

from .. import filekinds
from ..options import add_map_dir, map_dirs

NAME = "console"
HELP = "play a mapf-IR solution (or show an instance) in a window; --screenshot renders a PNG"
DESCRIPTION = (
    "Open the console's plan player on a mapf-IR solution (agents move along their paths) or "
    "instance (agents on their starts, goals marked). Press F1 in the window for the keys. "
    "With --screenshot PNG the view at time step --at is written as PNG and nothing stays on "
    "screen (without a display it renders on a private Xvfb). Exit 2 with FILE:LINE: message "
    "when the file cannot be read."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--replay", type=Path, metavar="SOLUTION", required=True,
                        help="mapf-IR solution (or instance) file to play")
    parser.add_argument("--map", type=Path, metavar="MAP",
                        help="use this .map instead of looking up the file's map_file=")
    add_map_dir(parser)
    parser.add_argument("--screenshot", type=Path, metavar="PNG",
                        help="write the view at time step --at as PNG and exit")
    parser.add_argument("--at", type=float, default=0.0, metavar="T",
                        help="time step for --screenshot (fractions move agents between cells)")
    parser.add_argument("--orientation", choices=("lab", "mapf-ir"), default="lab",
                        help="lab: origin bottom-left, y up (default); mapf-ir: as mapf-IR's "
                             "visualizer shows the file (origin top-left); key m toggles")
    parser.add_argument("--lines", choices=("goal", "path", "none"), default="goal",
                        help="line from each agent to its goal, its remaining path, or none")
    parser.add_argument("--agent", type=int, metavar="I", help="highlight agent I (0-based)")
    parser.add_argument("--ids", action="store_true", help="show agent and cell ids")
    parser.add_argument("--node-ids", action="store_true",
                        help="lab map: show the floor-marker node ids (427 ...) the robots and the demo use")
    parser.add_argument("--speed", type=float, default=4.0, metavar="S",
                        help="time steps per second when playing (0.25..64, default 4)")
    parser.add_argument("--paused", action="store_true", help="open paused at time step 0")
    parser.add_argument("--size", type=_size, metavar="WxH", help="canvas size in pixels")
    parser.add_argument("--strict-following", action="store_true",
                        help="list following moves as conflicts too (mapf-IR allows them)")


def _size(text: str) -> Tuple[int, int]:
    m = re.fullmatch(r"(\d+)x(\d+)", text)
    if m is None or int(m.group(1)) < 200 or int(m.group(2)) < 150:
        raise argparse.ArgumentTypeError("expected WIDTHxHEIGHT in pixels, at least 200x150, e.g. 1000x700")
    return int(m.group(1)), int(m.group(2))


def run(args: argparse.Namespace) -> int:
    from console.player import run_player, screenshot
    from console.scene import scene_from_instance, scene_from_solution
    from console.view_options import ViewOptions

    kind = filekinds.sniff(args.replay)
    if kind == filekinds.SOLUTION:
        scene = scene_from_solution(args.replay, args.map, map_dirs(args), args.strict_following)
    elif kind == filekinds.INSTANCE:
        scene = scene_from_instance(args.replay, args.map, map_dirs(args))
    else:
        raise FleetError("{}: is a {} file; --replay takes a mapf-IR solution or instance".format(
            args.replay, kind))
    selected: Optional[int] = args.agent
    if selected is not None and not 0 <= selected < scene.num_agents:
        raise FleetError("--agent {}: the plan has agents 0..{}".format(selected, scene.num_agents - 1))
    options = ViewOptions(lines=args.lines, ids=args.ids, node_ids=args.node_ids, orientation=args.orientation,
                          selected=selected)
    if args.screenshot is not None:
        w, h = screenshot(scene, args.screenshot, args.at, options, args.size)
        print("{}: time step {:g} of {}, {}x{} pixels".format(args.screenshot, min(max(args.at, 0), scene.makespan),
                                                              scene.makespan, w, h))
        return 0
    run_player(scene, options, args.size, speed=args.speed, playing=not args.paused)
    return 0
