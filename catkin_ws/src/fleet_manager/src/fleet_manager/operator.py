"""What an operator may do to a run, and the answer to each request.

Every action takes the run, the request's checked arguments and the time,
and returns (done?, a sentence for the operator): a refusal says why and what
to do instead, and changes nothing. Whether a request may move the run's
phase is the phase machine's to say (`run_phase.TRANSITIONS`); the checks
here are the ones that need more than the phase (robots connected and on
their starts, a replan under way).

`start` from waiting checks that every robot is connected and stands on its
plan start; `halt` stops every robot where it is, now (the robots in a move
hold both cells and finish the move when started again); `stop` sends
nothing new and lets robots finish the move they are making. Strategy
switches, enabling and disabling robots, and the position source apply at
once, whatever the phase.
"""
from __future__ import annotations

from typing import Any, Callable, Dict, Optional, Tuple

from fleet_common.control import ACTIONS as CONSOLE_ACTIONS
from fleet_common.errors import FleetError
from fleet_common.execution import STRATEGIES, Disabled, Pause, Resume, StepRound, SwitchStrategy, make_strategy
from fleet_common.limits import one_line

from .plan_requests import load_requested
from .robot import HALTED, VICON, Robot
from .run import Run
from .run_phase import RUNNING, WAITING

__all__ = ["apply", "resume", "ACTIONS"]

Answer = Tuple[bool, str]
Args = Dict[str, Any]
_REPLAN_OPEN = "a replan is being made or awaits accept/reject; answer it first"


def apply(run: Run, action: str, args: Args, now: float) -> Answer:
    """Carry out `action` (a name from ACTIONS) with its checked `args`."""
    handler = ACTIONS.get(action)
    if handler is None:
        return False, "unknown action {!r}".format(action)
    return handler(run, args, now)


# ---- the run ------------------------------------------------------------------------------

def start(run: Run, args: Args, now: float) -> Answer:
    if run.replanner.open:
        return False, _REPLAN_OPEN
    refusal = run.phase.refusal("start") or _ready(run, now)
    if refusal:
        return False, refusal
    resume(run, now)
    return True, ""


def resume(run: Run, now: float, trigger: str = "start") -> None:
    """Drive on: halted robots are enabled again, the engine resumes."""
    for robot in run.fleet:
        if robot.hold == HALTED:
            run.driver.enable(robot, now)
            run.out.record("out", robot=robot.id, why=None, reason="resumed after halt")
    run.move(trigger)
    run.driver.handle(Resume(now), now)


def _ready(run: Run, now: float) -> str:
    """At the first start or step (or the first after a resume), why the robots cannot go ("" when
    they can)."""
    if run.resuming is not None:
        return run.not_ready()
    if run.phase.phase != WAITING:
        return ""
    problem = run.not_ready()
    if not problem:
        run.started_at = now
    return problem


def pause(run: Run, args: Args, now: float) -> Answer:
    refusal = run.phase.refusal("pause")
    if refusal:
        return False, refusal
    run.driver.handle(Pause(now), now)
    run.move("pause", "paused by operator")
    return True, ""


def stop(run: Run, args: Args, now: float) -> Answer:
    refusal = run.phase.refusal("stop")
    if refusal:
        return False, refusal
    if not run.engine.paused:
        run.driver.handle(Pause(now), now)
    run.move("stop", "stopped by operator: robots finish their move")
    return True, ""


def step(run: Run, args: Args, now: float) -> Answer:
    refusal = run.phase.refusal("step") or (_REPLAN_OPEN if run.replanner.open else "") or _ready(run, now)
    if refusal:
        return False, refusal
    run.move("step", "one round released (step)")
    run.driver.handle(StepRound(now), now)
    return True, ""


def halt(run: Run, args: Args, now: float) -> Answer:
    refusal = run.phase.refusal("halt")
    if refusal:
        return False, refusal
    if not run.engine.paused:
        run.driver.handle(Pause(now), now)
    run.driver.halt()
    run.move("halt", "halted by operator: Start drives on")
    return True, ""


# ---- robots and strategy --------------------------------------------------------------------

def strategy(run: Run, args: Args, now: float) -> Answer:
    name = args["name"]
    if name not in STRATEGIES:
        return False, "unknown strategy {!r}; strategies: {}".format(name, ", ".join(STRATEGIES))
    settings = {}
    if args.get("lookahead") is not None:
        if "lookahead" not in STRATEGIES[name].SETTINGS:
            return False, "strategy {} has no lookahead".format(name)
        settings["lookahead"] = args["lookahead"]
    try:
        new = make_strategy(name, **settings)
    except FleetError as err:
        return False, str(err)
    old = run.engine.strategy.describe()
    run.driver.handle(SwitchStrategy(new, now), now)
    run.settings.strategy = name
    if "lookahead" in settings:
        run.settings.lookahead = settings["lookahead"]
    run.out.record("strategy", name=name, settings=settings, by="operator")
    run.out.desk.bump("strategy {} -> {}".format(old, new.describe()))
    run.out.tell("strategy", None, "strategy switched: {} -> {}".format(old, new.describe()))
    return True, ""


def _robot(run: Run, robot_id: int) -> Optional[Robot]:
    return run.fleet.by_id.get(robot_id)


def _not_in_run(run: Run, robot_id: object) -> Answer:
    return False, "robot {} is not in this run (robots: {})".format(
        robot_id, ", ".join(map(str, run.fleet.ids)))


def enable(run: Run, args: Args, now: float) -> Answer:
    robot = _robot(run, args["robot"])
    if robot is None:
        return _not_in_run(run, args["robot"])
    if run.engine.run.out[robot.agent] is None and robot.hold is None:
        return False, "robot {} is already enabled".format(robot.id)
    run.driver.enable(robot, now)
    run.out.record("out", robot=robot.id, why=None, reason="enabled by operator")
    run.out.desk.bump("robot {} enabled".format(robot.id), robot.id)
    return True, ""


def disable(run: Run, args: Args, now: float) -> Answer:
    robot = _robot(run, args["robot"])
    if robot is None:
        return _not_in_run(run, args["robot"])
    if run.engine.run.out[robot.agent] == "disabled":
        return False, "robot {} is already disabled".format(robot.id)
    run.driver.handle(Disabled(robot.agent, now), now)
    run.driver.drop_pending(robot)
    run.out.record("out", robot=robot.id, why="disabled", reason="disabled by operator")
    run.out.desk.bump("robot {} disabled".format(robot.id), robot.id)
    return True, ""


def source(run: Run, args: Args, now: float) -> Answer:
    if args["source"] == VICON and not run.fleet.vicon_enabled:
        return False, "no Vicon stream: start the manager with --vicon PORT"
    if args["robot"] is not None and _robot(run, args["robot"]) is None:
        return _not_in_run(run, args["robot"])
    changed = run.fleet.choose(args["source"], args["robot"])
    if changed:
        run.out.desk.bump("position source {} for robot{} {}".format(
            args["source"], "s" if len(changed) > 1 else "", ", ".join(map(str, changed))), args["robot"])
    return True, ""


# ---- plans --------------------------------------------------------------------------------

def load(run: Run, args: Args, now: float) -> Answer:
    refusal = run.phase.refusal("load")
    if refusal is None and run.driver.moving:
        refusal = "load another plan when no robot moves"
    if refusal:
        return False, refusal
    try:
        loaded = load_requested(run.settings.plan_dirs, run.settings.map_dirs, len(run.fleet),
                                args["path"], args["text"], args["name"])
    except FleetError as err:
        return False, "cannot load: {}".format(one_line(str(err), 400))
    run.load(loaded, now)
    return True, "{} loaded ({})".format(loaded.name, loaded.note)


def replan(run: Run, args: Args, now: float) -> Answer:
    refusal = run.phase.refusal("replan")
    if refusal:
        return False, refusal
    if run.replanner.open:
        return False, "a replan is already being made or awaits accept/reject"
    was_running = run.phase.phase == RUNNING
    if was_running:
        run.driver.handle(Pause(now), now)
    run.move("replan", "replanning: waiting for every robot to finish its move"
             if was_running else run.phase.reason)
    run.replanner.request(was_running, args["time_limit"], args["method"])
    run.out.desk.bump("replan requested")
    return True, "replanning; the proposal follows"


def accept(run: Run, args: Args, now: float) -> Answer:
    pending = run.replanner.pending
    if run.replanner.proposal_id is None or pending is None or pending.id != args["proposal"]:
        return False, "no proposal {} awaits an answer".format(args["proposal"])
    run.switch_plan(pending.result.plan, "replan", now)
    run.replanner.resolved()
    _resume_after_replan(run, now)  # a new plan's engine starts paused: otherwise it stays so
    return True, "switched to plan {}".format(run.plan_id)


def reject(run: Run, args: Args, now: float) -> Answer:
    if run.replanner.proposal_id is None or run.replanner.proposal_id != args["proposal"]:
        return False, "no proposal {} awaits an answer".format(args["proposal"])
    run.replanner.resolved()
    run.out.desk.bump("replan rejected")
    _resume_after_replan(run, now)
    return True, "kept plan {}".format(run.plan_id)


def _resume_after_replan(run: Run, now: float) -> None:
    """Drive on if the run was running when the replan was asked for and nobody paused or
    stopped it since."""
    if run.replanner.was_running and run.phase.refusal("resume") is None:
        resume(run, now, "resume")


ACTIONS: Dict[str, Callable[[Run, Args, float], Answer]] = {
    "start": start, "pause": pause, "stop": stop, "step": step, "halt": halt,
    "strategy": strategy, "enable": enable, "disable": disable, "source": source,
    "load": load, "replan": replan, "accept": accept, "reject": reject,
}
if set(ACTIONS) != set(CONSOLE_ACTIONS):  # the protocol's table is the one list of actions
    raise ImportError("operator actions {} differ from the console protocol's {}".format(
        sorted(ACTIONS), sorted(CONSOLE_ACTIONS)))
