"""`fleetctl virtual-fleet`: the fleet without robots, on the same protocol (thesis 4.4).

One virtual robot per line of robot_definitions.txt, all on 127.0.0.1: each
binds its own command port from the file and publishes pose feedback on
--feedback-base + its index (9980, 9981, ... by default), so a manager started
for a virtual run cannot tell it from the lab. Runs until interrupted.
"""
from __future__ import annotations

import argparse
import logging
import signal
from pathlib import Path
from typing import Dict, Optional

NAME = "virtual-fleet"
HELP = "run one virtual robot per robot definition on 127.0.0.1, speaking the robot protocol"
DESCRIPTION = HELP + ". Stops on Ctrl-C or SIGTERM."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--definitions", type=Path, default=None, metavar="FILE",
                        help="robot definitions (default: $FLEETCONTROL_ROBOTS, else the "
                             "repository's robot_definitions.txt)")
    parser.add_argument("--time-scale", type=_positive, default=1.0, metavar="K",
                        help="run K times faster than real time (default 1)")
    parser.add_argument("--delay-model", default="none", metavar="SPEC",
                        help="what goes wrong: comma-separated delay=D, slow=P:F, stall=P:S, "
                             "dropout=P:S (seconds of fleet time, P a probability per move); "
                             "default none")
    parser.add_argument("--seed", type=int, default=0, help="seed of the delay model (default 0)")
    parser.add_argument("--stall", action="append", default=[], metavar="R:K:S",
                        help="robot R halts S seconds (fleet time) halfway through its K-th drive, "
                             "whatever the delay model says; repeatable")
    parser.add_argument("--feedback-base", type=int, default=9980, metavar="PORT",
                        help="pose feedback port of the first robot; the others count up "
                             "(default 9980)")
    parser.add_argument("--speed", type=_positive, default=0.5, metavar="CELLS_PER_S",
                        help="driving speed (default 0.5 cells/s, about 0.35 m/s in the lab)")
    parser.add_argument("--turn-speed", type=_positive, default=1.5, metavar="RAD_PER_S",
                        help="turning speed (default 1.5 rad/s)")
    parser.add_argument("--instance", type=Path, default=None, metavar="FILE",
                        help="start robot i at agent i's start of this instance (default: the "
                             "lab instance if it has enough agents, else rows from (0, 0))")
    parser.add_argument("--keys", type=Path, default=None, metavar="DIR",
                        help="CurveZMQ key folder from `fleetctl keys` (default: "
                             "$FLEETCONTROL_KEYS, else ~/.config/fleetcontrol/keys)")
    parser.add_argument("--no-curve", action="store_true",
                        help="accept commands from anyone (no CurveZMQ); for local experiments")
    parser.add_argument("--log-level", default="info",
                        choices=["debug", "info", "warning", "error"])


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value > 0:
        raise argparse.ArgumentTypeError("expected a positive number, got {!r}".format(text))
    return value


def run(args: argparse.Namespace) -> int:
    from fleet_common.errors import FleetError
    from fleet_common.robots import default_definitions_path, read_robot_definitions
    from fleet_common.transport.curve_keys import default_keys_dir, load_robot_keys
    from virtual_fleet.delays import parse_delay_model
    from virtual_fleet.fleet import VirtualFleet
    from virtual_fleet.stalls import parse_stall

    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s %(levelname)s %(message)s")
    path = args.definitions or default_definitions_path()
    robots = read_robot_definitions(path)
    model = parse_delay_model(args.delay_model)
    stalls = [parse_stall(text) for text in args.stall]
    try:
        keys = None if args.no_curve else load_robot_keys(args.keys or default_keys_dir())
    except FleetError as err:
        raise FleetError("{}; or run the fleet with --no-curve".format(err)) from err
    fleet = VirtualFleet(robots, keys=keys, feedback_base=args.feedback_base,
                         time_scale=args.time_scale, model=model, seed=args.seed,
                         speed=args.speed, turn_speed=args.turn_speed,
                         start_poses=_start_poses(args.instance, robots), path=str(path),
                         stalls=stalls)
    stopping = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stopping.append(True))
    first, last = fleet.robots[0], fleet.robots[-1]
    print("virtual fleet: {} robots on 127.0.0.1, command ports {}..{}, feedback ports {}..{}, "
          "time x{:g}, {}{}".format(
              len(fleet.robots), first.command_port, last.command_port, fleet.ports[first.id],
              fleet.ports[last.id], args.time_scale,
              "CURVE on" if keys is not None else "no CURVE (anyone may drive)",
              "".join("; " + s.describe() for s in stalls)), flush=True)
    try:
        fleet.run(lambda: bool(stopping))
    finally:
        fleet.close()
    print("virtual fleet stopped ({} dropouts)".format(fleet.dropouts), flush=True)
    return 0


def _start_poses(instance: Optional[Path], robots: list) -> Optional[Dict]:
    from fleet_common.errors import FleetError
    from fleet_common.formats.instance import read_instance
    from fleet_common.lab import lab_instance_path, lab_map_path
    from fleet_common.wire.messages import Pose

    path = instance or lab_instance_path()
    inst = read_instance(str(path), map_dirs=[lab_map_path().parent, Path(path).parent])
    if len(inst.starts) < len(robots):
        if instance is not None:
            raise FleetError("{} has {} agents, fewer than the {} robots".format(
                instance, len(inst.starts), len(robots)))
        return None  # rows from (0, 0)
    return {r.id: Pose(float(s[0]), float(s[1]), 0.0) for r, s in zip(robots, inst.starts)}
