"""`python -m deploy COMMAND [ID...|all] [options]`: what scripts/ciirc-exec.sh calls.

Exit statuses: 0 every machine OK; 1 some machine FAILED (the table says which
and why; the others still ran); 2 bad input (deploy.yaml, the definitions, an
unknown robot, the command line), one line, no traceback; 130 interrupted.
"""
from __future__ import annotations

import argparse
import os
import shlex
import sys
from dataclasses import replace
from pathlib import Path
from typing import Dict, List, Optional, Tuple

from fleet_common.arg_types import Parser, integer, port, positive
from fleet_common.errors import FleetError, FormatError
from fleet_common.robots import default_definitions_path, read_robot_definitions
from fleet_common.wire.ports import FEEDBACK_PORT, feedback_ports

from .config import DeployConfig, default_config_path, read_config
from .errors import DeployError
from .fanout import exit_status, format_table, run_all
from .interactive import inspect_command, shell_command, ssh_argv
from .remote import format_steps, steps
from .ssh import run_steps
from .targets import Target, robot_targets, select_robots, server_target

PROG = "ciirc-exec.sh"

#: command -> (side, action, one line of help); `scripts/ciirc-exec.sh --help` shows the same.
COMMANDS: Dict[str, Tuple[str, str, str]] = {
    "server:init": ("server", "init", "Clone the repository on the server (deploy key copied first)."),
    "server:update": ("server", "update", "Hard-reset the server's checkout to the branch's newest commit."),
    "server:build": ("server", "build", "Run the server's build command (the project setup)."),
    "server:start": ("server", "start", "Start the server's processes, each in its own tmux session."),
    "server:stop": ("server", "stop", "Stop the server's processes (Ctrl-C, then the sessions go)."),
    "server:status": ("server", "status", "Say what runs on the server and which commit it has."),
    "server:ssh": ("server", "ssh", "Open a shell in the server's checkout."),
    "server:inspect": ("server", "inspect", "Attach to the server's process (tmux; Ctrl-b d detaches)."),
    "robots:init": ("robots", "init", "Clone the repository on robots ID... or all (deploy key copied first)."),
    "robots:update": ("robots", "update", "Hard-reset robots ID... or all to the branch's newest commit."),
    "robots:update:all": ("robots", "update", "Same as robots:update all."),
    "robots:build": ("robots", "build", "Build on robots ID... or all (catkin_make)."),
    "robots:start": ("robots", "start", "Start robots ID... or all, each process in its own tmux session."),
    "robots:start:all": ("robots", "start", "Same as robots:start all."),
    "robots:stop": ("robots", "stop", "Stop robots ID... (default all)."),
    "robots:status": ("robots", "status", "Say what runs on robots ID... (default all), which commit."),
    "robots:ssh": ("robots", "ssh", "Open a shell in robot ID's checkout."),
    "robots:inspect": ("robots", "inspect", "Attach to robot ID's process (tmux; Ctrl-b d detaches)."),
    "net:check": ("robots", "net", "Per robot: reachable, SSH login, command port, wire status."),
}

_ALL_BY_DEFAULT = ("stop", "status", "net")  # harmless or expected on the whole fleet


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, default=None, metavar="FILE",
                        help="deployment settings (default: $FLEETCONTROL_DEPLOY, else deploy.yaml "
                             "beside the robot definitions)")
    parser.add_argument("--definitions", type=Path, default=None, metavar="FILE",
                        help="robot definitions (default: $FLEETCONTROL_ROBOTS, else the "
                             "repository's robot_definitions.txt)")
    parser.add_argument("--log-dir", type=Path, default=None, metavar="DIR",
                        help="per-machine logs (default: log_dir in deploy.yaml, logs/deploy)")
    parser.add_argument("--jobs", type=_jobs, default=0, metavar="N",
                        help="machines at a time (default 0: all at once; 1: one by one)")
    parser.add_argument("--dry-run", action="store_true",
                        help="print what would run where, and connect to nothing")
    parser.add_argument("--accept-new-host-keys", action="store_true",
                        help="trust the host key of a machine met for the first time (adds it to "
                             "known_hosts); a changed key is refused all the same")


def _jobs(text: str) -> int:
    return integer(text, 0, None, "a number of machines at a time (0: all)")


def build_parser() -> Parser:
    parser = Parser(
        prog=PROG, description="Deploy FleetControl to the server and the robots over SSH.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, (side, action, text) in COMMANDS.items():
        p = sub.add_parser(name, help=text, description=text)
        if side == "robots" and action in ("ssh", "inspect"):
            p.add_argument("ids", nargs=1, metavar="ID", help="the robot's id")
        elif side == "robots" and not name.endswith(":all"):
            p.add_argument("ids", nargs="*", metavar="ID", help="robot ids, or 'all'")
        if action == "net":
            p.add_argument("--keys", type=Path, default=None, metavar="DIR",
                           help="CurveZMQ keys (manager.key_secret, robot.key; default: "
                                "$FLEETCONTROL_KEYS, else ~/.config/fleetcontrol/keys)")
            p.add_argument("--no-curve", action="store_true",
                           help="talk to robots without CurveZMQ (robots run with --no-curve)")
            p.add_argument("--wire-timeout", type=positive, default=3.0, metavar="S",
                           help="seconds to wait for every robot's status (default 3)")
            p.add_argument("--feedback-base", type=port, default=FEEDBACK_PORT, metavar="PORT",
                           help="pose feedback port of a robot alone on its host; robots sharing "
                                "a host use PORT+1, ... (default {}, as the robots)".format(
                                    FEEDBACK_PORT))
            p.add_argument("--hello", action="store_true",
                           help="say Hello and ask GetStatus instead of listening to pose feedback: "
                                "checks the protocol version too, but takes each robot over from "
                                "a running manager for a few seconds")
        _common(p)
    return parser


def _load(args: argparse.Namespace) -> DeployConfig:
    config = read_config(args.config or default_config_path())
    if args.log_dir is not None:
        config = replace(config, log_dir=args.log_dir)
    return config


def _targets(args: argparse.Namespace, config: DeployConfig, side: str, action: str) -> List[Target]:
    if side == "server":
        return [server_target(config)]
    path = args.definitions or default_definitions_path()
    robots = read_robot_definitions(path)
    ids = ["all"] if args.command.endswith(":all") else list(args.ids)
    if not ids and action in _ALL_BY_DEFAULT:
        ids = ["all"]
    return robot_targets(config, select_robots(robots, ids, str(path)))


def _fan_out(args: argparse.Namespace, side: str, action: str) -> int:
    config = _load(args)
    targets = _targets(args, config, side, action)
    plans = {t.name: steps(action, t, config) for t in targets}  # bad local files fail here
    if args.dry_run:
        print("\n\n".join(format_steps(t, plans[t.name]) for t in targets))
        return 0
    mode = "" if len(targets) == 1 else " one by one" if args.jobs == 1 else " in parallel"
    print("{}: {} machine{}{}".format(args.command, len(targets), "s" * (len(targets) != 1),
                                      mode), flush=True)
    outcomes = run_all(
        targets, lambda t, log: run_steps(t, config, plans[t.name], args.accept_new_host_keys, log),
        args.command, config.log_dir, args.jobs)
    print(format_table(outcomes))
    return exit_status(outcomes)


def _interactive(args: argparse.Namespace, side: str, action: str) -> int:
    config = _load(args)
    target = _targets(args, config, side, action)[0]
    remote = shell_command(target) if action == "ssh" else inspect_command(target, config)
    argv = ssh_argv(target, config, remote, args.accept_new_host_keys)
    if args.dry_run:
        print(" ".join(shlex.quote(a) for a in argv))
        return 0
    sys.stdout.flush()
    try:
        os.execvp(argv[0], argv)
    except FileNotFoundError:
        raise DeployError("ssh (the OpenSSH client) is not installed: run "
                          "scripts/ciirc-exec.sh setup") from None
    return 0  # not reached


def _net_check(args: argparse.Namespace) -> int:
    from fleet_common.transport.curve_keys import (ManagerKeys, default_keys_dir,
                                                   load_manager_keys)

    from .netcheck import check_robots, format_checks

    config = _load(args)
    targets = _targets(args, config, "robots", "net")
    path = args.definitions or default_definitions_path()
    wanted = {t.robot_id for t in targets}
    defined = read_robot_definitions(path)
    robots = [r for r in defined if r.id in wanted]
    # the port rule counts every robot on a host, chosen or not
    feedback = None if args.hello else feedback_ports(defined, args.feedback_base, str(path))
    if args.dry_run:
        for r, t in zip(robots, targets):
            wire = "Hello + GetStatus" if feedback is None else \
                "pose feedback on {}:{}".format(r.host, feedback[r.id])
            print("robot {}: TCP {}:{} and SSH login {}, TCP {}:{} and {}".format(
                r.id, r.host, t.port, t.address, r.host, r.command_port, wire))
        return 0
    keys: Optional[ManagerKeys] = None
    problem = ""
    if not args.no_curve:
        try:
            keys = load_manager_keys(args.keys or default_keys_dir())
        except FleetError as err:
            problem = "{} (or --no-curve)".format(err)
    checks = check_robots(robots, targets, config, keys, args.wire_timeout, problem, feedback)
    print(format_checks(checks))
    return 0 if all(c.ok for c in checks) else 1


def main(argv: Optional[List[str]] = None) -> int:
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    # argparse reports an unknown option from the top level, whose help lists the commands only:
    # point such a line to the command's own help (the top level has no options, so the first
    # word names the command)
    if words and words[0] in COMMANDS:
        parser.see = "{} {}".format(PROG, words[0])
    args = parser.parse_args(words)
    side, action, _ = COMMANDS[args.command]
    try:
        if action == "net":
            return _net_check(args)
        if action in ("ssh", "inspect"):
            return _interactive(args, side, action)
        return _fan_out(args, side, action)
    except FormatError as err:
        print(str(err), file=sys.stderr)
    except FleetError as err:
        print("{} {}: {}".format(PROG, args.command, err), file=sys.stderr)
    except KeyboardInterrupt:
        return 130
    return 2
