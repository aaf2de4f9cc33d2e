"""`fleetctl console`: the operator console, live on a manager (`--manager`) or the plan player (`--replay`)."""
from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Optional, Tuple

from fleet_common.arg_types import endpoint, non_negative, positive
from fleet_common.errors import FleetError

from .. import filekinds
from ..options import add_map_dir, map_dirs

NAME = "console"
HELP = "watch and steer a running fleet (--manager), or play a mapf-IR solution (--replay)"
DESCRIPTION = (
    "Without --replay: the live console of the manager at --manager (default tcp://127.0.0.1:7100): the robots "
    "where they are, the plan, who waits for whom, and the controls of the run; it reconnects "
    "by itself when the manager comes back. --screenshot PNG saves the window after --after "
    "seconds and exits; --record DIR saves a frame every --every plan steps; both render on a "
    "private Xvfb when there is no display. With --replay: the plan player on a mapf-IR "
    "solution (agents move along their paths) or instance (agents on their starts, goals "
    "marked); --screenshot PNG writes the view at time step --at. Press F1 in the window for "
    "the keys. Exit 2 with FILE:LINE: message when a file cannot be read."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from fleet_common.transport.console_channel import DEFAULT_ENDPOINT

    parser.add_argument("--replay", type=Path, metavar="SOLUTION",
                        help="mapf-IR solution (or instance) file to play")
    live = parser.add_argument_group("live console (without --replay)")
    live.add_argument("--manager", default=DEFAULT_ENDPOINT, metavar="ENDPOINT", type=endpoint,
                      help="the manager's console endpoint, HOST:PORT or tcp://HOST:PORT (default {})".format(
                          DEFAULT_ENDPOINT))
    live.add_argument("--keys", type=Path, default=None, metavar="DIR",
                      help="CurveZMQ key folder with console.key_secret and manager.key (default: "
                           "$FLEETCONTROL_KEYS, else ~/.config/fleetcontrol/keys)")
    live.add_argument("--no-curve", action="store_true",
                      help="no CurveZMQ (the manager runs with --no-curve too)")
    live.add_argument("--name", default=None, help="this console's name in the manager's log and "
                                                    "event list (default console@HOST)")
    live.add_argument("--after", type=non_negative, default=5.0, metavar="S",
                      help="with --screenshot: seconds to watch before saving (default 5)")
    live.add_argument("--record", type=Path, default=None, metavar="DIR",
                      help="save the window as DIR/NNNN.png every --every plan steps and at every "
                           "change of the run (listed in DIR/frames.txt)")
    live.add_argument("--every", type=positive, default=1.0, metavar="N",
                      help="with --record: plan steps between frames (default 1)")
    live.add_argument("--close-when-done", type=non_negative, default=None, metavar="S",
                      help="close the window S seconds after the run is done")
    live.add_argument("--start-when-ready", action="store_true",
                      help="press Start once every robot is connected (the demo's console)")
    live.add_argument("--switch-when-stalled", default=None, metavar="STRATEGY",
                      help="switch the run to STRATEGY once a robot waits for a stalled one, as an "
                           "operator would (`fleetctl demo --switch`)")
    live.add_argument("--present", action="store_true",
                      help="open in the presentation view for visitors: the map full screen, robots "
                           "large, a legend and the run's story in words (F11 switches)")
    parser.add_argument("--map", type=Path, metavar="MAP",
                        help="use this .map instead of looking up the file's map_file=")
    add_map_dir(parser)
    parser.add_argument("--screenshot", type=Path, metavar="PNG",
                        help="write a PNG and exit: the player's view at time step --at, or the live "
                             "console's window after --after seconds")
    parser.add_argument("--at", type=non_negative, default=0.0, metavar="T",
                        help="time step for --screenshot (fractions move agents between cells)")
    parser.add_argument("--orientation", choices=("file", "lab", "mapf-ir"), default="file",
                        help="whose coordinates the window shows: file (default), the plan file's "
                             "own, as its messages use them; lab: origin bottom-left, y up; mapf-ir: "
                             "as mapf-IR's visualizer shows the file (origin top-left); key m toggles")
    parser.add_argument("--lines", choices=("goal", "path", "none"), default="goal",
                        help="line from each agent to its goal, its remaining path, or none")
    parser.add_argument("--agent", type=int, metavar="I", help="highlight agent I (0-based)")
    parser.add_argument("--ids", action="store_true", help="show agent and cell ids")
    parser.add_argument("--node-ids", action="store_true",
                        help="lab map: show the floor-marker node ids (427 ...) the robots and the demo use")
    parser.add_argument("--speed", type=positive, default=4.0, metavar="S",
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
    if args.replay is None:
        return _live(args)
    return _replay(args)


def _live(args: argparse.Namespace) -> int:
    import socket

    from console.live_console import LiveOptions, run_live_console
    from fleet_common.transport.curve_keys import default_keys_dir, load_console_keys

    try:
        keys = None if args.no_curve else load_console_keys(args.keys or default_keys_dir())
    except FleetError as err:
        raise FleetError("{}; or run with --no-curve (and the manager too)".format(err)) from err
    if args.switch_when_stalled is not None:
        from fleet_common.execution import STRATEGIES

        if args.switch_when_stalled not in STRATEGIES:
            raise FleetError("--switch-when-stalled {}: expected one of {}".format(
                args.switch_when_stalled, ", ".join(sorted(STRATEGIES))))
    options = LiveOptions(
        name=args.name or "console@{}".format(socket.gethostname()), size=args.size,
        screenshot=args.screenshot, after=args.after, record=args.record, every=args.every,
        close_when_done=args.close_when_done, start_when_ready=args.start_when_ready, present=args.present,
        switch_when_stalled=args.switch_when_stalled,
        view=_view(args))
    outcome = run_live_console(args.manager, keys, options)
    if outcome.screenshot is not None:
        print("{}: the console on {} after {:g} s".format(outcome.screenshot, args.manager, args.after))
    if args.record is not None:
        print("{}: {} frames (index in frames.txt)".format(args.record, len(outcome.frames)))
    print("console closed: {}{}".format(outcome.reason, "; the run is {}".format(outcome.run_state)
                                        if outcome.run_state else ""), flush=True)
    return 0


def _view(args: argparse.Namespace):
    from console.view_options import ViewOptions

    follow = args.orientation == "file"
    return ViewOptions(lines=args.lines, ids=args.ids, orientation="lab" if follow else args.orientation,
                       follow_file=follow)


def _replay(args: argparse.Namespace) -> int:
    from console.player import run_player, screenshot
    from console.scene import scene_from_instance, scene_from_solution

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
    options = _view(args)
    options.node_ids, options.selected = args.node_ids, selected
    if args.screenshot is not None:
        w, h = screenshot(scene, args.screenshot, args.at, options, args.size)
        print("{}: time step {:g} of {}, {}x{} pixels".format(args.screenshot, min(max(args.at, 0), scene.makespan),
                                                              scene.makespan, w, h))
        return 0
    run_player(scene, options, args.size, speed=args.speed, playing=not args.paused)
    return 0
