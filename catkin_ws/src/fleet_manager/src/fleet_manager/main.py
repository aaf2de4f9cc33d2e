"""The manager's command line: `fleetctl manager` and the lab PC's `fleet_manager` node (thesis 5.3).

Connects to every robot of the fleet, checks that each stands on its start
cell, and on Start executes the plan under the chosen synchronization
strategy, feeding the robots' acknowledgements and completions into the
execution engine. Consoles connect to --bind (state stream 20 times a
second, commands: start, pause, stop, step, halt, strategy, enable/disable,
position source, reroute mode, load, replan). With --vicon, Vicon Tracker's stream is a
second position source, compared with the robots' own. Every run leaves a
run folder; --resume RUNDIR continues the run of a manager that died there.
"""
from __future__ import annotations

import argparse
import os
import signal
from pathlib import Path
from typing import List, Optional

from fleet_common.arg_types import ROBOT_SIZE_HELP, Parser, count, port, positive, robot_size, seed

DESCRIPTION = (
    "Execute PLAN (a mapf-IR solution, or an instance planned first with a built-in solver) on "
    "the fleet: plan agent i runs on the i-th robot of the definitions (or of --robots). Without "
    "--start the run waits for a console's Start. With --until-done it ends when every enabled "
    "robot is at its goal (exit 0) or the run cannot go on (exit 1, saying why), and prints a "
    "summary: arrivals, executed makespan, sum of costs, waits, collisions and the smallest "
    "distance between two robots. Ctrl-C stops every robot and closes the run log. --resume "
    "continues the run of a manager that died, in its run folder.")

#: --resume without a folder: the last run of PLAN on these robots in the --log folder.
LAST = "last"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from fleet_common.execution import STRATEGIES
    from fleet_common.execution.reroute import MODES as REROUTE_MODES, SCOPES as REROUTE_SCOPES
    from fleet_common.transport.console_channel import DEFAULT_ENDPOINT

    parser.add_argument("plan", type=Path, metavar="PLAN", nargs="?", default=None,
                        help="mapf-IR solution (run as it is) or instance (planned first); not "
                             "needed with --resume RUNDIR")
    parser.add_argument("--resume", nargs="?", const=LAST, default=None, metavar="RUNDIR",
                        help="continue the run of a manager that died, in its run folder RUNDIR "
                             "(alone: the last run of PLAN on these robots in the --log folder): "
                             "its progress from the folder's records, the robots where they "
                             "stand (those off the plan are replanned), the same strategy, the "
                             "run log appended to")
    parser.add_argument("--accept", action="store_true",
                        help="accept every replan proposal at once (for scripts; an operator "
                             "accepts in the console)")
    parser.add_argument("--definitions", type=Path, default=None, metavar="FILE",
                        help="robot definitions (default: $FLEETCONTROL_ROBOTS, else the "
                             "repository's robot_definitions.txt)")
    parser.add_argument("--robots", type=_ids, default=None, metavar="ID,...",
                        help="run on these robots, agent i on the i-th (default: every robot)")
    parser.add_argument("--host", default=None, metavar="HOST",
                        help="connect to every robot at HOST instead of its definitions address "
                             "(127.0.0.1 for `fleetctl virtual-fleet`)")
    parser.add_argument("--strategy", choices=list(STRATEGIES), default="adg",
                        help="synchronization strategy (default adg; switchable from a console)")
    parser.add_argument("--reroute", choices=list(REROUTE_MODES), default="off",
                        help="reroute robots a late robot holds up when it pays: off (default), "
                             "propose (the consoles show the new paths; accept or reject) or auto "
                             "(at once, the run going on); switchable from a console; a resumed run "
                             "keeps the mode it had")
    parser.add_argument("--trim", action="store_true",
                        help="trim each robot's path to the fewest moves that bring it in no later, around the "
                             "others: the plan at the start, any plan loaded later, and the held scope's "
                             "reroutes' plans before their hand-over (fewer moves meet fewer delays; off: the "
                             "plan as given; --reroute-scope all trims its own plans whatever this says; the "
                             "held scope does worse on a trimmed plan, EVALUATION.md)")
    parser.add_argument("--reroute-scope", choices=list(REROUTE_SCOPES), default="held",
                        help="whom a reroute may give new paths: held (the robots a late robot holds up, "
                             "default) or all (every robot replanned from where it is by PIBT when the "
                             "predicted makespan drops; a robot on a new path that moves before the "
                             "hand-over drops it); switchable from a console; a resumed run keeps "
                             "the scope it had")
    parser.add_argument("--lookahead", type=count, default=1, metavar="K",
                        help="adg: actions a robot may be sent ahead (default 1)")
    parser.add_argument("--bind", default=DEFAULT_ENDPOINT, metavar="ENDPOINT",
                        help="where consoles connect (default {})".format(DEFAULT_ENDPOINT))
    parser.add_argument("--log", type=Path, default=None, metavar="DIR",
                        help="run folders go in DIR/<timestamp>/ (default: $FLEETCONTROL_RUNS, else "
                             "~/.local/share/fleetcontrol/runs)")
    parser.add_argument("--no-log", action="store_true", help="write no run folder")
    parser.add_argument("--start", action="store_true",
                        help="start as soon as every robot is connected and on its start cell")
    parser.add_argument("--until-done", action="store_true",
                        help="exit when the run is over, printing its summary")
    parser.add_argument("--time-limit", type=positive, default=None, metavar="S",
                        help="with --until-done: give up (exit 1) after S seconds")
    parser.add_argument("--connect-timeout", type=positive, default=60.0, metavar="S",
                        help="with --start: how long to wait for every robot (default 60 s)")
    parser.add_argument("--keys", type=Path, default=None, metavar="DIR",
                        help="CurveZMQ key folder (default: $FLEETCONTROL_KEYS, else "
                             "~/.config/fleetcontrol/keys)")
    parser.add_argument("--no-curve", action="store_true",
                        help="no CurveZMQ to robots or consoles; for local experiments")
    parser.add_argument("--step-time", type=positive, default=2.5, metavar="S",
                        help="seconds a plan step is expected to take: the consoles' planned "
                             "position and 'behind plan' (default 2.5)")
    parser.add_argument("--state-rate", type=positive, default=20.0, metavar="HZ",
                        help="state messages to consoles per second when nothing happens "
                             "(default 20)")
    parser.add_argument("--state-max-rate", type=positive, default=50.0, metavar="HZ",
                        help="news (a pose, a reply) goes to consoles at once, but at most this "
                             "many times a second (default 50)")
    parser.add_argument("--no-preturn", action="store_true",
                        help="robots do not turn towards their next cell while they wait")
    parser.add_argument("-s", "--solver", default=None,
                        help="built-in solver for an instance (default cbs for up to 12 agents, "
                             "falling back to lacam; lacam above)")
    parser.add_argument("--plan-time-limit", type=positive, default=10.0, metavar="S",
                        help="how long planning an instance may take (default 10 s)")
    parser.add_argument("--no-repair", action="store_true",
                        help="do not repair the plan's rotations (robots cannot perform them): refuse it")
    parser.add_argument("--seed", type=seed, default=0)
    parser.add_argument("--vicon", type=port, default=None, metavar="PORT",
                        help="read Vicon Tracker's UDP stream on PORT (51001 in the lab): a "
                             "second position source, compared with the robots' own")
    parser.add_argument("--vicon-bind", default="0.0.0.0", metavar="ADDRESS",
                        help="local address for --vicon (default 0.0.0.0, every interface)")
    parser.add_argument("--frames", type=Path, default=None, metavar="FILE",
                        help="frames file holding vicon_to_base (default: the lab's frames.yaml)")
    parser.add_argument("--robot-size", type=robot_size, default=None, metavar="D:M|cell",
                        help=ROBOT_SIZE_HELP)
    parser.add_argument("--map-dir", metavar="D", action="append", default=[], type=Path,
                        help="folder to search for map_file= (repeatable), before the defaults")
    parser.add_argument("--plans", metavar="DIR", action="append", default=[], type=Path,
                        help="a folder whose plans and instances consoles may load by name "
                             "(repeatable); without it consoles send a plan's content")
    parser.add_argument("--log-level", default="warning",
                        choices=["debug", "info", "warning", "error"])


def _ids(text: str) -> List[int]:
    try:
        ids = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        ids = []
    if not ids:
        raise argparse.ArgumentTypeError("expected robot ids like 1,2,5, got {!r}".format(text))
    return ids


def default_runs_dir() -> Path:
    env = os.environ.get("FLEETCONTROL_RUNS")
    if env:
        return Path(env)
    data = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(data) / "fleetcontrol" / "runs"


def run(args: argparse.Namespace) -> int:
    import logging

    from fleet_common.errors import FleetError
    from fleet_common.formats.mapsearch import default_map_dirs
    from fleet_common.plan_loading import load_plan, pick_robots
    from fleet_common.robots import default_definitions_path, read_robot_definitions, read_robot_size
    from fleet_common.transport.curve_keys import default_keys_dir, load_manager_keys

    from .manager import Manager
    from .settings import ManagerSettings

    dirs = list(args.map_dir) + default_map_dirs()

    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(message)s")
    if args.plan is None and args.resume in (None, LAST):
        raise FleetError("give a PLAN to run, or --resume RUNDIR to continue a run")
    definitions = args.definitions or default_definitions_path()
    log_dir = None if args.no_log else (args.log or default_runs_dir())
    resume = None
    if args.resume is not None:
        from .resume_folder import load_resume

        fleet, loaded, resume = load_resume(args, definitions, dirs, log_dir, args.resume == LAST)
    else:
        fleet = pick_robots(read_robot_definitions(definitions), args.robots, str(definitions))
        loaded = load_plan(args.plan, len(fleet), str(definitions) if args.robots is None
                           else "--robots", dirs, solver=args.solver,
                           time_limit=args.plan_time_limit, seed=args.seed, repair=not args.no_repair)
    try:
        keys = None if args.no_curve else load_manager_keys(args.keys or default_keys_dir())
    except FleetError as err:
        raise FleetError("{}; or run with --no-curve (and the robots too)".format(err)) from err
    strategy, lookahead, reroute, scope = args.strategy, args.lookahead, args.reroute, args.reroute_scope
    trim = args.trim
    if resume is not None:  # the run goes on under the strategy, reroute mode and scope and trim it had
        strategy = resume[0].strategy
        lookahead = int(resume[0].settings.get("lookahead") or 1)
        reroute, scope = resume[0].reroute, resume[0].reroute_scope
        trim = resume[0].trim
    settings = ManagerSettings(
        strategy=strategy, lookahead=lookahead, bind=args.bind, log_dir=log_dir,
        step_time=args.step_time, state_rate=args.state_rate,
        state_max_rate=max(args.state_max_rate, args.state_rate), preturn=not args.no_preturn,
        definitions=definitions, map_dirs=dirs, vicon_port=args.vicon,
        vicon_bind=args.vicon_bind, frames=args.frames, plan_dirs=list(args.plans),
        size=args.robot_size or read_robot_size(definitions), accept=args.accept, reroute=reroute,
        reroute_scope=scope, trim=trim)
    manager = Manager(loaded, fleet, settings, keys=keys, host=args.host, resume=resume)
    loaded = manager.core.run.loaded  # trimmed, with --trim
    stopping: List[str] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, _frame: stopping.append(signal.Signals(signum).name))
    print("manager: {} robots ({}), plan {} ({}, {} steps), strategy {}{}; consoles on {} ({}){}".format(
        len(fleet), ", ".join(str(r.id) for r in fleet), loaded.name, loaded.note,
        loaded.plan.makespan, manager.core.run.engine.strategy.describe(),
        "" if reroute == "off" else ", reroute " + reroute + (
            "" if scope == "held" else " (scope " + scope + ")"), manager.consoles.endpoint,
        ("CURVE" if keys is not None else "no CURVE") + (
            "; Vicon on UDP {}:{}".format(*manager.vicon.address)
            if manager.vicon is not None else ""),
        "; run folder {}".format(manager.folder) if manager.folder else ""), flush=True)
    if resume is not None:
        engine = manager.core.run.engine
        print("resuming {}: {}, {} of {} actions done{}".format(
            resume[0].folder, resume[0].plan if resume[0].for_plan is None
            else "the way to the starts of {}".format(resume[0].for_plan),
            sum(engine.run.completed), engine.table.num_actions,
            "" if resume[0].began is not None else " (the run had not started)"), flush=True)
    outcome: Optional[str] = None
    try:
        if args.start:
            outcome = _start_when_ready(manager, args.connect_timeout, lambda: bool(stopping))
        if outcome is None and not stopping:
            outcome = manager.run(lambda: bool(stopping), until_done=args.until_done,
                                  time_limit=args.time_limit)
    finally:
        reason = ("interrupted ({})".format(stopping[0]) if stopping else outcome
                  or ("done" if manager.core.run.phase.phase == "done" else "manager stopped"))
        manager.stop_robots()
        manager.close(reason)
    summary = manager.summary()
    if args.until_done or stopping or outcome:
        if manager.core.run.started_at is None:  # nothing ran: no figures to give
            print("no summary: the run never started", flush=True)
        else:
            for line in summary.lines():
                print(line, flush=True)
    if manager.folder is not None:
        print("run folder: {}".format(manager.folder), flush=True)
    if stopping:
        return 130
    if outcome is not None:
        print("fleetctl manager: {}".format(outcome), flush=True)
        return 1
    if args.until_done:
        return 0 if summary.collisions == 0 and len(summary.arrived) == summary.enabled else 1
    return 0


def _start_when_ready(manager, timeout: float, should_stop) -> Optional[str]:
    """Serve until every robot is up and on its start, then Start; the reason if not in time."""
    deadline = manager.now() + timeout
    while not should_stop():
        until = min(deadline, manager.now() + 0.2)
        manager.run(lambda: should_stop() or manager.now() >= until)
        problem = manager.core.run.not_ready()
        if not problem:
            resumed = manager.core.run.phase.phase != "waiting"
            ok, problem = manager.start()
            if ok:
                print("started: {}".format("the resumed run drives on" if resumed
                                           else "every robot connected and on its start cell"), flush=True)
                return None
        if manager.now() >= deadline:
            return "cannot start after {:g} s: {}".format(timeout, problem)
    return None


def main(argv: Optional[List[str]] = None) -> int:
    """The lab PC's `fleet_manager` node: the same options; errors as one line, exit 2."""
    import sys

    from fleet_common.errors import FleetError

    parser = Parser(prog="fleet_manager", description=DESCRIPTION)
    add_arguments(parser)
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        return run(args)
    except FleetError as err:
        print("fleet_manager: {}".format(err), file=sys.stderr)
        return 2
    except OSError as err:
        where = "{}: ".format(err.filename) if err.filename is not None else ""
        print("fleet_manager: {}{}".format(where, err.strerror or err), file=sys.stderr)
        return 2
