"""The manager's run as a sans-I/O core: values in, values out, no sockets, threads or clocks.

Theory of operation (the model is h11's connection object). `RunCore` owns
everything the manager knows and decides: one `Robot` per robot (link, poses
and their sources, faults, hold, the command in flight), the `Run` (the plan,
its execution engine and driver, the phase machine, the replanner's state)
and the consoles' desk (who is connected, the version clock). Its inputs are
values, each with the time (seconds since the manager started):

    link_event(event, now)        a robot's link: up, down, a reply, a pose
    vicon(fixes, now)             Vicon's poses
    console_frame(peer, data, now)  bytes from a console (hello, request, ...)
    plan_ready(job, result, error, now)  the outcome of a PlanJob
    load_ready(job, loaded, error, now)  the outcome of a LoadJob (an instance to load, solved)
    reroute_ready(job, found, error, now)  the outcome of a RerouteJob (`rerouting`)
    tick(now), publish(now), log_poses(now)  what is due with time

and everything it decides comes out of `take()` as effects, in order
(`outbox`): wire commands to send, run-log records, frames for consoles,
lines for the terminal, planning to run in a thread, a new run folder. The
manager's loop (`manager.py`) owns the sockets and the run log and carries
the effects out; tests drive the core directly with a fake clock and
in-memory robots. A core may take over the run of a manager that died
(`resume`: the folder's records), checking its robots before anything
moves. Nothing a peer sends can raise out of an input: a console frame that
does not decode is refused by the desk, a reply the engine cannot place is
reported and ignored (`driver`); a refused request costs its answer and no
State, and is recorded once a minute per console (`refusals`).
"""
from __future__ import annotations

import math
from typing import Dict, Iterable, List, Optional, Sequence, Set, Tuple

from fleet_common.control import RUN_ACTIONS, Bye, Notice, Waiting
from fleet_common.control.messages import WHY_NOT_CHARS
from fleet_common.control.desk import ControlDesk
from fleet_common.execution import Freeze, Pause, Thaw
from fleet_common.execution.reroute import Reroute
from fleet_common.grid import Coord, Grid
from fleet_common.limits import one_line
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan
from fleet_common.planning.replan import ReplanResult
from fleet_common.robots import RobotDefinition
from fleet_common.runlog.summary import RunSummary
from fleet_common.wire.link_events import LinkDown, LinkEvent, LinkUp, RobotReply
from fleet_common.vicon.base_grid import ViconFix
from fleet_common.wire import PoseFeedback, Stop

from . import operator
from .carried import UNDER_WAY, carried, carried_words, clear_of, halt_near, where_the_run_has_it
from .outbox import Effect, Outbox, REROUTE
from .driver import AT_CELL, MADE_IT
from .refusals import RefusedRequests
from .replanning import SAFE_POINT, going_on, leans_into, stood_on, walled
from .rerouting import moved_since, moved_words
from .resume import ResumePoint, off_plan, passes_near, walls_around
from .robot import HALTED, RESUMING, VICON, Fleet, Robot, Seen
from .run import PLAN, Run, cut_off_words, lost_words
from .run_phase import RUNNING
from .settings import ManagerSettings
from .state_view import build_state, proposal, reroute_proposal, robot_waits
from .vicon_watch import ViconWatch

__all__ = ["RunCore"]

_STALL_GRACE = 3.0  # s a run must stay stuck before an unattended run gives up, or the run's line says so
_CANNOT_GO_ON = "the run cannot go on without an operator: "
_SETUP_EVERY = 1.0  # s: a console saying hello again sooner is not sent the whole setup again
#: Seconds the run actions a State allows may lag the robots' poses (the key's changes count at once).
ALLOWED_EVERY = 0.25
#: s between two looks for robots moved by hand (`carried`): poses come ten times a second
CARRIED_EVERY = 0.1


class RunCore:
    def __init__(self, loaded: LoadedPlan, robots: Sequence[RobotDefinition], settings: ManagerSettings,
                 session: str, now: float = 0.0, vicon: bool = False,
                 resume: Optional[Tuple[ResumePoint, Plan]] = None) -> None:
        self.desk = ControlDesk(session, now)
        self.out = Outbox(self.desk)
        self.out.now = now
        self.fleet = Fleet(robots, settings.stale_after)
        self.settings = settings
        if resume is not None:  # the summary covers the whole run, before and after
            for record in resume[0].records:
                self.out.summary.feed(record)
        self.run = Run(loaded, self.fleet, self.out, settings, resume, now)
        self.vicon_watch = ViconWatch(self.fleet, self.out) if vicon else None
        self._states = 0
        self._last_waits: Optional[Dict[int, Waiting]] = None
        self._stuck_since: Optional[float] = None
        self._refused = RefusedRequests()
        self._setups: Dict[bytes, float] = {}  # console -> when it was last sent the run's setup
        #: something changed that consoles should see soon (the loop publishes within its rate)
        self.news = False
        self._refusals = _Burst()
        #: (key, when, allowed, why not the others): `_allowed_now`
        self._allowed: Optional[Tuple[tuple, float, Tuple[str, ...], Dict[str, str]]] = None
        self._home_due = 0.0  # when robots left away from their goals are next given ways home
        self._stuck_due = 0.0  # when the run is next judged for whether it can go on (`_say_if_stuck`)
        self._said_before = ""  # the run's line before it said it cannot go on
        self._replan_line: Optional[str] = None  # a waiting replan's line before it named robots Vicon lost
        self._carried_due = 0.0  # when robots are next judged for standing where the run has them
        self._carried_told: Set[int] = set()  # the robots found moved by hand, told already

    def take(self) -> List[Effect]:
        """The effects of the inputs so far, in order (and forget them)."""
        return self.out.take()

    def _at(self, now: float) -> None:
        self.out.now = now

    # ---- robots -----------------------------------------------------------------------------

    def link_event(self, event: LinkEvent, now: float) -> None:
        self._at(now)
        robot = self.fleet.by_id.get(event.robot_id)
        if robot is None:
            return
        driver = self.run.driver
        if isinstance(event, PoseFeedback):
            robot.own = Seen(event.pose, now)
            robot.own_current, robot.own_ended = event.current, event.ended
            robot.says_ended = robot.says_ended or event.ended is not None
            robot.facing = None
            if tuple(event.faults) != robot.faults:
                driver.faults(robot, event.faults)
            driver.release_followers(robot)
        elif isinstance(event, RobotReply):
            driver.reply(robot, event.reply, now)
        elif isinstance(event, LinkUp):
            robot.link, robot.link_reason = "up", ""
            driver.link_up(robot, event.restarted, now)
        elif isinstance(event, LinkDown):
            robot.link, robot.link_reason = ("failed" if event.fatal else "down"), event.reason
            driver.link_down(robot, event.reason, event.fatal)

    def vicon(self, fixes: Iterable[ViconFix], now: float) -> None:
        self._at(now)
        if self.vicon_watch is not None:
            self.vicon_watch.poses(fixes, now)

    # ---- consoles ---------------------------------------------------------------------------

    def console_frame(self, peer: bytes, data: bytes, now: float) -> Optional[str]:
        """A frame from console `peer`; the refusal to log, if the desk refused it."""
        self._at(now)
        intake = self.desk.receive(peer, data, now)
        self.out.frames(intake.out)
        if intake.joined is not None:
            # the run's setup (a whole plan) once a second at most, however often a peer says hello
            if now - self._setups.get(peer, float("-inf")) >= _SETUP_EVERY:
                self._setups[peer] = now
                self.out.frames(self.desk.to(intake.joined, self.run.setup()))
                pending = self.run.replanner.pending
                if self.run.replanner.proposal_id is not None and pending is not None:
                    self.out.frames(self.desk.to(intake.joined, proposal(pending, self.fleet, self.run.loaded.name)))
                rerouted = self.run.rerouting.pending
                if rerouted is not None:
                    self.out.frames(self.desk.to(intake.joined, reroute_proposal(
                        rerouted[0], rerouted[1], self.fleet, self.run.loaded.name)))
            self._state_to(now, peer)
        if intake.request is not None:
            console = self.desk.consoles.get(peer)
            name = console.name if console is not None else "?"
            action = intake.request.action
            self.desk.acting = peer  # what the request changes is this console's own doing
            try:
                ok, reason = operator.apply(self.run, action, intake.args, now)
            finally:
                self.desk.acting = None
            if ok or self._refused.first(peer, name, now):  # refusals: the first a minute, then counted
                self.out.record("operator", console=name, action=action, args=intake.args, ok=ok, reason=reason)
            asked = request_words(action, intake.args)
            robot = intake.args.get("robot") if action in ("enable", "disable", "source") else None
            if ok:
                self.out.tell("operator", robot, "{}: {}{}".format(name, asked, " (" + reason + ")" if reason else ""))
            elif self._refusals.allow(name, now):
                self.out.say("[{:7.1f} s] {}: {} refused: {}".format(now, name, asked, reason))
            self.out.frames(self.desk.answer(peer, intake.request, ok, reason))
            if ok:  # what changed goes out to every console as soon as its rate allows
                self.news = True
                self.publish(now)
        if intake.refusal is None:
            return None
        return "console {}{!r}: {}".format(intake.refusal.name + " " if intake.refusal.name else "",
                                           peer[:16], intake.refusal.reason)

    def request(self, action: str, args: Dict, now: float) -> operator.Answer:
        """An operator request from the manager itself (--start), carried out like a console's."""
        self._at(now)
        return operator.apply(self.run, action, args, now)

    # ---- time -------------------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """What is due whatever arrives: a replan at its safe point, the end of the run,
        heartbeats to consoles."""
        self._at(now)
        run = self.run
        if run.resuming is not None and not run.not_ready():
            self.resumed(now)
        if run.replanner.state == SAFE_POINT and run.driver.moving:
            blocked = operator.behind_out(run)
            if blocked:  # a leader went out while the robots finished their moves: no safe point comes
                run.drop_replan()
                run.replan_ended("replan given up: " + blocked)
                run.say("replan given up: " + blocked)
                self.out.tell("plan", None, "replan given up: " + blocked)
        if run.replanner.state != SAFE_POINT:
            self._replan_line = None
        else:
            self._say_replan_waits()
        if run.replanner.state == SAFE_POINT and not run.driver.moving and all(
                r.pose_settled() for r in self.fleet.robots if r.link_up):
            # a pose taken before a robot's last reply (late) may show it short of where it
            # stopped: walls and cells are judged on the next one, taken after
            halfway = run.halfway_cells()  # (nobody finishes a move into one: wide carrying seed 673)
            here = stood_on(run.grid, self.fleet.robots, run.positions(), self._short_of(run.walls | halfway))
            out, on = self._replanned_from(here, run.walls | halfway)
            current = [on.get(a, c) for a, c in enumerate(here)]
            grid = _without(walled(run.grid, self.fleet.robots, here, set(on), halfway), self._walls_but(current))
            shared = self._sharing(current) or self._sharing_first(here, on, current)
            if shared:  # no plan has two robots on a cell: say what would let the replan plan them
                run.drop_replan()
                run.replan_ended("replan given up: " + shared)
                run.say("replan given up: " + shared)
                self.out.tell("plan", None, "replan given up: " + shared)
            else:
                self.out.add(run.replanner.job(grid, current, list(run.loaded.goals), out,
                                               {a: here[a] for a in on}, run.progress()))
                run.replan_says("replanning: planning from where the robots stand")
        said = operator.way_after(run, now)
        if said:
            self.out.tell("run", None, said)
        self._carried_tick(now)
        self._reroute_tick(now)
        self._ways_home_tick(now)
        self._say_if_stuck(now)
        if run.phase.phase == RUNNING:
            run.driver.tick(now)
        if (run.phase.phase == RUNNING or run.phase.stepped) and run.all_arrived() and not run.driver.moving:
            if run.purpose == PLAN:
                self.out.tell("run", None, "run done: {}".format("; ".join(self.summary().lines()[:2])))
            run.arrived(now)
            self.news = True  # consoles must see the end (the loop waits for it: `news`)
            self.publish(now)
        for held in self._refused.due(now):
            self.out.record("refused", console=held.console, requests=held.requests, seconds=held.seconds)
        if len(self._setups) > 64:
            self._setups = {p: t for p, t in self._setups.items() if now - t < _SETUP_EVERY}
        for line in self._refusals.counts(now):
            self.out.say("[{:7.1f} s] {}".format(now, line))
        self.out.frames(self.desk.tick(now))

    def _short_of(self, walls: Set[Coord]) -> Set[int]:
        """The robots that stopped within `AT_CELL` of the cell they were driving into but farther
        than `MADE_IT` from its centre, and can finish that move (`going_on`): a replan plans them
        into it, not from it (live session 900: robot 2, halted 0.27 cells short of its goal and
        taken for standing on it, had no move left, counted arrived 19 cm off its marker)."""
        robots = self.fleet.robots
        _, on = self._replanned_from(self.run.positions(), walls)
        return {a for a, far in on.items()
                if robots[a].pose is not None
                and MADE_IT < math.hypot(robots[a].pose.x - far[0], robots[a].pose.y - far[1]) <= AT_CELL}

    def _replanned_from(self, here: Sequence[Coord], walls: Set[Coord]) -> Tuple[Set[int], Dict[int, Coord]]:
        """Who a replan at its safe point plans around (out), and who finishes the move it is
        half through first (`going_on`: agent -> the cell it is planned from). A robot the
        operator halted takes part, as Start would take it back: from the cell it stands on, or
        from the one it was halted on the way into. Planned around instead, nobody halted moved
        in the new plan ("replanned 0 robots") and each was left away from its goal. One halted
        between two cells that cannot finish its move there (the cell is another's), or halted in
        a move with no pose to say where, or whose link is down, stays out: planned from its cell,
        it would drive across the corner. So does any other robot standing between two cells that
        cannot finish its move, nearer the cell it leans into than the safe distance (big session
        3071: robot 2, halted in its move and taken back by Start into a plan with no move for it,
        was planned from its cell; robot 10, half into that cell, was found "moved by hand" as soon
        as the plan took robot 2 away)."""
        state = self.run.engine.run
        robots = self.fleet.robots
        halted = {r.agent for r in robots if r.hold == HALTED and state.out[r.agent] not in (None, "disabled")}
        out = {a for a, why in enumerate(state.out) if why is not None} - halted
        on = going_on(self.run.grid, robots, here, out, walls)
        out |= {a for a in halted if a not in on and (not robots[a].link_up or leans_into(robots[a], here[a]) is not None
                                                   or (robots[a].pose is None and state.halfway[a]))}
        safe = self.run.settings.size.safe_cells
        for robot in robots:  # (not one the safe distance or more from the cell it leans into: a
            # follower stopped at its hold point, whom nobody in that cell comes nearer, big carrying 1430)
            far = leans_into(robot, here[robot.agent]) if robot.agent not in on else None
            if far is not None and not clear_of((robot.pose.x, robot.pose.y), far, safe):
                out.add(robot.agent)
        return out, on

    def _say_replan_waits(self) -> None:
        """The line of a replan waiting at its safe point for a robot whose link is down in the
        middle of a move (it may be driving on, or have lost its power: it finishes that move
        once it is back), or for Vicon to see a robot again (the pose the run uses is older than
        the robot's last move), says so, and what the operator can do; back to what it said once
        it waits for none (a robot settled is not lost). (A live Vicon session, 1023: 33 s of
        "waiting for every robot to finish its move", the robots long standing; a robot's power
        cut, in-memory `--faults` 155: the same for 20 s, robot 5's link down.)"""
        run = self.run
        if run.replan_said is None or run.phase.reason != run.replan_said:
            return  # the replan's line is no longer up: somebody said something else since
        robots = self.fleet.robots
        cut = run.cut_off()
        lost = [r.id for r in robots if r.link_up and r.source == VICON and r.vicon_lost and not r.pose_settled()
                ] if not any(r.link_up and r.flight is not None for r in robots) else []
        if cut or lost:
            if self._replan_line is None:
                self._replan_line = run.phase.reason
            run.say("replanning: " + "; ".join(([cut_off_words(cut)] if cut else []) +
                                               ([lost_words(lost)] if lost else [])))
        elif self._replan_line is not None:
            run.say(self._replan_line)
            self._replan_line = None
        run.replan_said = run.phase.reason

    def _walls_but(self, current: Sequence[Coord]) -> Set[Coord]:
        """The run's walls a replan keeps off, but the cells robots start on: a robot's own cell
        stays its start, a wall around where it stood before or not (one put on a cell of the
        walls a restart raised around it between cells: wide carrying seed 673, whose replan was
        refused as invalid)."""
        return self.run.walls - {tuple(c) for c in current}  # type: ignore[misc]

    def _carried_tick(self, now: float) -> None:
        """Robots moved by hand while the run is under way (`carried`), judged ten times a second:
        the run halts, drives that would pass near them stop short, and the operator is told once
        per robot found."""
        run = self.run
        if now < self._carried_due:
            return
        self._carried_due = now + CARRIED_EVERY
        found = carried(run) if run.phase.phase in UNDER_WAY else []
        ids = {c.robot.id for c in found}
        new, self._carried_told = ids - self._carried_told, ids
        if not found:
            return
        size = self.settings.size
        stopped = halt_near(run, found, 1.0 if size.cell_sized else size.safe_cells)
        words = carried_words(run, found)
        halted = run.phase.phase == RUNNING
        if halted:
            if not run.engine.paused:
                run.driver.handle(Pause(now), now)
            run.move("halt", "halted: " + words)
        for rid in sorted(new):  # the presentation's ticker
            run.out.desk.bump("robot {} moved by hand{}".format(rid, ": the run halts" if halted else ""), rid)
        if new or stopped:
            short = "" if not stopped else "; robot{} {} stopped short".format(
                "s" if len(stopped) > 1 else "", ", ".join(str(r.id) for r in stopped))
            self.out.tell("run", None, ("halted: " if halted else "") + words + short)

    def _ways_home_tick(self, now: float) -> None:
        """A robot a replan left away from its goal, enabled again while no way home around the
        others was free (a disabled robot in it, its pose not settled yet), is tried again once a
        plan step while the run runs: it drives home once a way opens, and nobody has to replan."""
        run = self.run
        if (run.phase.phase != RUNNING or run.purpose != PLAN or not run.stranded or now < self._home_due
                or run.rerouting.job is not None or run.engine.frozen):
            return
        self._home_due = now + run.engine.run.clock.step_time
        said = operator.ways_home(run, now)
        if said:
            self.out.tell("plan", None, said)

    def _sharing(self, current: List[Coord]) -> str:
        """Why a replan cannot plan from `current` ("" if it can): two robots would start on one cell.
        A robot halted in the middle of its move, behind a robot that stopped in the cell it enters,
        with a follower already in the cell it leaves, stands on neither (found by random operator
        sessions, `--dying`, seed 1496)."""
        run = self.run
        seen: Dict[Coord, Robot] = {}
        for robot, cell in zip(self.fleet, current):
            other = seen.setdefault(tuple(cell), robot)
            if other is robot:
                continue
            between = next((r for r in (robot, other) if r.pose is not None
                            and math.hypot(r.pose.x - cell[0], r.pose.y - cell[1]) > AT_CELL), robot)
            pose = between.pose
            return ("robots {} and {} would both start on {}: robot {} stands between two cells{}; let it "
                    "finish its move (Start, and enable the robot ahead of it if that one is out), or put it "
                    "on a free cell").format(other.id, robot.id, run.loaded.show(cell), between.id,
                                             "" if pose is None else " at {}".format(run.where(pose.x, pose.y)))
        return ""

    def _sharing_first(self, here: Sequence[Coord], on: Dict[int, Coord], current: List[Coord]) -> str:
        """`_sharing` for the plan's first step, where the robots going on (`on`) still stand in
        their own cells (big session 840: a follower had completed its move into the cell its
        leader, halted, was leaving; both started there, and the plan, accepted, raised building
        its engine)."""
        return self._sharing([here[a] if a in on else c for a, c in enumerate(current)]) if on else ""

    def resumed(self, now: float) -> None:
        """A resumed run's robots have all answered: those standing where the run left them go
        on; the others are named and replanned from where they stand (those between cells are
        held and planned around), and drives that would pass close to them stop short."""
        run = self.run
        folder = run.resuming.point.folder.name if run.resuming is not None else "?"
        recorded = run.resuming is not None and run.resuming.point.walls is not None
        run.resuming = None
        run.driver.releasing = True
        held = run.positions()
        holding = {tuple(c): a for a, c in enumerate(held)}
        # off the plan by the live check's rule too: a robot halted in a move, taken back (Start after
        # Halt) and not sent it again stands on that move, as it would for the dead manager (big
        # session 12: one a fifth of a cell short of its next cell was "replanned from" that cell, the
        # replan given up, and the run went on with the cell it never stood on as its place)
        off = [o for o in off_plan(self.fleet, held, run.engine.run.out, run.grid)
               if not where_the_run_has_it(run, o.robot, o.pose, o.expected, holding)]
        for robot in self.fleet:
            if robot.hold == RESUMING:
                robot.hold = None
        for o in off:  # first where each robot found on a cell stands: no wall goes up on it
            if o.cell is not None:
                run.standing[o.robot.agent] = o.cell
        keep = set(run.positions())
        # the plan's walls are in its record (`Run._resume` keeps to them); a folder from before
        # they were recorded: inferred from where robots out stand
        leans = set() if recorded else self._out_leaning_into(keep)
        if leans:
            run.rerouting.keep_to(_without(run.grid, run.walls | leans))
        if not off:
            run.say("resumed from {}: every robot where the run left it; Start drives on".format(folder))
            self.out.tell("run", None, "resumed from {}: every robot stands where the run left it".format(folder))
            for robot in self.fleet:
                run.driver.release_followers(robot)
                run.driver.pump(robot, now)
            return
        size = self.settings.size
        reach = 1.0 if size.cell_sized else size.safe_cells
        told = []
        for o in off:
            where = "robot {} stands at {}, where the run has it at {}".format(
                o.robot.id, run.where(*o.pose), run.loaded.show(o.expected))
            if o.cell is not None:
                told.append("{}: replanned from {}".format(where, run.loaded.show(o.cell)))
            else:
                run.walls |= walls_around(o.pose, reach + 0.5, run.grid, keep)
                run.driver.hold_out(o.robot, "stands between cells after the manager restarted: planned "
                                    "around; put it on a cell and enable it", now)
                told.append("{}: between cells, held and planned around".format(where))
        if run.walls:  # reroutes keep off them too, whether the replan is accepted or not
            run.rerouting.keep_to(_without(run.rerouting.maps.grid, run.walls | leans))
        near = [r for r in self.fleet if r.flight is not None and r.flight.kind == "drive"
                and r.pose is not None and r not in [o.robot for o in off]
                and any(passes_near((r.pose.x, r.pose.y), (r.flight.target[0], r.flight.target[1]), o.pose, reach)
                        for o in off)]
        if near:
            run.driver.halt(near)
            told.append("robot{} {} stopped short of them".format("s" if len(near) > 1 else "",
                                                                  ", ".join(str(r.id) for r in near)))
        for robot in self.fleet:
            run.driver.release_followers(robot)
            run.driver.pump(robot, now)
        run.replanner.request(False, None, None)
        run.ask_replan("resumed from {}: replanning robots off the plan".format(folder))
        self.out.desk.bump("replan requested")
        self.out.tell("plan", None, "resumed from {}: {}; a replan from where they stand follows".format(
            folder, "; ".join(told)))

    def _out_leaning_into(self, keep: Set[Coord]) -> Set[Coord]:
        """For a run resumed from a folder whose records do not name the plan's walls (written before
        `Run.kept_walls`; since, they are read from the records, and a robot out standing in another
        cell was moved there: carrying session 1860, a robot carried off its goal while disabled,
        taken by this inference for one left leaning into that cell, and counted arrived once
        enabled): the cells that robots out, standing between two cells with no move
        left in the plan (a bumper stopped them in a move, a replan planned around them and left
        them there), lean into, but cells robots stand on (`keep`). The plan holds the cell each
        has, not that one, which the manager that made the plan walled off (`replanning.walled`)
        for its reroutes, and whose walls went with it: this manager's reroutes and ways home keep
        off them too (`Rerouting.keep_to`; dying seeds 92 and 169: a way home through one). Not
        the run's `walls`: a replan walls them off itself, but for a robot enabled since, which
        finishes its move into it (`replanning.going_on`; wide seed 2502: kept from it, it was
        planned from its other cell and drove across the corner). A robot out with a move left,
        into that cell, has it held by the engine (`reroute_plan._hold_targets`)."""
        run = self.run
        held = run.positions()
        state = run.engine.run
        # (a robot's cell stays free for it, but one it has a move out of: a replan walled it off
        # for the one leaning into it, which the robot leaves: `replanning.walled`, narrow session 594)
        leaving = {tuple(held[a]) for a in range(state.num_agents) if not state.finished_agent(a)}
        leans: Set[Coord] = set()
        for robot in self.fleet:
            a = robot.agent
            far = leans_into(robot, held[a]) if state.out[a] is not None and state.finished_agent(a) else None
            if far is not None and run.grid.in_bounds(far) and (far not in keep or far in leaving):
                leans.add(far)
        return leans

    def plan_ready(self, job_id: int, result: Optional[ReplanResult], error: Optional[str],
                   now: float) -> None:
        self._at(now)
        if job_id == self.run.to_starts_job:
            self.run.to_starts_ready(result, error, now)
            self.news = True  # the run changed under the consoles: every one sees it at once
            self._state_to(now, None, at_once=True)
            self.publish(now)
            return
        replanner = self.run.replanner
        message = replanner.finished(job_id, result, error)
        if message is None:
            return
        if replanner.pending is None:  # failed, or found no plan
            self.run.drop_replan()
            self.run.replan_ended(message)
        self.out.tell("plan", None, message)
        self.out.desk.bump(message if replanner.pending is None else
                           "replan {} proposed".format(replanner.pending.id))
        if replanner.pending is not None:
            self.run.replan_says("replan {} proposed ({}): accept or reject it".format(replanner.pending.id,
                                                                                      replanner.pending.result.message))
            self.out.broadcast(proposal(replanner.pending, self.fleet, self.run.loaded.name))
            if self.settings.accept:  # scripts: --accept takes every proposal
                ok, reason = operator.apply(self.run, "accept", {"proposal": replanner.pending.id}, now)
                self.out.record("operator", console="--accept", action="accept", args={}, ok=ok, reason=reason)
                self.out.tell("operator", None, "--accept: accept: {}".format(reason))
        elif replanner.was_running and self.run.phase.refusal("resume") is None:
            operator.resume(self.run, now, "resume")

    def load_ready(self, job_id: int, loaded: Optional[LoadedPlan], error: Optional[str], now: float) -> None:
        """The outcome of a LoadJob: the plan of an instance a console asked to load (loaded now if
        the run still may), or why it could not be solved; every console is told."""
        self._at(now)
        if self.run.loading is None or self.run.loading[0] != job_id:
            return
        _, text = operator.solved(self.run, loaded, error, now)  # a plan loaded opens its own run folder
        self.out.tell("plan", None, text)
        self.out.desk.bump(text)
        self.news = True
        self._state_to(now, None, at_once=True)
        self.publish(now)

    # ---- rerouting (`rerouting`) ----------------------------------------------------------

    def _reroute_tick(self, now: float) -> None:
        """A look for a reroute when one is due (auto mode: no new move is sent while it is in
        flight, `Rerouting.freezes`); a proposal dropped when it went stale."""
        run, rerouting = self.run, self.run.rerouting
        if run.engine.frozen and not rerouting.freezes(run.engine, now):
            self._thaw(now)  # the look was given up, or takes too long to wait for
        pending = rerouting.pending
        if pending is not None:
            moved = moved_since(run.engine, pending[1])
            if moved:
                self._drop_proposal("reroute {} dropped: {} since it was proposed".format(
                    pending[0], moved_words(moved, self.fleet.ids)))
        if (run.phase.phase == RUNNING and run.purpose == PLAN and not run.replanner.open
                and run.resuming is None and not self._reroute_held_back()
                and rerouting.due(run.engine, now)):
            self.out.add(rerouting.ask(run.engine, now))
            if rerouting.freezes(run.engine, now):
                run.driver.handle(Freeze(now), now)

    def _reroute_held_back(self) -> bool:
        """Rerouting waits while the plan being run goes through walls a takeover raised for the
        replan it asked for (`Run.walls`: a look would keep robots on those paths and be refused,
        big carrying session 786); rerouting every robot also while a robot the plan left stranded
        stands between two cells (`Run.stranded_between`): it would plan that robot from its cell."""
        run = self.run
        return bool(run.walls) or (run.rerouting.rule.scope == "all" and bool(run.stranded_between()))

    def _thaw(self, now: float) -> None:
        if self.run.engine.frozen:
            self.run.driver.handle(Thaw(now), now)

    def _drop_proposal(self, why: str) -> None:
        self.run.rerouting.resolved()
        self.run.rerouting.dropped += 1
        self.out.record("reroute_dropped", reason=why)
        self.out.tell(REROUTE, None, why)
        self.out.desk.bump(why)
        self.news = True

    def reroute_ready(self, job_id: int, found: Optional[Reroute], error: Optional[str], now: float) -> None:
        """The outcome of a RerouteJob: a reroute that pays (None: none does), or why the look
        raised. Auto mode hands over at once; propose mode proposes it."""
        self._at(now)
        run, rerouting = self.run, self.run.rerouting
        if not rerouting.finished(job_id, run.engine):
            return  # a look given up (mode off) or of a plan no longer run
        self._reroute_found(found, error, now)
        self._thaw(now)  # the run's own engine, if nothing was handed over

    def _reroute_found(self, found: Optional[Reroute], error: Optional[str], now: float) -> None:
        run, rerouting = self.run, self.run.rerouting
        if error is not None:
            self.out.record("reroute_dropped", reason="the look failed: " + error)
            self.out.tell(REROUTE, None, "reroute look failed: {}".format(error))
            return
        if (found is None or rerouting.mode == "off" or run.phase.phase != RUNNING or run.engine.paused
                or run.replanner.open):
            return
        rerouting.found += 1
        if rerouting.mode == "auto":
            self.hand_over(found, now)
            return
        pid = rerouting.propose(found)
        text = found.describe(lambda a: self.fleet.ids[a])
        self.out.record("reroute_proposed", proposal=pid, robots=[self.fleet.ids[a] for a in found.agents],
                        text=text)
        self.out.tell(REROUTE, None, "reroute {} proposed: {}".format(pid, text))
        self.out.desk.bump("reroute {} proposed".format(pid))
        self.out.broadcast(reroute_proposal(pid, found, self.fleet, run.loaded.name))
        self.news = True

    def hand_over(self, found: Reroute, now: float) -> None:
        """Run `found`'s plan from now (auto mode), or drop it with one line if it no longer fits."""
        if self.run.reroute(found, now) is None:
            self.news = True
            self.publish(now)

    def waits(self) -> Dict[int, Waiting]:
        return robot_waits(self.run.engine, self.fleet, self.run.driver.following)

    def state(self, now: float, waits: Dict[int, Waiting]):
        self._states += 1
        run = self.run
        allowed, why_not = self._allowed_now(now)
        return build_state(self._states, self.desk.version, now, run.clock(now), run.plan_steps(now),
                           run.engine, self.fleet, run.phase, run.plan_id, run.replanner, self.min_distance,
                           self.collisions, waits, run.driver.following, run.purpose, allowed, why_not,
                           run.rerouting.mode, run.rerouting.proposal_id, run.plan_start, run.rerouting.rule.scope,
                           run.settings.trim)

    def _allowed_now(self, now: float) -> Tuple[Tuple[str, ...], Dict[str, str]]:
        """What the manager would carry out now, and why not the rest (one line each): again when
        anything decisive changed, else at most every ALLOWED_EVERY seconds (where 300 standing
        robots are costs milliseconds)."""
        run = self.run
        key = (self.desk.version, run.phase.phase, run.purpose, run.to_starts_job, run.replanner.state,
               run.driver.moving, run.rerouting.proposal_id)
        last = self._allowed
        if last is None or last[0] != key or now - last[1] >= ALLOWED_EVERY:
            refused = operator.refusals(run, now)
            self._allowed = (key, now, tuple(a for a in RUN_ACTIONS if a not in refused),
                             {a: one_line(why, WHY_NOT_CHARS) for a, why in refused.items()})
        return self._allowed[2], self._allowed[3]

    def publish(self, now: float) -> bool:
        """Who waits for whom to the run log when it changed; the State to the consoles not sent
        one within their rate (`state_max_rate`). True if a State went out."""
        self._at(now)
        waits = self.waits()
        if waits != self._last_waits:
            self._last_waits = waits
            self.out.record("waits", w=[[rid, list(w.on), None if w.cell is None else list(w.cell), w.reason]
                                        for rid, w in sorted(waits.items())])
        return self._state_to(now, None, waits)

    def _state_to(self, now: float, peer: Optional[bytes], waits: Optional[Dict[int, Waiting]] = None,
                  at_once: bool = False) -> bool:
        """A State to `peer` (None: every console) if its rate allows (`at_once`: whatever it
        allows); True if one went out."""
        if not self.desk.consoles:
            self.news = False  # nobody to tell
            return False
        interval = 0.0 if at_once else 1.0 / self.settings.state_max_rate
        if not self.desk.state_due(now, interval, peer):
            return False
        self.news = False
        state = self.state(now, self.waits() if waits is None else waits)
        self.out.frames(self.desk.states(state, now, interval, peer))
        return True

    def log_poses(self, now: float) -> None:
        """Every robot's pose to the run log (the summary finds the closest pair in it)."""
        self._at(now)
        if self.vicon_watch is not None:
            self.vicon_watch.check(now)
        rows = []
        for robot in self.fleet:
            seen = robot.seen()
            if seen is not None:
                p = seen.pose
                rows.append([robot.id, round(p.x, 3), round(p.y, 3), round(p.theta, 3), robot.source,
                             round(now - seen.at, 3)])
        if rows:
            self.out.record("poses", p=rows)

    # ---- the run's outcome ------------------------------------------------------------------

    def summary(self) -> RunSummary:
        return self.out.summary.summary()

    @property
    def min_distance(self) -> Optional[float]:
        """The smallest distance between two robots in the run so far (cells)."""
        found = self.out.summary.min_distance
        return None if found is None else round(found, 3)

    @property
    def collisions(self) -> int:
        return self.out.summary.collisions

    def _say_if_stuck(self, now: float) -> None:
        """A running run that nothing can move on without an operator says so, and what to do, in
        its line (`cannot_go_on`), twice a second; the line clears once something moves again. (It
        said nothing: a live session, robots a replan left between two cells, enabled after a
        restart and promised a way home at Start that could not come, the run "running" with
        nobody moving; only an unattended run gave up and said why.)"""
        if now < self._stuck_due:
            return
        self._stuck_due = now + 0.5
        run = self.run
        reason = run.phase.reason
        why = self.cannot_go_on(now)
        if why is not None:  # (only while running: `Run.stuck`)
            if not reason.startswith(_CANNOT_GO_ON):
                self._said_before = reason  # ("" or the way to the starts' line): back once it moves
            run.say(why)
        elif reason.startswith(_CANNOT_GO_ON) and run.phase.phase == RUNNING:
            run.say(self._said_before)

    def cannot_go_on(self, now: float) -> Optional[str]:
        """Why an unattended run (--until-done) cannot finish, once that has lasted a while."""
        run = self.run
        if not run.stuck():
            self._stuck_since = None
            return None
        if self._stuck_since is None:
            self._stuck_since = now
        if now - self._stuck_since < _STALL_GRACE:
            return None
        parts = []
        blocking = sorted(run.engine.blocked_by().items())
        for agent, waiting in blocking:
            robot = self.fleet[agent]
            why = run.engine.run.out[agent]
            parts.append("robot {} is {}{}{}".format(
                robot.id, "held by a fault" if why == "failed" else "disabled",
                " ({})".format(robot.hold_reason) if robot.hold_reason else "",
                "; {} for it".format(_robots_wait([self.fleet[a].id for a in waiting])) if waiting else ""))
        if blocking:  # what the operator can do about them
            them = "it" if len(blocking) == 1 else "them"
            fault = any(run.engine.run.out[agent] == "failed" for agent, _ in blocking)
            parts.append("enable {0}{1}, or replan around {0}".format(them, " once clear" if fault else ""))
        if run.stranded_words():
            parts.append(run.stranded_words())
        return _CANNOT_GO_ON + ("; ".join(parts) or "nothing can move")

    def stop_all(self, now: float) -> None:
        """Tell every connected robot to stop now."""
        self._at(now)
        for robot in self.fleet:
            if robot.link_up:
                self.out.send(robot.id, Stop(robot.take_id()))

    def close(self, reason: str, now: float) -> None:
        """The manager stops: the run log's last record, and every console told."""
        self._at(now)
        self.out.summary.feed({"k": "end", "t": round(now, 4), "reason": reason})  # the summary says why
        summary = self.summary()
        self.out.record("end", reason=reason, arrived=len(summary.arrived), robots=summary.robots,
                        summary=summary.as_dict())
        self.out.broadcast(Notice(self.out.notices + 1, round(now, 3), "run", None, "manager stopping: " + reason))
        # consoles learn at once that this manager is gone (not after 3.5 s of silence)
        self.out.broadcast(Bye("manager stopping: " + reason))


def _without(grid: Grid, cells: Iterable[Tuple[int, int]]) -> Grid:
    """`grid` with `cells` blocked."""
    cells = list(cells)
    if not cells:
        return grid
    free = grid.free.copy()
    for x, y in cells:
        free[y, x] = False
    return Grid(free, name=grid.name)


def request_words(action: str, args: Dict) -> str:
    """A request as the manager's log and the consoles' event lists say it: "disable robot 3"."""
    if action in ("enable", "disable"):
        return "{} robot {}".format(action, args.get("robot"))
    if action == "source":
        return "position source {} for {}".format(args.get("source"), "every robot" if args.get("robot") is None
                                                  else "robot {}".format(args["robot"]))
    if action == "strategy":
        return "strategy {}{}".format(args.get("name"), "" if args.get("lookahead") is None
                                      else " (lookahead {})".format(args["lookahead"]))
    if action == "load":
        return "load {}".format(args.get("path") or args.get("name"))
    if action in ("accept", "reject"):  # a replan's or a reroute's: proposals share one numbering
        return "{} proposal {}".format(action, args.get("proposal"))
    if action == "to_starts":
        return "go to starts"
    if action == "reroute":  # "reroute auto", "reroute scope all", "reroute auto, scope all", "reroute trim on"
        words = ([str(args["mode"])] if args.get("mode") is not None else []) + (
            ["scope {}".format(args["scope"])] if args.get("scope") is not None else []) + (
            ["trim {}".format("on" if args["trim"] else "off")] if args.get("trim") is not None else [])
        return "reroute {}".format(", ".join(words) or "(nothing)")
    return action


class _Burst:
    """Refused requests said on the terminal: `burst` a console per `window` seconds, then a
    count, so that one console repeating a refused request cannot flood the log."""

    def __init__(self, burst: int = 3, window: float = 60.0) -> None:
        self.burst, self.window = burst, window
        self._seen: Dict[str, List[float]] = {}  # console -> [window start, said, held back]

    def allow(self, name: str, now: float) -> bool:
        entry = self._seen.get(name)
        if entry is None or now - entry[0] >= self.window:
            entry = self._seen[name] = [now, 0, 0]
        if entry[1] < self.burst:
            entry[1] += 1
            return True
        entry[2] += 1
        return False

    def counts(self, now: float) -> List[str]:
        """Lines for the windows that have passed with refusals held back."""
        lines = []
        for name, (start, _, held) in list(self._seen.items()):
            if now - start >= self.window:
                del self._seen[name]
                if held:
                    lines.append("{}: {:,} more refused requests in the last {:g} s".format(
                        name, int(held), self.window))
        return lines


def _robots_wait(ids: List[int]) -> str:
    if len(ids) == 1:
        return "robot {} waits".format(ids[0])
    return "robots {} wait".format(", ".join(map(str, ids)))
