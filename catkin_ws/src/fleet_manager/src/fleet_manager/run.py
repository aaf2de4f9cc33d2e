"""One run: a plan, its engine and driver, the run's phase, and how plans change under it.

`Run` is what the operator's requests act on (`operator.py`) and what the
core (`core.py`) feeds robot news to. It owns the plan being run (a new one
after a `load`, which starts a new run in a new run folder, or an accepted
replan, which continues the same run with plan-2.txt, plan-3.txt ...), the
execution engine for it, the driver that turns the engine's decisions into
commands, the phase (`run_phase`) and the replanner's state. Everything it
does goes out through the `Outbox` as values.

The plan the operator chose is `target`; what runs now is `loaded`, which is
the target, or, while the robots drive to the target's starts (`to_starts`,
and `reset` when they are elsewhere), a plan from the cells they stand on to
those starts: a run of its own (`purpose` "to-starts", its own run folder),
planned off the loop (a `PlanJob`) and executed by the same engine and driver
as any plan, so followers, safety and the run log apply to it too. When every
robot is on its start the target is loaded again, waiting for Start.

Positions and cells in messages are the plan file's own coordinates
(`where`), as everything a person reads about a plan. A run may also be resumed from
the folder of a manager that died (`resume.py`): it goes on there.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence, Set, Tuple

from fleet_common.control import RunSetup
from fleet_common.errors import FleetError
from fleet_common.execution import Disabled, Engine, EventError, Resume, RobotFailed
from fleet_common.execution.handover import HandoverError, hand_over
from fleet_common.execution.reorder import replay as replay_passes
from fleet_common.execution.reroute import Reroute, RerouteError, RerouteRule, way_home
from fleet_common.formats.solution import format_solution, make_solution
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan, trim_loaded
from fleet_common.planning.replan import ReplanResult
from fleet_common.runlog.records import FORMAT_VERSION, plan_file, size_fields
from fleet_common.robot_size import STOP_OVERSHOOT_M
from fleet_common.runlog.summary import SummaryBuilder

from .driver import AT_CELL, MADE_IT, Driver
from .following import Following
from .outbox import NewRunFolder, Outbox, PlanJob, REROUTE, ResumeRunFolder, WriteFile
from .replanning import Replanner, going_on, prefixed, walled
from .rerouting import Rerouting, moved_since, moved_words
from .resume import ResumePoint, Resuming
from .robot import FAULT, HALTED, RESUMING, VICON, Fleet, InFlight, Robot
from .run_phase import RUNNING, WAITING, RunPhase
from .settings import ManagerSettings
from .state_view import setup

__all__ = ["Run", "PLAN", "TO_STARTS", "NO_WAY_HOME"]

#: What a run is for: the plan the operator chose, or the way to its starts.
PLAN, TO_STARTS = "plan", "to-starts"
#: `Run.take_home`'s answer when the others leave no way (a robot out in it, one parked on it)
NO_WAY_HOME = "no way to its goal around the others now"
#: A robot given a way home drives on at once, followed and following as if it stood on its cell's
#: centre: it must, within its own arrival tolerance. `AT_CELL` (0.3 cells) would let one halted
#: in the middle of its move count, and its first drive would cut a corner (Vicon session 2283).
ON_CENTRE = MADE_IT


#: Seconds a plan's trim may take (`ManagerSettings.trim`) before the manager serves anyone, and
#: in its loop (a plan a console loads: robots and consoles wait meanwhile). A whole trim takes
#: 0.1 s at 70 robots and 0.6 s at 300 (bench/trim.py); the robots with the most moves to spare
#: go first, and those not reached in time keep their paths.
TRIM_AT_START_S = 30.0
TRIM_IN_LOOP_S = 2.0


def action_counts(plan: Plan) -> List[int]:
    return [int(k) for k in plan.move_counts()]


class Run:
    def __init__(self, loaded: LoadedPlan, fleet: Fleet, out: Outbox, settings: ManagerSettings,
                 resume: Optional[Tuple[ResumePoint, Plan]] = None, now: float = 0.0) -> None:
        self.fleet = fleet
        self.out = out
        self.settings = settings
        self.phase = RunPhase()
        #: ids of work done off the loop: replans, ways to the starts, reroutes, instances to load
        self.job_ids = iter(range(1, 2 ** 62))
        self.replanner = Replanner(settings.replan_limit, self.job_ids)
        self.rerouting = Rerouting(loaded.grid, settings.reroute, self.job_ids, settings.reroute_timed,
                                   RerouteRule(scope=settings.reroute_scope, per_turn=settings.quarter_turn_steps,
                                               trim=settings.trim))
        if settings.trim and resume is None:  # a run resumed goes on with the plan its folder recorded
            loaded = trim_loaded(loaded, TRIM_AT_START_S)[0]
        #: the map this fleet runs on: the first plan's (another plan must be on the same map)
        self.fleet_map = loaded.grid
        self.target = loaded
        self.loaded = loaded
        self.purpose = PLAN
        self.plan: Plan = loaded.plan
        self.plan_id = 1
        self.started_at: Optional[float] = None   # the run's Start
        self.plan_since: Optional[float] = None   # the current plan's step 0 (a replan's accept)
        #: the run's plan steps before the current plan's step 0 (what the run's earlier plans took)
        self.plan_start = 0.0
        self.ended_at: Optional[float] = None     # the run was done (the clock stops)
        self.to_starts_job: Optional[int] = None  # the way to the starts being planned
        self.to_starts_first: Dict[int, Coord] = {}  # robots it has finish a move first (`prefixed`)
        self.to_starts_grid: Optional[Grid] = None  # the map it is planned on, walls included
        self.loading: Optional[Tuple[int, str]] = None  # (job, name): an instance being solved to load
        #: a resumed run before its robots were checked (`resume.py`)
        self.resuming: Optional[Resuming] = None
        #: agent -> the cell a robot a restart found off the plan stands on, while the replan from
        #: there is open (`drop_replan`)
        self.standing: Dict[int, Coord] = {}
        #: the phase's reason an open replan put up ("replanning: ..."), to be replaced when the
        #: replan ends unless something else has said why since (`replan_ended`)
        self.replan_said: Optional[str] = None
        #: cells walled off for replanning around robots standing between cells
        self.walls: Set[Coord] = set()
        #: agents the current plan leaves away from their goals (out when a replan was made, they
        #: stand where they stopped; or a replan found no way for them): not arrived until a later
        #: plan takes them home
        self.stranded: Set[int] = set()
        #: a Reset or Go to starts that waits for the robots to stand: (action, when pressed)
        self.way_after: Optional[Tuple[str, float]] = None
        if resume is None:
            self.engine = self._engine(self.plan)
            self.driver = self._driver(self.engine)
            self._begin()
        else:
            self._resume(resume[0], resume[1], now)

    @property
    def grid(self) -> Grid:
        return self.loaded.grid

    # ---- the clock ------------------------------------------------------------------------

    def clock(self, now: float) -> float:
        """Seconds since the run started (0 before Start); it stops when the run is done."""
        if self.started_at is None:
            return 0.0
        return max(0.0, min(now, self.ended_at if self.ended_at is not None else now) - self.started_at)

    def plan_steps(self, now: float) -> float:
        """Plan steps since the current plan's step 0 (not capped: a late robot is behind it)."""
        if self.plan_since is None or self.settings.step_time <= 0:
            return 0.0
        end = self.ended_at if self.ended_at is not None else now
        return max(0.0, min(now, end) - self.plan_since) / self.settings.step_time

    def begin_clock(self, now: float) -> None:
        """The first Start (or Step) of the run."""
        self.started_at = self.plan_since = now
        self.ended_at = None
        self.plan_start = 0.0

    def next_plan_clock(self, now: float) -> None:
        """A new plan of the same run (an accepted replan, a reroute) has its step 0 now; the run's
        plan clock (`plan_start` + `plan_steps`) goes on from where the old plan's was."""
        if self.started_at is not None:
            self.plan_start += self.plan_steps(now)
            self.plan_since = now  # behind-ness is measured from the new plan's step 0

    # ---- the phase ------------------------------------------------------------------------

    def move(self, trigger: str, reason: str = "") -> None:
        """Move the phase (the caller checked `phase.refusal`); recorded and versioned."""
        if self.phase.move(trigger, reason):
            self._phase_changed()

    def _phase_changed(self) -> None:
        state, reason = self.phase.phase, self.phase.reason
        self.out.desk.bump("run {}{}".format(state, ": " + reason if reason else ""))
        self.out.record("state", run=state, reason=reason, purpose=self.purpose)

    def all_arrived(self) -> bool:
        """Every robot not disabled by an operator is at its goal (a robot held by a fault
        has not arrived: it still takes part, and waits for someone to clear the fault; nor has
        one the plan leaves away from its goal, `stranded`)."""
        run = self.engine.run
        return all(run.out[a] == "disabled" or (run.finished_agent(a) and a not in self.stranded)
                   for a in range(run.num_agents))

    def disabled(self) -> List[int]:
        return [r.id for r in self.fleet if self.engine.run.out[r.agent] == "disabled"]

    def stuck(self) -> bool:
        """Running, not everyone arrived, and nothing can happen without an operator (robots
        standing at their hold point behind a robot that is out count as not moving, and so do
        those behind a leader standing still with nothing sent: big session 3334, under the time
        step a follower held behind a robot that waited for the round of one that was out; the
        run ran on with nobody moving, and said nothing)."""
        if self.phase.phase != RUNNING or self.engine.paused or self.all_arrived() or self.replanner.busy:
            return False
        held = self.held_behind_standing(set(self.held_behind_out()))
        run = self.engine.run
        return not any(r.hold == "recover" or not r.link_up or (r.agent not in held and (
            r.flight is not None or run.dispatched[r.agent] > run.completed[r.agent])) for r in self.fleet)

    def held_behind_standing(self, held: Set[int]) -> Set[int]:
        """`held` (followers that cannot go on) and the followers behind a leader of them, or behind
        a leader standing still with nothing sent to it (`stuck`)."""
        run, following = self.engine.run, self.driver.following
        leaders = {agent: following.leader_of(agent) for agent in following.holds}
        while True:
            more = {agent for agent, leader in leaders.items() if agent not in held and leader is not None and (
                leader in held or (self.fleet[leader].flight is None and run.dispatched[leader] <= run.completed[leader]))}
            if not more:
                return held
            held |= more

    def _left_between(self, agent: int, plan: Plan) -> bool:
        """`plan` gives the robot of `agent` no move and it stands between two cells, off the
        cell the plan leaves it on (an out robot stopped half out of its goal, walled in): it
        has not arrived, even there, until a replan takes it onto the cell."""
        if (plan.positions[:, agent] != plan.positions[0, agent]).any():
            return False
        robot = self.fleet[agent]
        pose, cell = robot.pose, plan.positions[0, agent]
        return pose is not None and robot.pose_settled() and math.hypot(pose.x - cell[0], pose.y - cell[1]) > AT_CELL

    def stranded_words(self) -> str:
        """The robots the plan leaves away from their goals, and what the operator can do
        ("" if none)."""
        ids = sorted(self.fleet[a].id for a in self.stranded if self.engine.run.out[a] != "disabled")
        if not ids:
            return ""
        one = len(ids) == 1
        return "robot{} {} {} no way home in plan {}: replan (enable {} first if out), or disable {}".format(
            "" if one else "s", _ids(ids), "has" if one else "have", self.plan_id, "it" if one else "them",
            "it" if one else "them")

    def held_behind_out(self) -> Set[int]:
        """Followers whose leader is out, or is itself such a follower (a train behind a robot
        that is out): they wait at their hold points until it is back."""
        following, out = self.driver.following, self.engine.run.out
        leaders = {agent: following.leader_of(agent) for agent in following.holds}
        held = {agent for agent, leader in leaders.items() if leader is not None and out[leader] is not None}
        while True:
            more = {agent for agent, leader in leaders.items() if leader in held} - held
            if not more:
                return held
            held |= more

    def held_behind_taken_back(self) -> Dict[int, int]:
        """Followers at their hold points whose leader, taking part, has not been sent again the
        move they follow (a halt took it back, or it was out): follower agent -> leader agent. It
        is sent at Start; while the run is paused they wait (big carrying session 408: a replan asked
        for then waited for them to stand, and Start waited for the replan)."""
        following, run = self.driver.following, self.engine.run
        found: Dict[int, int] = {}
        for agent in following.holds:
            leader = following.leader_of(agent)
            queue = self.fleet[agent].queue
            d = queue[0] if queue else None
            if (leader is not None and run.out[leader] is None and d is not None and d.follows is not None
                    and d.follows[0] == leader and run.dispatched[leader] <= d.follows[1]):
                found[agent] = leader
        return found

    # ---- where the robots are, in words -------------------------------------------------------

    def where(self, x: float, y: float) -> str:
        """A position in the plan file's own coordinates: "(3, 4)" on a cell, "(3.4, 4.0)" off."""
        sx, sy = self.loaded.show((x, y))  # type: ignore[arg-type]
        if abs(sx - round(sx)) < 0.05 and abs(sy - round(sy)) < 0.05:
            return "({:d}, {:d})".format(int(round(sx)), int(round(sy)))
        return "({:.1f}, {:.1f})".format(sx, sy)

    def _map_words(self, grid: Grid) -> str:
        return "{} ({} x {})".format(grid.name or "its map", grid.width, grid.height)

    def not_ready(self) -> str:
        """Why the run cannot start or go on now ("" if it can): robots not connected or not on
        their starts; for a resumed run, robots not checked yet or a replan to answer."""
        if self.resuming is not None:
            return self.resuming.waiting_for(self.fleet, self.engine.run.out)
        if self.phase.phase != WAITING:
            return ""
        down = [r.id for r in self.fleet if not r.link_up]
        if down:
            why = {r.link_reason for r in self.fleet if not r.link_up and r.link_reason}
            return "not connected: robot{} {}{}".format(
                "s" if len(down) > 1 else "", _ids(down), " ({})".format("; ".join(sorted(why)[:2])) if why else "")
        off: List[str] = []
        settling: List[int] = []
        lost: List[int] = []  # Vicon's pose, the one the run uses, is older than the last move
        outside = 0
        for robot in self.fleet:
            if self.engine.run.out[robot.agent] is not None:
                continue
            start = self.engine.table.start(robot.agent)
            pose = robot.pose
            if pose is None:
                off.append("robot {} has not reported a pose".format(robot.id))
            elif not robot.pose_settled():  # taken during a move that has ended since: where it was
                (lost if robot.vicon_lost and robot.source == VICON else settling).append(robot.id)
            elif math.hypot(pose.x - start[0], pose.y - start[1]) > AT_CELL:
                cell = (int(round(pose.x)), int(round(pose.y)))
                if not self.grid.in_bounds(cell) or not self.grid.is_free(cell):
                    outside += 1
                off.append("robot {} is at {}, its start is {}".format(
                    robot.id, self.where(pose.x, pose.y), self.where(*start)))
        if not off and lost:
            return lost_words(lost)
        if not off and settling:  # (a way to the starts just driven: poses 0.1-0.3 s late)
            return "robot{} {} finished {} move a moment ago: waiting for {} pose".format(
                "s" if len(settling) > 1 else "", _ids(settling), "a" if len(settling) > 1 else "its",
                "their next" if len(settling) > 1 else "its next")
        if not off:
            return ""
        text = "not on their start cells (the plan file's coordinates): " + "; ".join(off[:5]) + (
            "; and {} more".format(len(off) - 5) if len(off) > 5 else "")
        if outside * 2 > len(self.fleet):  # most of the fleet is elsewhere: another map?
            return text + "; {} of them stand{} off the free cells of the plan's map {}: is the plan " \
                "for this fleet's map?".format(outside, "s" if outside == 1 else "", self._map_words(self.grid))
        return text + ("; Go to starts drives them there, or continue their last run (fleetctl manager "
                       "--resume)")

    def ask_replan(self, reason: str) -> None:
        """The phase for a replan asked for (the caller checked the refusal and requested it)."""
        self.move("replan", reason)
        self.replan_said = self.phase.reason

    def cut_off(self) -> List[int]:
        """The robots whose link is down in the middle of a move (it may drive on, or have lost its
        power): nobody knows where they stop until they are back."""
        return [r.id for r in self.fleet if not r.link_up and r.flight is not None]

    def replan_says(self, line: str) -> None:
        """The open replan's line moves on (planning, proposed), if it is still the one the replan
        put up: the line said "waiting for every robot to finish its move" beside the proposal."""
        if self.replan_said is not None and self.phase.reason == self.replan_said:
            self.say(line)
            self.replan_said = self.phase.reason

    def replan_ended(self, why: str) -> None:
        """The open replan is answered, given up or failed: `why` becomes the phase's reason if it
        still reads what the replan put up (after a takeover, "replanning robots off the plan"
        stayed under a rejected replan while Start refused to drive)."""
        if self.replan_said is not None and self.phase.reason == self.replan_said:
            self.say(why)
        self.replan_said = None

    def drop_replan(self) -> None:
        """The open replan ends without a new plan (rejected, given up, or it found none; the
        caller then says which, `replan_ended`): the robots a restart found off the plan are judged
        again against the engine's record (`carried`), no longer held where they stood for it.
        (Kept, they hid a robot carried elsewhere while no manager ran: the restart's replan
        rejected, Start drove the old plan around the cell the engine had it on, and a drive from
        where it stood was sent to it.)"""
        self.replanner.resolved()
        self.standing.clear()

    def progress(self) -> Tuple[Tuple[int, ...], ...]:
        """How far each robot has got in the plan: actions started, and completed."""
        run = self.engine.run
        return tuple(run.started), tuple(run.completed)

    def positions(self) -> List[Coord]:
        """The cell each robot holds for planning (a robot found off the plan: where it stands)."""
        return [self.standing.get(r.agent) or self.driver.position(r) for r in self.fleet]

    def standing_cells(self) -> Tuple[List[Coord], str]:
        """The cell each robot stands on, from its pose (a disabled robot: where it stands, or the
        cell it holds), and why not ("" when every robot taking part stands on a cell's centre,
        or between the nearest one and a free neighbour, a move the way to the starts finishes:
        `_going_on`). A pose taken before the robot's last reply (late) gives way to the cell
        the reply left it on."""
        cells: List[Coord] = []
        off: List[Tuple[Robot, bool, bool]] = []  # not on a centre: (robot, on the map, centred)
        problems: List[str] = []
        for robot in self.fleet:
            held = self.driver.position(robot)
            pose = robot.pose
            if pose is None or not robot.pose_settled():
                # a late pose, taken before the last reply: a completed move left the robot on
                # its cell, but one that stopped it (out) did not say where: wait for the next
                cells.append(held)
                if pose is None and self.engine.run.out[robot.agent] != "disabled":
                    problems.append("robot {} has not reported a pose".format(robot.id))
                elif pose is not None and self.engine.run.out[robot.agent] is not None:
                    problems.append(lost_words([robot.id]) if robot.vicon_lost and robot.source == VICON
                                    else "robot {} stopped a moment ago: no pose since yet".format(robot.id))
                continue
            cell = (int(round(pose.x)), int(round(pose.y)))
            centred = math.hypot(pose.x - cell[0], pose.y - cell[1]) <= AT_CELL
            on_map = self.grid.in_bounds(cell) and self.grid.is_free(cell)
            cells.append(cell if on_map else held)
            if not (centred and on_map):
                off.append((robot, on_map, centred))
        going = self._going_on(cells)
        for robot, on_map, centred in off:
            if self.engine.run.out[robot.agent] != "disabled" and robot.agent not in going:
                pose = robot.pose
                problems.append("robot {} stands at {}, {}".format(
                    robot.id, self.where(pose.x, pose.y), "not on a cell's centre" if on_map or not centred
                    else "off the free cells of {}".format(self._map_words(self.grid))))
        if not problems:
            seen: dict = {}
            for robot, cell in zip(self.fleet, cells):
                if cell in seen:
                    problems.append("robots {} and {} both stand on {}".format(
                        seen[cell], robot.id, self.where(*cell)))
                seen[cell] = robot.id
        return cells, "; ".join(problems[:5]) + ("; and {} more".format(len(problems) - 5)
                                                 if len(problems) > 5 else "")

    def on_target_starts(self) -> bool:
        """Every robot taking part stands on its start in the target plan."""
        for robot, start in zip(self.fleet, self.target.starts):
            if self.engine.run.out[robot.agent] == "disabled":
                continue
            pose = robot.pose
            if pose is None or math.hypot(pose.x - start[0], pose.y - start[1]) > AT_CELL:
                return False
        return True

    # ---- plans ----------------------------------------------------------------------------

    def _engine(self, plan: Plan) -> Engine:
        settings = {"lookahead": self.settings.lookahead} if self.settings.strategy == "adg" else {}
        return Engine(plan, self.settings.strategy, show=self.loaded.show,
                      follow=not self.settings.size.cell_sized, step_time=self.settings.step_time,
                      **settings)

    def _driver(self, engine: Engine) -> Driver:
        size = self.settings.size
        # held farther back by what a robot's own stop may overshoot (`robot_size.STOP_OVERSHOOT_M`)
        following = Following(engine, self.fleet,
                              None if size.cell_sized else size.safe_cells + STOP_OVERSHOOT_M / size.cell)
        driver = Driver(engine, self.fleet.robots, self.out, following, self.settings.preturn, self.loaded.show)
        engine.allow_take_back(driver.take_back)
        return driver

    def _begin(self) -> None:
        """The first records of a run (and of each run after a `load`)."""
        loaded = self.loaded
        self.out.add(NewRunFolder(loaded.text()))
        self.out.record("run", version=FORMAT_VERSION, started=None, source="manager", time_unit="s",
                        plan=plan_file(1), definitions=None, robots=self.fleet.ids,
                        strategy=self.settings.strategy, settings={"lookahead": self.settings.lookahead},
                        reroute=self.rerouting.mode, reroute_scope=self.rerouting.rule.scope,
                        trim=self.settings.trim,
                        plan_name=loaded.name, actions=action_counts(loaded.plan),
                        starts=[list(c) for c in loaded.starts], goals=[list(c) for c in loaded.goals],
                        map=self.grid.name, step_time=self.settings.step_time,
                        size=size_fields(self.settings.size), purpose=self.purpose,
                        # each robot's next command id: a manager resuming this folder speaks in
                        # the same epoch, and the robots remember the ids of the folders before
                        next_ids=[r.next_id for r in self.fleet], walls=self.kept_walls(),
                        **({"for_plan": self.target.name} if self.purpose == TO_STARTS else {}))

    def kept_walls(self) -> List[List[int]]:
        """The cells of the map the plan being run keeps off (`Rerouting.keep_to`: robots a replan or
        the way to the starts left between cells), for its record: a manager taking the run over
        keeps off them too, and knows that a robot standing in another cell was moved there."""
        kept = self.rerouting.maps.grid
        if kept is self.grid or kept.free.shape != self.grid.free.shape:
            return []
        ys, xs = (self.grid.free & ~kept.free).nonzero()  # (a reroute's record at 300 robots: no loop over cells)
        return [[int(x), int(y)] for x, y in zip(xs, ys)]

    def _resume(self, point: ResumePoint, plan: Plan, now: float) -> None:
        """Go on with the run of `point`'s folder (its manager died): the progress from its
        records, the commands no reply settled sent again with their ids, nothing new until
        the robots are checked (`core.RunCore.resumed`)."""
        self.plan, self.plan_id = plan, point.plan_number
        if point.for_plan is not None:  # a way to the starts: the target (loaded) waits for Start after it
            self.loaded, self.purpose = self._way(plan, "resumed from {}".format(point.folder)), TO_STARTS
        self.stranded = {self.fleet.by_id[rid].agent for rid in point.stranded if rid in self.fleet.by_id}
        if point.walls:  # (None: a folder from before walls were recorded, `RunCore.resumed` infers them)
            free = self.grid.free.copy()
            for x, y in point.walls:
                if self.grid.in_bounds((x, y)):
                    free[y, x] = False
            self.rerouting.keep_to(Grid(free, name=self.grid.name))
        self.out.add(ResumeRunFolder(point.folder))
        self.engine = self._engine(plan)
        self.driver = self._driver(self.engine)
        fleet, run = self.fleet, self.engine.run
        agents = {r.id: r.agent for r in fleet}
        done = [min(point.completed.get(r.id, 0), run.count(r.agent)) for r in fleet]
        back = [r.id in point.taken_back for r in fleet]  # a move begun, then taken back by a fault
        began = [d if b else min(point.started.get(r.id, 0), run.count(r.agent)) for r, d, b in zip(fleet, done, back)]
        sent = [d if b else min(point.dispatched(r.id), run.count(r.agent)) for r, d, b in zip(fleet, done, back)]
        try:  # the cells' order as the passes of a re-ordering strategy left it, then the progress
            replay_passes(run, [(agents.get(a, -1), k, agents.get(b, -1), j) for a, k, b, j in point.passes])
            dispatches = self.engine.restore(done, began, sent, now, back)
        except (ValueError, EventError) as err:
            raise FleetError("cannot resume {}: its records do not fit {}: {}".format(
                point.folder, point.plan, err)) from None
        for d in dispatches:
            fleet[d.agent].queue.append(d)
        for robot in fleet:
            robot.next_id = max(robot.next_id, point.next_id.get(robot.id, 1))
            run.halfway[robot.agent] = back[robot.agent]  # between two cells until it makes that move
        disabled = []
        for rid, (why, reason) in sorted(point.out.items()):
            robot = fleet.by_id.get(rid)
            if robot is None:
                continue
            if why == "disabled":
                self.engine.handle(Disabled(robot.agent, now))
                disabled.append(robot)
            else:
                self.engine.handle(RobotFailed(robot.agent, now))
                robot.queue.clear()
                robot.hold, robot.hold_reason = (HALTED if reason.startswith("halted") else FAULT), reason
        again = []
        for robot in fleet:
            for u in point.unsettled.get(robot.id, ()):
                if u.action is not None and u.action >= run.count(robot.agent):
                    continue  # a command of an older plan
                self.out.send(robot.id, u.command)
                again.append([robot.id, u.command.id, u.command.TYPE])
                kind = u.command.TYPE
                if kind in ("drive", "turn", "stop"):
                    target = ((u.command.x, u.command.y) if kind == "drive"  # type: ignore[union-attr]
                              else (u.command.angle,) if kind == "turn" else ())  # type: ignore[union-attr]
                    robot.flight = InFlight(u.command.id, kind, u.action, now, target)
                if kind == "drive" and robot.queue and robot.queue[0].index == u.action:
                    self.driver.following.sent(robot.queue[0], u.hold)
        for robot in disabled:  # after their drives in flight are back: those finish (a follower
            self.driver.drop_pending(robot)  # among them is released as its leader goes on)
        self.started_at, self.plan_since = point.began, point.plan_since
        step = self.settings.step_time
        self.plan_start = point.earlier_plans / step if step > 0 else 0.0
        self.out.record("resume", started=None, plan=point.plan, completed=done, sent=again,
                        dropped=0, downtime=round(max(0.0, now - point.last_t), 3),
                        # where this manager's ids start: a manager taking over after it numbers
                        # above them (its releases are not logged, and the robots remember them)
                        next_ids=[r.next_id for r in fleet])
        if point.began is not None:  # under way: nothing moves on before the robots are checked
            self.driver.releasing = False
            for robot in fleet:
                if robot.hold is None:
                    robot.hold = RESUMING
            self.resuming = Resuming(point, now)
            self.move("resumed", "resumed from {}: checking where the robots are".format(point.folder.name))

    def say(self, reason: str) -> None:
        """A new reason for the phase the run is in (recorded and versioned)."""
        if reason != self.phase.reason:
            self.phase.reason = reason
            self._phase_changed()

    def switch_plan(self, plan: Plan, reason: str, now: float, grid: Optional[Grid] = None) -> None:
        """Run `plan` from now on (a safe point: nobody mid-move), keeping who is out; `grid`: the
        map it was planned on, walls included (default: the run's), which its reroutes keep to. A
        plan the engine refuses (`PlanError`) changes nothing."""
        old = self.engine
        engine = self._engine(plan)  # first: a plan it refuses leaves the run as it was
        self.rerouting.keep_to(self.grid if grid is None else grid)
        goals = self.loaded.goals
        self.stranded = {a for a in range(plan.num_agents)
                         if tuple(plan.positions[-1, a]) != tuple(goals[a]) or self._left_between(a, plan)}
        self.standing.clear()
        self.walls.clear()
        self.plan_id += 1
        self.plan = plan
        for agent, why in enumerate(old.run.out):
            if why is not None:
                engine.handle((Disabled if why == "disabled" else RobotFailed)(agent, now))
        self._drive(engine)
        self.next_plan_clock(now)
        self._write_plan(plan, reason)

    def _write_plan(self, plan: Plan, reason: str, concerns: Optional[List[int]] = None, **fields: object) -> None:
        """The run's new plan (`plan_id`) to the run folder, its record, and every console told; a
        change of the whole run for the consoles' version, or of the robots `concerns` names."""
        name = plan_file(self.plan_id)
        starts = [tuple(int(v) for v in c) for c in plan.positions[0]]
        sol = make_solution(self.grid, self.loaded.solution.map_file or "", plan, starts,
                            [tuple(int(v) for v in c) for c in plan.positions[-1]],
                            "fleetcontrol-" + reason, True, 0)
        sol.orientation = self.loaded.solution.orientation
        self.out.add(WriteFile(name, format_solution(sol)))
        if self.stranded:  # the summary does not count them arrived (`stranded`)
            fields["stranded"] = sorted(self.fleet[a].id for a in self.stranded)
        self.out.record("plan", file=name, robots=self.fleet.ids, reason=reason, at=None,
                        actions=action_counts(plan), starts=[list(c) for c in starts],
                        walls=self.kept_walls(), **fields)
        self.out.desk.bump("plan {} ({})".format(self.plan_id, reason), robots=concerns)
        self.out.broadcast(self.setup())

    def reroute(self, found: Reroute, now: float) -> Optional[str]:
        """Go on with `found`'s plan from now, the robots in the middle of their moves; why not
        (said to the operator and recorded, nothing changed) when the robots have moved since
        its cut (`handover`)."""
        ids = self.fleet.ids
        look = round(now - found.cut.time, 3)  # s from the look's cut to now (the worker's time, or the operator's)
        try:
            new, dispatches = hand_over(self.engine, found, now)
        except HandoverError as err:
            self.rerouting.dropped += 1
            moved = moved_since(self.engine, found)
            why = "the reroute no longer fits: {}".format(
                moved_words(moved, ids) + " since" if moved else err)
            self.out.record("reroute_dropped", reason=why, robots=[ids[a] for a in found.agents], look=look)
            self.out.tell(REROUTE, None, "reroute dropped: " + why)
            return why
        self.rerouting.done += 1
        base = found.cut.base
        run = new.run
        self.plan_id += 1
        self.plan = found.plan
        self.next_plan_clock(now)
        text = found.describe(lambda a: ids[a])
        # a follower's move done before its leader left is the new plan's first, done already
        self._write_plan(found.plan, "reroute", [ids[a] for a in found.agents], done=list(run.completed),
                         base=list(base))
        self.out.record("reroute", robots=[ids[a] for a in found.agents], around=ids[found.around],
                        late=found.late, gain=found.gain, text=text, plan=plan_file(self.plan_id),
                        base=list(base), look=look)
        self.out.tell(REROUTE, None, text)
        self.driver.hand_over(new, base, dispatches, now)
        self.engine = new
        return None

    @staticmethod
    def _on_centre(robot: Robot, here: Coord) -> bool:
        """Whether `robot` stands on the centre of `here` (`ON_CENTRE`), by a pose taken since its
        last reply."""
        pose = robot.pose
        return pose is not None and robot.pose_settled() and math.hypot(pose.x - here[0], pose.y - here[1]) <= ON_CENTRE

    def stranded_between(self) -> List[int]:
        """The ids of robots taking part that the plan leaves away from their goals and that stand
        off their cells' centres (between two cells): a reroute of every robot would plan them from
        those cells (wide big session 1421: robots 2 and 7, stranded leaning into each other's
        cells, were both given paths; robot 7 then had moves out of the cell robot 2 leaned half
        into, and robot 2 was found moved by hand). A replan plans them from where they stand."""
        if not self.stranded:  # (asked every loop turn while rerouting every robot)
            return []
        cells = self.positions()
        return [r.id for r in self.fleet if r.agent in self.stranded and self.engine.run.out[r.agent] is None
                and not self._on_centre(r, cells[r.agent])]

    def never_home(self, robot: Robot) -> str:
        """Why `robot`, stranded, can be given no way home however long the run goes on ("" if
        it may be): a pose taken since its last reply has it off the centre of the cell the run has
        it on, so only a replan, from where it stands, takes it home (`take_home`)."""
        here = self.positions()[robot.agent]
        if robot.pose is None or not robot.pose_settled() or self._on_centre(robot, here):
            return ""
        return "it does not stand on the centre of {}".format(self.loaded.show(here))

    def take_home(self, robot: Robot, now: float) -> Optional[str]:
        """Robot `robot`, enabled again where the plan had left it away from its goal (`stranded`),
        given a way to its goal around the others while the run goes on (`reroute.way_home`, handed
        over as a reroute), and with it every other robot taking part that the plan leaves away
        from its goal (it may have had no way then, this one in it); why not (nothing changed).
        Only robots standing on the centre of the cell the run has them on (`ON_CENTRE`), a pose taken since
        their last reply saying so: one between two cells, or carried elsewhere, a replan plans
        from where it stands (`replanning.going_on`, `stood_on`)."""
        cells = self.positions()

        def on_centre(r: Robot) -> bool:
            return self._on_centre(r, cells[r.agent])

        if not on_centre(robot):
            return "it does not stand on the centre of {}".format(self.loaded.show(cells[robot.agent]))
        if self.rerouting.on_walls(self.engine) or self.walls:  # (a way from now would start a robot on a
            return NO_WAY_HOME  # wall, or keep one on a path through a wall a takeover raised; tried again every step)
        others = [r for r in self.fleet if r.agent in self.stranded and r is not robot
                  and self.engine.run.out[r.agent] is None and on_centre(r)]
        found = None
        for group in ([robot] + others, [robot]) if others else ([robot],):
            try:
                found = way_home(self.engine, self.rerouting.maps, now,
                                 {r.agent: tuple(self.loaded.goals[r.agent]) for r in group})  # type: ignore[misc]
            except RerouteError as err:  # a plan its own checks refuse: said, nothing handed over
                return str(err)  # (the caller is the loop: a request, or a tick)
            if found is not None:
                break
        if found is None:
            return NO_WAY_HOME
        was = set(self.stranded)
        self.stranded -= set(found.agents)  # the plan record says so: they count once home
        why = self.reroute(found, now)
        if why is not None:
            self.stranded = was
        return why

    def load(self, loaded: LoadedPlan, now: float, why: str = "another plan was loaded",
             reason: str = "") -> None:
        """Another plan (the operator's `load`, or the target again after `reset` or the way to
        its starts): a new run, in a new run folder, waiting for Start."""
        self.way_after = None  # (a Reset pressed before: it was for the plan run so far)
        self._end(why)
        if self.settings.trim and loaded is not self.target:  # the target again is trimmed already
            loaded = trim_loaded(loaded, TRIM_IN_LOOP_S)[0]
        self.target = self.loaded = loaded
        self.purpose = PLAN
        self._new_run(loaded.plan, now)
        self.move("load" if self.phase.refusal("load") is None else "reset",
                  reason or "{} loaded; waiting for Start".format(loaded.title))
        self.out.broadcast(self.setup())

    def trim_waiting(self, now: float) -> Optional[str]:
        """The plan waiting for Start trimmed now (`trim_loaded`; trim switched on before it), in the
        same run folder, and what was trimmed ("is trimmed: ...", or "is as it was (...)"); None
        once the run has begun (the plan running is not trimmed: its robots may be in the middle
        of moves it would change), or while the way to the starts runs. Reset takes the trimmed
        plan again."""
        if self.started_at is not None or self.purpose != PLAN or self.loaded is not self.target:
            return None
        trimmed, result = trim_loaded(self.loaded, TRIM_IN_LOOP_S)
        if not result.robots:  # nobody had a move to spare (or time ran out first): as it was
            return "is as it was ({})".format(result.describe())
        self.switch_plan(trimmed.plan, "trim", now)
        self.target = self.loaded = trimmed
        return "is " + result.describe()  # "is trimmed: 10 moves fewer (67 to 57), 3 robots"

    def _end(self, why: str) -> None:
        self.out.summary.feed({"k": "end", "t": round(self.out.now, 4), "reason": why})
        summary = self.out.summary.summary()
        self.out.record("end", reason=why, arrived=len(summary.arrived), robots=len(self.fleet),
                        summary=summary.as_dict())
        self.out.summary = SummaryBuilder()

    def _new_run(self, plan: Plan, now: float) -> None:
        self.plan = plan
        self.started_at = self.plan_since = self.ended_at = None
        self.plan_start = 0.0
        self.plan_id += 1
        self.stranded = set()
        old_out = self.engine.run.out
        engine = self._engine(plan)
        for agent, why in enumerate(old_out):
            if why == "disabled":  # the operator's choice outlives the plan
                engine.handle(Disabled(agent, now))
            elif self.fleet[agent].hold in (FAULT, HALTED):  # held still: out of the new run too, so
                engine.handle(RobotFailed(agent, now))  # that enabling it (or Start) takes it back
        self._begin()
        self._drive(engine)

    def _drive(self, engine: Engine) -> None:
        """Run `engine` from now on: robots keep their state, not the old plan's queue."""
        for robot in self.fleet:
            robot.queue.clear()
            robot.flight = None
        self.engine = engine
        self.driver = self._driver(engine)

    def setup(self) -> RunSetup:
        return setup(self.grid, self.fleet, self.plan_id, self.plan, self.loaded.name,
                     self.settings.step_time, self.settings.size, self.loaded.solution.orientation)

    def halfway_cells(self) -> Set[Coord]:
        """The cells robots out with no pose stopped halfway into (a fault in the middle of the
        move: the engine keeps the cell for them, `RunState.halfway`). A replan walls off the
        cell a robot leans into by its pose (`replanning.walled`); a robot with no pose from the
        chosen source (Vicon has not seen it since this manager started) leans into nothing, and
        one was planned through the cell another stood half in (Vicon session 2839): these are
        walled off by the engine's record. Once a replan has planned around such a robot, the
        engine no longer has it halfway: the cells next to its cell that the plan keeps off
        (`kept_walls`) stand for that record, so the next replan walls them off again (a live
        Vicon session, 580: a second replan planned without them, and the robot was "moved by
        hand")."""
        state, table = self.engine.run, self.engine.table
        cells: Set[Coord] = set()
        kept = {(x, y) for x, y in self.kept_walls()}
        for a in range(state.num_agents):
            if state.out[a] is None or self.fleet[a].pose is not None:
                continue
            nxt = state.next_incomplete(a)
            if state.halfway[a] and nxt >= 0:
                cells.add(tuple(table.coord(state.dst[nxt])))  # type: ignore[arg-type]
            elif kept:
                x, y = self.driver.position(self.fleet[a])
                cells |= kept & {(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)}
        return cells

    # ---- the way to the starts --------------------------------------------------------------

    def _going_on(self, cells: Sequence[Coord]) -> Dict[int, Coord]:
        """The robots taking part that stand between their cell (of `cells`) and a free one: the
        way to the starts has them finish that move first (`replanning.going_on`)."""
        out = {r.agent for r in self.fleet if self.engine.run.out[r.agent] is not None}
        return going_on(self.fleet_map, self.fleet.robots, cells, out, self.halfway_cells())

    def plan_to_starts(self, cells: Sequence[Coord], now: float, reason: str) -> None:
        """Plan the way from `cells` (where the robots stand) to the target's starts, off the
        loop; the run waits meanwhile (`to_starts_ready` carries on). The cell a robot between
        two cells leans into is walled off, but for one taking part that can finish its move
        into it first (planned from there, the move prefixed: `replanning.prefixed`)."""
        out = {r.agent for r in self.fleet if self.engine.run.out[r.agent] == "disabled"}
        on = self._going_on(cells)
        grid = walled(self.fleet_map, self.fleet.robots, cells, set(on), self.halfway_cells())
        self.to_starts_first = {a: tuple(cells[a]) for a in on}
        self.to_starts_grid = grid
        job = PlanJob(next(self.job_ids), grid, [on.get(a, c) for a, c in enumerate(cells)],
                      list(self.target.starts), out, self.settings.to_starts_limit, "pp")
        self.to_starts_job = job.id
        self.out.add(job)
        self.move("to_starts" if self.phase.refusal("to_starts") is None else "reset", reason)

    def _way(self, plan: Plan, note: str, comp_time_ms: int = 0) -> LoadedPlan:
        """`plan`, the way from where the robots stand to the target's starts, as a loaded plan. Its
        file (the way's plan-1.txt) names as each robot's goal where the way leaves it: a robot
        disabled when it was planned stays where it stands, and a file naming its start would not
        validate, nor could a manager taking the way over read it (a live session: `--resume` said
        "invalid plan ... agent 1 ends at (6, 8) but its goal is (11, 8)")."""
        starts = [tuple(int(v) for v in c) for c in plan.positions[0]]
        ends = [tuple(int(v) for v in c) for c in plan.positions[-1]]
        sol = make_solution(self.fleet_map, self.target.solution.map_file or "", plan, starts,
                            ends, "fleetcontrol-to-starts", True, comp_time_ms)
        sol.orientation = self.target.solution.orientation
        return LoadedPlan(plan, self.fleet_map, starts, list(self.target.starts),
                          "to the starts of {}".format(self.target.title), sol, self.target.show, note)

    def to_starts_ready(self, result: Optional[ReplanResult], error: Optional[str], now: float) -> None:
        """The way to the starts is planned (or not): run it, or say why not."""
        self.to_starts_job = None
        if self.phase.phase != WAITING:
            return  # nobody waits for it any more
        name = self.target.title
        if error is not None or result is None or result.plan is None or result.unreachable:
            why = error or (result.message if result is not None else "no result")
            if result is not None and result.unreachable:
                why = "robot{} {} cannot reach {} start (a disabled robot stands in the way)".format(
                    "s" if len(result.unreachable) > 1 else "",
                    _ids([self.fleet[a].id for a in sorted(result.unreachable)]),
                    "its" if len(result.unreachable) == 1 else "their")
            self.move("no_way", "no way to the starts of {}: {}".format(name, why))
            self.out.tell("run", None, "no way to the starts of {}: {}".format(name, why))
            return
        plan = prefixed(result.plan, self.to_starts_first)
        way = self._way(plan, result.message, round(result.comp_time_ms))
        self._end("the robots drive to the starts first (a run of its own)")
        self.loaded, self.purpose = way, TO_STARTS
        if self.to_starts_grid is not None:  # its reroutes keep off the cells it was walled off from,
            self.rerouting.keep_to(self.to_starts_grid)  # and a robot left leaning into one stands there
        self._new_run(plan, now)
        self.begin_clock(now)
        self.move("start", "driving every robot to its start for {} ({} moves)".format(
            name, sum(action_counts(plan))))
        self.take_back_halted(now, "resumed after halt: the way to the starts")  # driven at once, as Start would
        self.driver.handle(Resume(now), now)  # an engine starts paused
        self.out.broadcast(self.setup())
        self.out.tell("run", None, "robots driving to the starts of {}".format(name))

    def take_back_halted(self, now: float, reason: str) -> None:
        """The robots the operator halted take part again (Start, Step, the way to the starts)."""
        for robot in self.fleet:
            if robot.hold == HALTED:
                self.driver.enable(robot, now)
                self.out.record("out", robot=robot.id, why=None, reason=reason)

    def arrived(self, now: float) -> None:
        """Every robot taking part is at its goal: the run is done (the way to the starts: the
        target plan waits for Start)."""
        self.ended_at = now
        disabled = self.disabled()
        if self.purpose == TO_STARTS:
            # a robot disabled when the way was planned stayed where it stood (enabled since, it
            # takes part again): the target waits for Start all the same, which names it
            away = [r.id for r in self.fleet if tuple(self.driver.position(r)) != tuple(self.target.starts[r.agent])]
            said = ("every robot is on its start" if not away else "the way to the starts is driven, but robot{} "
                    "{} stayed off {} (disabled on the way)".format("s" if len(away) > 1 else "", _ids(away),
                                                                   "their starts" if len(away) > 1 else "its start"))
            self.move("arrived", said)
            self.load(self.target, now, said, "{}: {}".format(said, "press Start to run {}".format(self.target.title)
                                                            if not away else "Go to starts drives {} there".format(
                                                                "them" if len(away) > 1 else "it")))
            self.out.tell("run", None, "every robot is on its start of {}: ready for Start".format(self.target.title)
                          if not away else "{} of {}".format(said, self.target.title))
            return
        self.move("arrived", "every enabled robot is at its goal{}".format(
            "" if not disabled else " (disabled: robot{} {})".format("s" if len(disabled) > 1 else "",
                                                                     _ids(disabled))))

    def new_leg(self, robot: Robot, now: float) -> None:
        """A robot enabled again after the run was done drives on to its goal: a new leg."""
        self.ended_at = None
        self.move("leg", "robot {} enabled again after the end: a new leg to its goal".format(robot.id))
        if self.engine.paused:  # a run stepped to its end stands paused
            self.driver.handle(Resume(now), now)
        self.out.tell("run", robot.id, "robot {} enabled after the end: a new leg of the run".format(robot.id))


def lost_words(ids: List[int]) -> str:
    """What the operator can do about robots whose Vicon pose, the one the run uses, is older
    than their last move: Vicon lost them (occluded, or out of the cameras' view)."""
    one = len(ids) == 1
    return ("Vicon has not seen robot{} {} since {} last move: wait until it does, or choose {} own "
            "pose{} (position source)".format("" if one else "s", _ids(ids), "its" if one else "their",
                                              "the robot's" if one else "the robots'", "" if one else "s"))


def cut_off_words(ids: List[int]) -> str:
    """What a replan waits for from robots whose link went down in the middle of a move: they
    finish it once they are back (a robot that lost its power is sent it again)."""
    one = len(ids) == 1
    return ("robot{} {} lost {} link in the middle of a move: waiting until {} back and {} finished "
            "it (power {} on, check {} network), or Stop to give the replan up".format(
                "" if one else "s", _ids(ids), "its" if one else "their", "it is" if one else "they are",
                "has" if one else "have", "it" if one else "them", "its" if one else "their"))


def _ids(ids: List[int]) -> str:
    return ", ".join(str(i) for i in ids)
