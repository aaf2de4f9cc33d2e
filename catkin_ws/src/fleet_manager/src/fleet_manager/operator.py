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
nothing new and lets robots finish the move they are making; `to_starts`
sends the robots from where they stand to the plan's starts (a run of its
own, planned first), `reset` starts the plan over in a new run folder, the
robots driving back to their starts first (either, pressed while robots are
still finishing their moves, is carried out once they stand: `way_after`). Strategy switches, the reroute
mode, enabling and disabling robots, and the position source apply at once,
whatever the phase (a robot enabled after the end of the run drives on: a new
leg; one a replan left away from its goal, enabled while the run is running or
after its end, is given a way home around the others at once; enabled while
it was paused or stopped, at Start; and if no way was free then, once one
opens, tried again every plan step: `Run.take_home`, `ways_home`). `accept` and `reject` answer a replan's proposal or a reroute's
(`rerouting`: accepted, it is handed over at once if the robots it reroutes
have not moved since; the run never paused for it).

Each run action without arguments has its refusal written once (`why_not`),
so that the State can say which of them the manager would carry out now
(`allowed`) and why not the others (`refusals`, one pass for both): a console
greys them and says why.
"""
from __future__ import annotations

from typing import Any, Callable, Dict, Optional, Tuple

from fleet_common.control import ACTIONS as CONSOLE_ACTIONS
from fleet_common.control import RUN_ACTIONS
from fleet_common.errors import FleetError
from fleet_common.execution import STRATEGIES, Disabled, Pause, PlanError, Resume, StepRound, SwitchStrategy, make_strategy
from fleet_common.execution.reroute import MODES as REROUTE_MODES, SCOPES as REROUTE_SCOPES
from fleet_common.grid import Grid
from fleet_common.limits import one_line
from fleet_common.plan_loading import LoadedPlan

from .carried import carried, carried_words, replan_refusal
from .outbox import REROUTE, LoadJob
from .plan_requests import SOLVE_LIMIT, Requested, read_requested
from .replanning import PLANNING, PROPOSED, SAFE_POINT, placed
from .robot import VICON, Robot
from .run import NO_WAY_HOME, TO_STARTS, Run
from .run_phase import DONE, PAUSED, RUNNING, STOPPED, WAITING

__all__ = ["apply", "resume", "solved", "allowed", "refusals", "why_not", "behind_out", "ways_home", "way_after",
           "ACTIONS"]

Answer = Tuple[bool, str]
Args = Dict[str, Any]
_REPLAN_OPEN = "a replan is being made or awaits accept/reject; answer it first"
_TO_STARTS_BUSY = "the way to the starts is being planned; the robots drive there next"
#: How long a Reset or Go to starts pressed while robots finish their moves waits for them to
#: stand (a drive takes 2-3 s on the lab's robots; a halted robot's next pose comes within 0.2 s)
WAY_AFTER_LIMIT = 15.0


def apply(run: Run, action: str, args: Args, now: float) -> Answer:
    """Carry out `action` (a name from ACTIONS) with its checked `args`."""
    handler = ACTIONS.get(action)
    if handler is None:
        return False, "unknown action {!r}".format(action)
    return handler(run, args, now)


# ---- the run ------------------------------------------------------------------------------

def why_not(run: Run, action: str, now: float) -> str:
    """Why run action `action` (of RUN_ACTIONS) would be refused now ("" if it would not)."""
    return _WHY_NOT[action](run) or ""


def allowed(run: Run, now: float) -> Tuple[str, ...]:
    """The run actions the manager would carry out now (what they share is looked at once)."""
    refused = refusals(run, now)
    return tuple(a for a in RUN_ACTIONS if a not in refused)


def refusals(run: Run, now: float) -> Dict[str, str]:
    """The run actions the manager would refuse now, each with why (the sentence its answer would
    give), in RUN_ACTIONS' order; the others are allowed. One pass: what the refusals share is
    looked at once."""
    _SHARED.clear()
    _SHARED["on"] = run
    try:
        answers = ((a, why_not(run, a, now)) for a in RUN_ACTIONS)
        return {a: why for a, why in answers if why}
    finally:
        _SHARED.clear()


#: Within one `allowed`, the answers several refusals share (where the robots stand: 300 robots
#: cost milliseconds), by question; empty otherwise.
_SHARED: Dict[str, Any] = {}


def _once(run: Run, question: str, answer: Callable[[], Any]) -> Any:
    if _SHARED.get("on") is not run:
        return answer()
    if question not in _SHARED:
        _SHARED[question] = answer()
    return _SHARED[question]


def _busy(run: Run) -> Optional[str]:
    if run.replanner.open:
        return _REPLAN_OPEN
    if run.to_starts_job is not None:
        return _TO_STARTS_BUSY
    if run.loading is not None:
        return "{} is being solved to be loaded; wait for it".format(run.loading[1])
    return None


def _why_not_start(run: Run) -> Optional[str]:
    return _busy(run) or run.phase.refusal("start") or _ready(run) or _moved(run)


def _why_not_step(run: Run) -> Optional[str]:
    return run.phase.refusal("step") or _busy(run) or _ready(run) or _moved(run)


def _carried(run: Run) -> list:
    """The robots moved by hand (`carried`), judged once for all the refusals of a State."""
    return _once(run, "carried", lambda: carried(run))


def _moved(run: Run) -> str:
    """Why no robot may drive now ("" if they may): one was moved by hand."""
    return carried_words(run, _carried(run))


def _ready(run: Run) -> str:
    """At the first start or step (or the first after a resume), why the robots cannot go ("" when
    they can)."""
    if run.resuming is not None:
        return run.not_ready()
    if run.phase.phase != WAITING:
        return ""
    return _once(run, "not_ready", run.not_ready)


def start(run: Run, args: Args, now: float) -> Answer:
    refusal = _why_not_start(run)
    if refusal:
        return False, refusal
    if run.phase.phase == WAITING:
        run.begin_clock(now)
    resume(run, now)
    return True, ways_home(run, now)


def ways_home(run: Run, now: float) -> str:
    """Robots a replan left away from their goals that take part again (enabled while the run was
    paused or stopped, or with no way round then) are given ways home around the others while it
    runs (`Run.take_home`): at Start, and again every plan step (`RunCore.tick`); what to tell the
    operator ("" if nobody was given one)."""
    waiting = [r for r in run.fleet if r.agent in run.stranded and run.engine.run.out[r.agent] is None]
    if not waiting or run.phase.phase != RUNNING or run.replanner.open or run.rerouting.proposal_id is not None:
        return ""
    for robot in waiting:
        if run.take_home(robot, now) is None:
            break
    home = [r.id for r in waiting if r.agent not in run.stranded]
    return "" if not home else "robot{} {} drive{} to {} goal{}: plan {} takes {} there around the others".format(
        "s" if len(home) > 1 else "", ", ".join(map(str, home)), "" if len(home) > 1 else "s",
        "their" if len(home) > 1 else "its", "s" if len(home) > 1 else "", run.plan_id,
        "them" if len(home) > 1 else "it")


def resume(run: Run, now: float, trigger: str = "start") -> None:
    """Drive on: halted robots are enabled again, the engine resumes."""
    run.take_back_halted(now, "resumed after halt")
    run.move(trigger, "" if run.purpose != TO_STARTS else "driving every robot to its start for {}".format(
        run.target.title))
    run.driver.handle(Resume(now), now)


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
    cut = run.cut_off()
    if run.replanner.state == SAFE_POINT and cut:
        # a replan waiting for a robot whose link is down in a move waits until it is back: Stop gives
        # it up (its line says so), and the others may drive on meanwhile (a battery that died)
        run.drop_replan()
        run.replan_said = None
        run.move("stop", "stopped by operator: replan given up, robot{} {} not back; Start drives the others "
                         "on, and a replan may be asked for again once {} back".format(
                             "s" if len(cut) > 1 else "", ", ".join(map(str, cut)),
                             "it is" if len(cut) == 1 else "they are"))
        return True, "replan given up"
    run.move("stop", "stopped by operator: robots finish their move")
    return True, ""


def step(run: Run, args: Args, now: float) -> Answer:
    refusal = _why_not_step(run)
    if refusal:
        return False, refusal
    if run.phase.phase == WAITING:
        run.begin_clock(now)
    run.take_back_halted(now, "stepped after halt")  # (else each step released nothing, for ever)
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
    if not run.replanner.open:
        run.move("halt", "halted by operator: Start drives on")
        return True, ""
    # a replan asked for goes on, and Start waits for it: the line says so and stays the replan's
    # (it said "Start drives on" while a replan waited for a robot powered off in a move, `--faults`)
    pid = run.replanner.proposal_id
    run.move("halt", "halted by operator: " + ("replan {} awaits accept or reject".format(pid) if pid is not None
                                               else "the replan goes on once every robot stands"))
    run.replan_said = run.phase.reason
    return True, ""


# ---- the way to the starts and back ----------------------------------------------------------

def _why_not_to_starts(run: Run) -> Optional[str]:
    refusal = run.phase.refusal("to_starts") or _busy(run)
    if refusal:
        return refusal
    if run.purpose == TO_STARTS:
        return "the robots are on their way to the starts"
    return _way_refusal(run) or ("every robot already stands on its start: press Start"
                                 if _once(run, "on_starts", run.on_target_starts) else None)


def _why_not_reset(run: Run) -> Optional[str]:
    return run.phase.refusal("reset") or _busy(run) or _way_refusal(run)


def _way_refusal(run: Run) -> Optional[str]:
    """Why the robots cannot be sent anywhere now: not all connected, some off cells (None while
    some are finishing a move, `_settling`: the way waits for them, `_after_settling`)."""
    down = [r.id for r in run.fleet if not r.link_up and run.engine.run.out[r.agent] != "disabled"]
    if down:
        return "not connected: robot{} {}".format("s" if len(down) > 1 else "", ", ".join(map(str, down)))
    if _once(run, "settling", lambda: _settling(run)):
        return None
    if _once(run, "on_starts", run.on_target_starts):
        return None
    _, problem = _once(run, "standing", run.standing_cells)
    return "cannot plan the way to the starts: " + problem if problem else None


def _settling(run: Run) -> bool:
    """Some robot is finishing a move, or was stopped in one a moment ago (halted, disabled, its
    bumper) and its pose since has not come yet: where it stands is known a moment later. (One
    whose reply says it completed its move stands on that cell, whatever its late pose says. A
    robot Vicon lost is not settling: that wait has no end the manager can foresee, and
    `Run.standing_cells` says so.)"""
    out = run.engine.run.out
    return run.driver.moving or any(
        r.link_up and out[r.agent] is not None and r.pose is not None and not r.pose_settled()
        and not (r.source == VICON and r.vicon_lost) for r in run.fleet)


def _after_settling(run: Run, action: str, now: float) -> str:
    """Reset or Go to starts pressed while robots finish their moves (after Stop, Pause or Halt):
    carried out once they stand (`way_after`), not refused with "wait until they stand"."""
    run.way_after = (action, now)
    return "{} once every robot stands (some are finishing a move or have just stopped)".format(_LABELS[action])


def way_after(run: Run, now: float) -> Optional[str]:
    """A Reset or Go to starts waiting for the robots to stand (`_after_settling`): carried out
    once they do, called off if something else (Start, a replan, a robot's link lost) makes it
    refused meanwhile, given up after `WAY_AFTER_LIMIT`; what to tell the operator (None: it
    waits on, or none waits)."""
    if run.way_after is None:
        return None
    action, since = run.way_after
    refusal = _WHY_NOT[action](run)
    if not refusal and _settling(run):
        if now - since < WAY_AFTER_LIMIT:
            return None
        refusal = "some robots did not stand within {:.0f} s".format(WAY_AFTER_LIMIT)
    run.way_after = None
    if refusal:
        return "{} called off: {}".format(_LABELS[action], refusal)
    done, text = ACTIONS[action](run, {}, now)
    return "{}: {}".format(_LABELS[action], text) if done else "{} called off: {}".format(_LABELS[action], text)


_LABELS = {"reset": "Reset", "to_starts": "Go to starts"}


def to_starts(run: Run, args: Args, now: float) -> Answer:
    refusal = _why_not_to_starts(run)
    if refusal:
        return False, refusal
    if _settling(run):
        return True, _after_settling(run, "to_starts", now)
    cells, _ = run.standing_cells()
    run.plan_to_starts(cells, now, "planning the way to the starts of {}".format(run.target.title))
    return True, "planning the way to the starts; the robots drive there next"


def reset(run: Run, args: Args, now: float) -> Answer:
    refusal = _why_not_reset(run)
    if refusal:
        return False, refusal
    if _settling(run):
        return True, _after_settling(run, "reset", now)
    if run.on_target_starts():
        run.load(run.target, now, "reset by operator", "{} again: waiting for Start".format(run.target.title))
        return True, "{} again from its starts, in a new run folder".format(run.target.title)
    cells, _ = run.standing_cells()
    run.plan_to_starts(cells, now, "reset: planning the way back to the starts of {}".format(run.target.title))
    return True, "the robots drive back to their starts first (planning the way), then {} waits for " \
        "Start in a new run folder".format(run.target.title)


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
    # said first: the passes the new strategy makes at once are told (and logged) after it
    run.out.record("strategy", name=name, settings=settings, by="operator")
    run.out.desk.bump("strategy {} -> {}".format(old, new.describe()))
    run.out.tell("strategy", None, "strategy switched: {} -> {}".format(old, new.describe()))
    run.driver.handle(SwitchStrategy(new, now), now)
    run.settings.strategy = name
    if "lookahead" in settings:
        run.settings.lookahead = settings["lookahead"]
    return True, ""


def reroute(run: Run, args: Args, now: float) -> Answer:
    """The reroute mode: off, propose (found reroutes await the operator) or auto (at once), its
    scope: held (the robots a late one holds up) or all (every robot, its plans always trimmed),
    and trim (the held scope's reroutes' plans, plans loaded from now on and the plan waiting for
    Start trimmed of moves that bring nobody in sooner); any may be left out (it stays as it is)."""
    mode, scope, trim = args.get("mode"), args.get("scope"), args.get("trim")
    if trim is not None and mode is None and scope is None:
        return _trim(run, bool(trim), now)
    if mode is None and scope is None:
        return False, "a reroute request names a mode ({}), a scope ({}) or trim (true or false)".format(
            ", ".join(REROUTE_MODES), ", ".join(REROUTE_SCOPES))
    if trim is not None:
        ok, why = _trim(run, bool(trim), now)
        if not ok:
            return ok, why
    mode = run.rerouting.mode if mode is None else mode  # a scope alone keeps the mode, and back
    if mode not in REROUTE_MODES:
        return False, "unknown reroute mode {!r}; modes: {}".format(mode, ", ".join(REROUTE_MODES))
    if scope is not None and scope not in REROUTE_SCOPES:
        return False, "unknown reroute scope {!r}; scopes: {}".format(scope, ", ".join(REROUTE_SCOPES))
    rerouting = run.rerouting
    old, old_scope = rerouting.mode, rerouting.rule.scope
    scope = old_scope if scope is None else scope
    if (mode, scope) == (old, old_scope):
        return True, "rerouting is {} already".format(_mode_words(mode, scope))
    dropped = rerouting.proposal_id if mode != "propose" else None
    rerouting.set_mode(mode)
    rerouting.set_scope(scope)
    run.settings.reroute, run.settings.reroute_scope = mode, scope
    run.out.record("reroute_mode", mode=mode, scope=scope, by="operator")
    run.out.desk.bump("reroute {} -> {}".format(_mode_words(old, old_scope), _mode_words(mode, scope)))
    run.out.tell(REROUTE, None, "reroute switched: {} -> {}{}".format(
        _mode_words(old, old_scope), _mode_words(mode, scope),
        "" if dropped is None else " (reroute {} dropped)".format(dropped)))
    return True, ""


def _trim(run: Run, trim: bool, now: float) -> Answer:
    """Trim on or off: the held scope's reroutes' plans before their hand-over and plans loaded
    from now on, and the plan waiting for Start (`Run.trim_waiting`); a plan running stays as it
    is, and so does a trimmed plan when trim goes off (it brings nobody in later)."""
    if run.settings.trim == trim:
        return True, "trim is {} already".format("on" if trim else "off")
    run.settings.trim = trim
    run.rerouting.set_trim(trim)
    run.out.record("reroute_mode", mode=run.rerouting.mode, scope=run.rerouting.rule.scope, trim=trim,
                   by="operator")
    run.out.desk.bump("trim {}".format("on" if trim else "off"))
    if not trim:
        run.out.tell(REROUTE, None, "trim off: plans from now on run as they are made")
        return True, ""
    waiting = run.trim_waiting(now)
    run.out.tell(REROUTE, None, "trim on: {}plans loaded from now on and the held scope's reroutes' plans are "
                 "trimmed of moves that bring nobody in sooner{}".format(
                     "" if waiting is None else "the plan waiting for Start {}; ".format(waiting),
                     " (the plan running stays as it is)" if waiting is None else ""))
    return True, ""


def _mode_words(mode: str, scope: str) -> str:
    """"auto", or "auto (every robot)" for scope all: how a reroute mode is told (off with scope
    all: "off (every robot when on)", so a change of scope alone is not told as "off -> off")."""
    if scope == "held":
        return mode
    return "{} (every robot{})".format(mode, " when on" if mode == "off" else "")


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
    if planned_as_they_stand(run) and run.engine.run.halfway[robot.agent]:  # (enabled, it finishes that move)
        return False, ("a replan is being made or awaits accept/reject, planned with robot {} stopped in its move: "
                       "answer it first, then enable the robot".format(robot.id))
    here = run.positions()[robot.agent]
    if not placed(run.grid, robot, here):  # carried off between two cells while it was out
        pose = robot.pose
        # before the first move the run has it on its start: left off it by the way there, it need
        # not have been moved by anyone (wide dying Vicon session 1091: stopped by its bumper)
        where = "off its start {}" if run.phase.phase == WAITING else "away from {}, where the run has it"
        return False, "robot {} stands at {}, between two cells {}: put it on a cell, then enable it".format(
            robot.id, run.where(pose.x, pose.y), where.format(run.loaded.show(here)))
    # carried onto another cell while it was out: its next drive would start from there (before
    # the first move, where it stands is for Start to judge: on its start, or Go to starts;
    # wide sessions 1021, 1776: disabled on the way to the starts, it stayed off its start)
    moved = [c for c in carried(run) if c.robot is robot] if run.phase.phase != WAITING else []
    if moved:
        return False, carried_words(run, moved) + ", then enable it"
    run.driver.enable(robot, now)
    run.out.record("out", robot=robot.id, why=None, reason="enabled by operator")
    run.out.desk.bump("robot {} enabled".format(robot.id), robot.id)
    stranded = robot.agent in run.stranded
    leg = run.phase.phase == DONE and (stranded or not run.engine.run.finished_agent(robot.agent))
    if leg:
        run.new_leg(robot, now)  # the run goes on
    was = "the run was done: " if leg else ""
    if not stranded:
        return True, was + ("robot {} drives on to its goal (a new leg)".format(robot.id) if leg else "")
    never = run.never_home(robot)  # (a promise of a way home it cannot keep: live session 3)
    if never or run.phase.phase != RUNNING or run.replanner.open or run.rerouting.proposal_id is not None:
        return True, was + (("plan {} has no way to its goal for robot {}: {}; replan to take it home".format(
            run.plan_id, robot.id, never)) if never else (
            "plan {} leaves robot {} away from its goal: it is given a way home around the others once the run "
            "goes on, or replan to take it home".format(run.plan_id, robot.id)))
    why = run.take_home(robot, now)
    if why is None:  # a way home around the others, the run going on
        return True, was + "robot {} drives to its goal: plan {} takes it there around the others".format(
            robot.id, run.plan_id)
    if why == NO_WAY_HOME:  # tried again while the run goes on (`ways_home`)
        return True, was + ("robot {} has no way to its goal around the others now: it drives home once one "
                            "opens, or replan to take it home".format(robot.id))
    return True, was + "plan {} has no way to its goal for robot {}: {}; replan to take it home".format(
        run.plan_id, robot.id, why)


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
    refusal = _load_refusal(run)
    if refusal:
        return False, refusal
    try:
        loaded = read_requested(run.settings.plan_dirs, run.settings.map_dirs, len(run.fleet),
                                args["path"], args["text"], args["name"])
    except FleetError as err:
        return False, "cannot load: {}".format(one_line(str(err), 400))
    grid = loaded.instance.grid if isinstance(loaded, Requested) else loaded.grid
    refusal = _other_map(run, loaded.name, grid)
    if refusal:
        return False, refusal
    if isinstance(loaded, Requested):  # solved off the loop: the robots and consoles are served meanwhile
        job = LoadJob(next(run.job_ids), loaded)
        run.loading = (job.id, loaded.name)  # as the console named it
        run.out.add(job)
        run.out.desk.bump("solving {}".format(loaded.name))
        return True, "{} is an instance: solving it (at most {:g} s); it is loaded when solved".format(
            loaded.name, SOLVE_LIMIT)
    return True, _load(run, loaded, now)


def solved(run: Run, loaded: Optional[LoadedPlan], error: Optional[str], now: float) -> Tuple[bool, str]:
    """The instance being loaded (`run.loading`) was solved, or not (`error`): load its plan if the
    run still may, and say what happened."""
    name = run.loading[1] if run.loading is not None else "?"
    run.loading = None
    if error is not None or loaded is None:
        return False, "cannot load {}: {}".format(name, one_line(error or "no plan", 400))
    refusal = _load_refusal(run)
    if refusal:
        return False, "{} was solved but not loaded: {}".format(name, refusal)
    return True, _load(run, loaded, now)


def _load_refusal(run: Run) -> Optional[str]:
    refusal = run.phase.refusal("load") or _busy(run)
    if refusal is None and run.driver.moving:
        refusal = "load another plan when no robot moves"
    return refusal


def _other_map(run: Run, name: str, mine: Grid) -> Optional[str]:
    if mine == run.fleet_map:
        return None
    fleet = run.fleet_map
    return "cannot load {}: it is a plan for map {} ({} x {}); this fleet runs on {} ({} x {})".format(
        name, mine.name or "?", mine.width, mine.height, fleet.name or "?", fleet.width, fleet.height)


def _load(run: Run, loaded: LoadedPlan, now: float) -> str:
    run.load(loaded, now)
    where = "" if run.on_target_starts() else "; the robots are not on its starts: Go to starts drives them there"
    return "{} loaded ({}){}".format(loaded.title, loaded.note, where)


def replan(run: Run, args: Args, now: float) -> Answer:
    refusal = _WHY_NOT["replan"](run)
    if refusal:
        return False, refusal
    was_running = run.phase.phase == RUNNING
    if was_running:
        run.driver.handle(Pause(now), now)
    run.ask_replan("replanning: waiting for every robot to finish its move" if was_running else run.phase.reason)
    run.replanner.request(was_running, args["time_limit"], args["method"])
    run.out.desk.bump("replan requested")
    return True, "replanning; the proposal follows"


def _answer_reroute(run: Run, args: Args, now: float, take: bool) -> Answer:
    """accept (hand over now, if the robots have not moved since) or reject a reroute proposal."""
    pid, found = run.rerouting.pending  # type: ignore[misc]
    run.rerouting.resolved()
    if not take:
        run.rerouting.rejected(run.engine, now)
        run.out.desk.bump("reroute {} rejected".format(pid))
        return True, "kept plan {}".format(run.plan_id)
    if run.phase.phase != RUNNING:
        run.out.desk.bump("reroute {} dropped".format(pid))
        return False, "the reroute is for a running run (the run is {}); it is dropped".format(run.phase.phase)
    why = run.reroute(found, now)
    if why is not None:
        run.out.desk.bump("reroute {} dropped".format(pid))
        return False, why + "; it is dropped"
    return True, "switched to plan {}".format(run.plan_id)


def planned_as_they_stand(run: Run) -> bool:
    """The open replan has taken where the robots stand (it is being made, or awaits an answer):
    none may move until it is answered. (A live session: robots halted in their moves, enabled
    while the proposal waited, were sent those moves again at once; accepted, the new plan had
    them where they had stood: commands refused as busy, one "moved by hand". Enabling such a
    robot is refused now; a robot that moved all the same drops the proposal at its accept.)"""
    return run.replanner.state in (PLANNING, PROPOSED)


def accept(run: Run, args: Args, now: float) -> Answer:
    if run.rerouting.proposal_id is not None and run.rerouting.proposal_id == args["proposal"]:
        return _answer_reroute(run, args, now, True)
    pending = run.replanner.pending
    if run.replanner.proposal_id is None or pending is None or pending.id != args["proposal"]:
        return False, "no proposal {} awaits an answer".format(args["proposal"])
    started, completed = run.progress()
    was_started, was_completed = pending.progress or (started, completed)
    moved = [r.id for r in run.fleet if (r.flight is not None and r.flight.kind == "drive")
             or started[r.agent] != was_started[r.agent] or completed[r.agent] != was_completed[r.agent]]
    if moved:  # (a plan from where they stood would not fit; enabling a robot stopped in its move is refused)
        why = "replan {} dropped: robot{} {} moved since it was made; replan again".format(
            pending.id, "s" if len(moved) > 1 else "", ", ".join(map(str, moved)))
        run.drop_replan()
        run.replan_ended(why)
        return False, why
    plan = pending.result.plan
    moving = [run.fleet[a].id for a in range(plan.num_agents)
              if (plan.positions[1:, a] != plan.positions[:-1, a]).any()]
    try:
        run.switch_plan(plan, "replan", now, pending.grid)
    except PlanError as err:  # (never, by the checks at the safe point; the run stays as it was)
        why = "replan {} dropped: its plan does not fit the run ({}); replan again".format(pending.id, err)
        run.drop_replan()
        run.replan_ended(why)
        return False, why
    run.out.tell("plan", None, "replanned {} robot{}: plan {} ({})".format(
        len(moving), "" if len(moving) == 1 else "s", run.plan_id, pending.result.message))
    if run.stranded_words():
        run.out.tell("plan", None, run.stranded_words())
    run.replanner.resolved()
    run.replan_ended("switched to plan {}: {}".format(run.plan_id, _drive_on(run)))
    _resume_after_replan(run, now)  # a new plan's engine starts paused: otherwise it stays so
    return True, "switched to plan {}".format(run.plan_id)


def reject(run: Run, args: Args, now: float) -> Answer:
    if run.rerouting.proposal_id is not None and run.rerouting.proposal_id == args["proposal"]:
        return _answer_reroute(run, args, now, False)
    if run.replanner.proposal_id is None or run.replanner.proposal_id != args["proposal"]:
        return False, "no proposal {} awaits an answer".format(args["proposal"])
    run.drop_replan()
    run.replan_ended("replan {} rejected, plan {} kept: {}".format(args["proposal"], run.plan_id, _drive_on(run)))
    run.out.desk.bump("replan rejected")
    _resume_after_replan(run, now)
    return True, "kept plan {}".format(run.plan_id)


def _drive_on(run: Run) -> str:
    """What lets the run drive on after a replan's answer, for the phase line (Start's own refusal
    says the same when it is refused)."""
    moved = carried_words(run, carried(run))
    return moved or ("Start drives on" if run.phase.phase in (PAUSED, STOPPED) else "driving on")


def _resume_after_replan(run: Run, now: float) -> None:
    """Drive on if the run was running when the replan was asked for and nobody paused or
    stopped it since."""
    if run.replanner.was_running and run.phase.refusal("resume") is None and not carried(run):
        resume(run, now, "resume")


def _between_cells(run: Run) -> Optional[str]:
    """Why not replan now: a robot enabled again after a fault in the middle of a move stands
    between two cells until that move, sent again, is made (`RunState.halfway`). A plan from
    its cell would send it on from where it does not stand, and others into the cell it is
    partly in (a robot still out is walled in where it stopped: `replanning.walled`)."""
    state = run.engine.run
    ids = [run.fleet[a].id for a in range(state.num_agents) if state.halfway[a] and state.out[a] is None]
    if not ids:
        return None
    return ("robot{} {} stopped between two cells after a fault: start or step until {} that move, or "
            "disable {} (planned around where {})").format(
        "s" if len(ids) > 1 else "", ", ".join(str(i) for i in ids), "they finish" if len(ids) > 1 else "it finishes",
        "them" if len(ids) > 1 else "it", "they stand" if len(ids) > 1 else "it stands")


def behind_out(run: Run) -> Optional[str]:
    """Why not replan now: a follower waits at its hold point, in the middle of its drive, behind
    a robot that is out (stopped on its way out of the cell the follower enters). A replan starts
    once every robot stands (no command in flight); this one stands only when its leader moves
    on, so the replan would wait for ever, and Start with it (found by random operator sessions)."""
    following, out = run.driver.following, run.engine.run.out
    if run.engine.paused:  # (running, the engine sends it again at once)
        back = [(run.fleet[a].id, run.fleet[lead].id) for a, lead in sorted(run.held_behind_taken_back().items())
                if run.fleet[a].flight is not None]
        if back:
            waits = "; ".join("robot {} waits behind robot {}, whose move was taken back".format(f, lead)
                              for f, lead in back)
            return "{}: a replan needs every robot standing; start (both finish their moves), or halt first".format(
                waits)
    held = [a for a in run.held_behind_out() if run.fleet[a].flight is not None]
    # named: each that waits right behind a robot that is out (a train behind it waits with it)
    pairs = sorted((run.fleet[a].id, run.fleet[following.leader_of(a)].id) for a in held
                   if out[following.leader_of(a)] is not None)
    if not held:
        return None
    if not pairs:  # (cannot be: a train's first follower waits right behind the robot out)
        return "robots {} wait behind a robot that is out: a replan needs every robot standing".format(
            ", ".join(str(run.fleet[a].id) for a in sorted(held)))
    waits = "; ".join("robot {} waits behind robot {}, which is out".format(f, lead) for f, lead in pairs)
    return ("{}: a replan needs every robot standing; enable {} and start (both finish their moves), "
            "or halt first").format(waits, "robot {}".format(pairs[0][1]) if len({p[1] for p in pairs}) == 1
                                    else "those robots")


_WHY_NOT: Dict[str, Callable[[Run], Optional[str]]] = {
    "start": _why_not_start, "step": _why_not_step,
    "pause": lambda run: run.phase.refusal("pause"), "stop": lambda run: run.phase.refusal("stop"),
    "halt": lambda run: run.phase.refusal("halt"),
    # (on the way to the starts too: its goals are the starts; a robot stuck on the way, or left
    # without one by a replan, has no other way on: Reset and Go to starts plan the same)
    "replan": lambda run: run.phase.refusal("replan") or (
        "a replan is already being made or awaits accept/reject" if run.replanner.open else None) or (
        "a reroute proposal awaits accept/reject; answer it first" if run.rerouting.proposal_id is not None
        else None) or _between_cells(run) or behind_out(run) or replan_refusal(run, _carried(run)),
    "to_starts": _why_not_to_starts, "reset": _why_not_reset,
}
if set(_WHY_NOT) != set(RUN_ACTIONS):
    raise ImportError("run actions {} differ from the console protocol's {}".format(
        sorted(_WHY_NOT), sorted(RUN_ACTIONS)))

ACTIONS: Dict[str, Callable[[Run, Args, float], Answer]] = {
    "start": start, "pause": pause, "stop": stop, "step": step, "halt": halt,
    "to_starts": to_starts, "reset": reset,
    "strategy": strategy, "reroute": reroute, "enable": enable, "disable": disable, "source": source,
    "load": load, "replan": replan, "accept": accept, "reject": reject,
}
if set(ACTIONS) != set(CONSOLE_ACTIONS):  # the protocol's table is the one list of actions
    raise ImportError("operator actions {} differ from the console protocol's {}".format(
        sorted(ACTIONS), sorted(CONSOLE_ACTIONS)))
