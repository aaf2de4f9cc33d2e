"""`fleetctl virtual-fleet`: the fleet without robots, on the same protocol (thesis 4.4).

One virtual robot per line of robot_definitions.txt, all on 127.0.0.1: each
binds its own command port from the file and publishes pose feedback on
--feedback-base + its index (9980, 9981, ... by default), so a manager started
for a virtual run cannot tell it from the lab. `--robots 1-150,300` serves
only those robots, with the ports they have in the whole file, so several
processes serve one fleet; `--on-hosts` puts each robot on the address its
line names (several hosts, as in the lab: robots sharing a host count their
feedback ports up from the base among themselves). Each robot knows its map (--map,
else the map of --instance, else the lab's) and refuses what a TurtleBot
refuses: drives off the map, into obstacles, farther than --max-step cells or
later than --max-time s. Runs until interrupted.
"""
from __future__ import annotations

import argparse
import logging
import signal
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

from fleet_common.arg_types import non_negative, port, positive, seed
from fleet_common.delays import FORMS
from virtual_fleet.kinematics import SPEED, TURN_SPEED

NAME = "virtual-fleet"
HELP = "run one virtual robot per robot definition on 127.0.0.1, speaking the robot protocol"
DESCRIPTION = (HELP + ". --robots serves a part of the definitions (their ports as in the whole file), so "
               "that several processes or hosts serve one fleet; --on-hosts puts each robot on its own "
               "line's address instead. Stops on Ctrl-C or SIGTERM; SIGUSR1 cuts its power (every robot "
               "stops where it stands, no goodbye, the --state file exact).")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--definitions", type=Path, default=None, metavar="FILE",
                        help="robot definitions (default: $FLEETCONTROL_ROBOTS, else the "
                             "repository's robot_definitions.txt)")
    parser.add_argument("--robots", type=_robot_ids, default=None, metavar="IDS",
                        help="serve only these robots: ids and ranges, e.g. 1-150,300 (default: all); "
                             "their ports are those they have in the whole file")
    parser.add_argument("--on-hosts", action="store_true",
                        help="each robot listens on the address its line names (this machine's), as a "
                             "real robot does, instead of 127.0.0.1; feedback ports count up from "
                             "--feedback-base among the robots of one host")
    parser.add_argument("--time-scale", type=positive, default=1.0, metavar="K",
                        help="run K times faster than real time (default 1)")
    parser.add_argument("--delay-model", action="append", default=[], metavar="SPEC",
                        help="what goes wrong, the same language as `fleetctl simulate --delay-model` "
                             "(repeatable, they combine): " + FORMS + "; a nominal move is one cell at "
                             "--speed (2 s by default); default none")
    parser.add_argument("--seed", type=seed, default=None,
                        help="seed of the delay model (default: the model's seed=, else 0)")
    parser.add_argument("--feedback-base", type=port, default=9980, metavar="PORT",
                        help="pose feedback port of the first robot; the others count up "
                             "(default 9980)")
    parser.add_argument("--speed", type=positive, default=SPEED, metavar="CELLS_PER_S",
                        help="driving speed (default {:g} cells/s, about 0.35 m/s in the lab)".format(SPEED))
    parser.add_argument("--turn-speed", type=positive, default=TURN_SPEED, metavar="RAD_PER_S",
                        help="turning speed (default {:g} rad/s)".format(TURN_SPEED))
    parser.add_argument("--paired", action="store_true",
                        help="robot i's k-th drive meets the fate `fleetctl simulate` draws for agent "
                             "i's k-th move of the --instance plan (same --delay-model and --seed): "
                             "runs through the manager and on the engine alone meet the same delays")
    parser.add_argument("--instance", type=Path, default=None, metavar="FILE",
                        help="start robot i at agent i's start of this instance or solution "
                             "(default: the lab instance if it has enough agents, else rows "
                             "from (0, 0))")
    parser.add_argument("--state", type=Path, default=None, metavar="FILE",
                        help="keep each robot's pose in FILE; a fleet started again with it "
                             "puts every robot where it stood (as after a power cut)")
    parser.add_argument("--truth", type=Path, default=None, metavar="FILE",
                        help="write the ground truth (true poses at 20 Hz, every command "
                             "started) to FILE as JSON lines")
    parser.add_argument("--truth-port", type=port, default=None, metavar="PORT",
                        help="publish the true poses on tcp://127.0.0.1:PORT (for `fleetctl "
                             "vicon simulate`)")
    parser.add_argument("--drift", action="append", default=[], type=_drift, metavar="ID:RATE",
                        help="robot ID's own localization drifts RATE cells/s along x away "
                             "from the truth (repeatable; to test the Vicon cross-check)")
    parser.add_argument("--bump", action="append", default=[], type=_bump, metavar="ID@K",
                        help="robot ID's bumper is pressed halfway through its K-th drive, for "
                             "1 s: it stops with a 'bumper' fault until a stop clears it "
                             "(repeatable)")
    parser.add_argument("--stall", action="append", default=[], type=_stall, metavar="ID:K:S",
                        help="robot ID halts S seconds (fleet time) halfway through its K-th drive, "
                             "then drives on: one robot late on purpose, whatever the delay "
                             "model says (repeatable)")
    parser.add_argument("--map", type=Path, default=None, metavar="FILE",
                        help="the robots' map: they refuse drives off it or into its obstacles "
                             "(default: the map of --instance, else the lab's when the robots "
                             "start at the lab instance, else none)")
    parser.add_argument("--max-step", type=non_negative, default=1.5, metavar="CELLS",
                        help="longest drive a robot accepts, from where it stands (default 1.5: "
                             "one cell and some slack; 0: any distance)")
    parser.add_argument("--max-time", type=positive, default=120.0, metavar="S",
                        help="latest arrival time a drive may ask for (default 120 s)")
    parser.add_argument("--keys", type=Path, default=None, metavar="DIR",
                        help="CurveZMQ key folder from `fleetctl keys` (default: "
                             "$FLEETCONTROL_KEYS, else ~/.config/fleetcontrol/keys)")
    parser.add_argument("--no-curve", action="store_true",
                        help="accept commands from anyone (no CurveZMQ); for local experiments")
    parser.add_argument("--log-level", default="info",
                        choices=["debug", "info", "warning", "error"])


def _robot_ids(text: str) -> object:
    from fleet_common.robot_ids import parse_robot_ids

    try:
        return parse_robot_ids(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _drift(text: str) -> tuple:
    robot, _, rate = text.partition(":")
    try:
        return int(robot), float(rate)
    except ValueError:
        raise argparse.ArgumentTypeError("expected ID:CELLS_PER_S (e.g. 3:0.2), got {!r}".format(text))


def _bump(text: str) -> tuple:
    robot, _, drive = text.partition("@")
    try:
        pair = int(robot), int(drive)
    except ValueError:
        pair = (0, 0)
    if pair[1] < 1:
        raise argparse.ArgumentTypeError("expected ID@K with K >= 1 (e.g. 3@2), got {!r}".format(text))
    return pair


def _stall(text: str) -> object:
    from fleet_common.errors import FleetError
    from virtual_fleet.stalls import parse_stall

    try:
        return parse_stall(text)
    except FleetError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def run(args: argparse.Namespace) -> int:
    from fleet_common.errors import FleetError
    from fleet_common.robot_ids import describe_ids, select_robots
    from fleet_common.robots import default_definitions_path, read_robot_definitions
    from fleet_common.transport.curve_keys import default_keys_dir, load_robot_keys
    from fleet_common.delays import parse_delay_model
    from fleet_common.wire.command_check import CommandCheck, CommandLimits
    from virtual_fleet.delays import FleetDelays
    from virtual_fleet.fleet import VirtualFleet

    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s %(levelname)s %(message)s")
    path = args.definitions or default_definitions_path()
    robots = read_robot_definitions(path)
    serve = None if args.robots is None else [r.id for r in select_robots(robots, args.robots, str(path))]
    spec = parse_delay_model(args.delay_model)
    seed = args.seed if args.seed is not None else (spec.seed or 0)
    model = FleetDelays(spec, nominal_s=1.0 / args.speed, seed=seed, num_robots=len(robots))
    try:
        keys = None if args.no_curve else load_robot_keys(args.keys or default_keys_dir())
    except FleetError as err:
        raise FleetError("{}; or run the fleet with --no-curve".format(err)) from err
    poses, grid, map_name = _world(args.instance, args.map, robots)
    if args.paired:
        model = model.paired_with(_plan_moves(args.instance))
    limits = CommandLimits(args.max_step or None, args.max_time)
    fleet = VirtualFleet(robots, keys=keys, feedback_base=args.feedback_base,
                         time_scale=args.time_scale, model=model, seed=seed,
                         speed=args.speed, turn_speed=args.turn_speed,
                         start_poses=poses, path=str(path), check=CommandCheck(grid, limits),
                         truth=args.truth, state=args.state, truth_port=args.truth_port,
                         drift=dict(args.drift), bumps=args.bump, stalls=args.stall,
                         serve=serve, on_hosts=args.on_hosts)
    stopping: List[str] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stopping.append("stop"))
    signal.signal(signal.SIGUSR1, lambda *_: stopping.append("power cut"))  # (tests: a fleet losing power)
    first, last = fleet.robots[0], fleet.robots[-1]
    hosts = sorted({r.host for r in fleet.robots})
    print("virtual fleet: {} robots{} on {}, command ports {}..{}, feedback ports {}..{}, "
          "time x{:g}, {}, {}".format(
              len(fleet.robots), "" if serve is None else " ({} of {})".format(describe_ids(serve), len(robots)),
              ", ".join(hosts[:4]) + (", ..." if len(hosts) > 4 else ""), first.command_port,
              last.command_port, fleet.ports[first.id], fleet.ports[last.id], args.time_scale,
              "CURVE on" if keys is not None else "no CURVE (anyone may drive)",
              "map {} ({}x{})".format(map_name, grid.width, grid.height) if grid is not None
              else "no map (drives checked for length and time only)")
          + "".join("; " + s.describe() for s in args.stall), flush=True)
    try:
        fleet.run(lambda: bool(stopping))
    finally:
        fleet.close(power_cut="power cut" in stopping)
    print("virtual fleet {} ({} dropouts)".format(
        "lost power: every robot stopped where it stood, silent" if "power cut" in stopping else "stopped",
        fleet.dropouts), flush=True)
    return 0


def _plan_moves(path: Optional[Path]) -> List[int]:
    """Moves of each agent of the plan in `path`, as the engine counts them (--paired)."""
    from fleet_common.errors import FleetError
    from fleet_common.execution.actions import ActionTable
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.formats.problem_file import read_problem
    from fleet_common.formats.solution import Solution
    from fleet_common.lab import lab_map_path

    if path is None:
        raise FleetError("--paired needs --instance PLAN: the plan whose moves the fates are drawn for")
    problem = read_problem(path, [lab_map_path().parent, *default_map_dirs()])
    if not isinstance(problem, Solution) or problem.plan is None:
        raise FleetError("--paired needs --instance to be a plan (a solution file with its moves); {} "
                         "has none".format(path))
    first = ActionTable.from_plan(problem.plan).first
    return [int(first[i + 1] - first[i]) for i in range(len(first) - 1)]


def _world(instance: Optional[Path], map_path: Optional[Path],
           robots: list) -> Tuple[Optional[Dict], Optional[Any], str]:
    """(start poses or None for rows from (0, 0), the robots' grid or None, its name)."""
    from fleet_common.errors import FleetError
    from fleet_common.formats.mapfile import read_map
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.formats.problem_file import read_problem
    from fleet_common.lab import lab_instance_path, lab_map_path
    from fleet_common.wire.messages import Pose

    path = instance or lab_instance_path()
    inst = read_problem(path, [lab_map_path().parent, *default_map_dirs()])
    poses: Optional[Dict] = None
    grid, name = None, ""
    if len(inst.starts) >= len(robots):
        poses = {r.id: Pose(float(s[0]), float(s[1]), 0.0) for r, s in zip(robots, inst.starts)}
        grid, name = inst.grid, inst.map_file
    elif instance is not None:
        raise FleetError("{} has {} agents, fewer than the {} robots".format(
            instance, len(inst.starts), len(robots)))
    if map_path is not None:
        grid, name = read_map(str(map_path)).grid, str(map_path)
        if poses is None:
            from virtual_fleet.fleet import row_poses

            poses = row_poses(robots)
        for robot in robots:
            cell = (int(poses[robot.id].x), int(poses[robot.id].y))
            if not grid.is_free(cell):
                raise FleetError("robot {} would start at {}, which is not a free cell of {}; give "
                                 "--instance with starts on that map".format(robot.id, cell, name))
    return poses, grid, name
