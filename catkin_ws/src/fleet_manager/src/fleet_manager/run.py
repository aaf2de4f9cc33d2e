"""One run: a plan, its engine and driver, the run's phase, and how plans change under it.

`Run` is what the operator's requests act on (`operator.py`) and what the
core (`core.py`) feeds robot news to. It owns the plan being run (a new one
after a `load`, which starts a new run in a new run folder, or an accepted
replan, which continues the same run with plan-2.txt, plan-3.txt ...), the
execution engine for it, the driver that turns the engine's decisions into
commands, the phase (`run_phase`) and the replanner's state. Everything it
does goes out through the `Outbox` as values. A run may also be resumed
from the folder of a manager that died (`resume.py`): it goes on there.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Dict, List, Optional, Set, Tuple

from fleet_common.control import RunSetup
from fleet_common.errors import FleetError
from fleet_common.execution import Disabled, Engine, EventError, RobotFailed
from fleet_common.execution.reorder import replay as replay_passes
from fleet_common.formats.solution import format_solution, make_solution
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.plan_loading import LoadedPlan
from fleet_common.runlog.records import FORMAT_VERSION, plan_file, size_fields
from fleet_common.runlog.summary import SummaryBuilder

from .driver import AT_CELL, Driver
from .following import Following
from .outbox import NewRunFolder, Outbox, ResumeRunFolder, WriteFile
from .replanning import Replanner
from .resume import ResumePoint, Resuming
from .robot import FAULT, HALTED, RESUMING, Fleet, InFlight
from .run_phase import RUNNING, WAITING, RunPhase
from .settings import ManagerSettings
from .state_view import setup

__all__ = ["Run"]


def action_counts(plan: Plan) -> List[int]:
    pos = plan.positions
    return [int((pos[1:, i] != pos[:-1, i]).any(axis=1).sum()) for i in range(plan.num_agents)]


class Run:
    def __init__(self, loaded: LoadedPlan, fleet: Fleet, out: Outbox, settings: ManagerSettings,
                 resume: Optional[Tuple[ResumePoint, Plan]] = None, now: float = 0.0) -> None:
        self.fleet = fleet
        self.out = out
        self.settings = settings
        self.phase = RunPhase()
        self.replanner = Replanner(settings.replan_limit)
        self.loaded = loaded
        self.plan: Plan = loaded.plan
        self.plan_id = 1
        self.started_at: Optional[float] = None
        #: a resumed run before its robots were checked (`resume.py`)
        self.resuming: Optional[Resuming] = None
        #: agent -> the cell a robot found off the plan stands on (replanned from there)
        self.standing: Dict[int, Coord] = {}
        #: cells walled off for replanning around robots standing between cells
        self.walls: Set[Coord] = set()
        if resume is None:
            self.engine = self._engine(self.plan)
            self.driver = self._driver(self.engine)
            self._begin()
        else:
            self._resume(resume[0], resume[1], now)

    @property
    def grid(self) -> Grid:
        return self.loaded.grid

    def clock(self, now: float) -> float:
        """Seconds since the run started (0 before Start)."""
        return 0.0 if self.started_at is None else max(0.0, now - self.started_at)

    # ---- the phase ------------------------------------------------------------------------

    def move(self, trigger: str, reason: str = "") -> None:
        """Move the phase (the caller checked `phase.refusal`); recorded and versioned."""
        if self.phase.move(trigger, reason):
            self._phase_changed()

    def _phase_changed(self) -> None:
        state, reason = self.phase.phase, self.phase.reason
        self.out.desk.bump("run {}{}".format(state, ": " + reason if reason else ""))
        self.out.record("state", run=state, reason=reason)

    def all_arrived(self) -> bool:
        """Every robot not disabled by an operator is at its goal (a robot held by a fault
        has not arrived: it still takes part, and waits for someone to clear the fault)."""
        run = self.engine.run
        return all(run.out[a] == "disabled" or run.finished_agent(a) for a in range(run.num_agents))

    def stuck(self) -> bool:
        """Running, not everyone arrived, and nothing can happen without an operator (robots
        standing at their hold point behind a robot that is out count as not moving)."""
        if self.phase.phase != RUNNING or self.engine.paused or self.all_arrived() or self.replanner.busy:
            return False
        held = self.held_behind_out()
        run = self.engine.run
        return not any(r.hold == "recover" or not r.link_up or (r.agent not in held and (
            r.flight is not None or run.dispatched[r.agent] > run.completed[r.agent])) for r in self.fleet)

    def held_behind_out(self) -> Set[int]:
        """Followers whose leader is out: they wait at their hold point until it is back."""
        following, out = self.driver.following, self.engine.run.out
        leaders = {agent: following.leader_of(agent) for agent in following.holds}
        return {agent for agent, leader in leaders.items() if leader is not None and out[leader] is not None}

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
        for robot in self.fleet:
            if self.engine.run.out[robot.agent] is not None:
                continue
            start = self.engine.table.start(robot.agent)
            pose = robot.pose
            if pose is None:
                off.append("robot {} has not reported a pose".format(robot.id))
            elif math.hypot(pose.x - start[0], pose.y - start[1]) > AT_CELL:
                off.append("robot {} stands at {}, its start is {}".format(
                    robot.id, self.shown(pose.x, pose.y), self.loaded.show(start)))
        if off:
            return ("not on their start cells: " + "; ".join(off[:5]) + (
                "; and {} more".format(len(off) - 5) if len(off) > 5 else "")
                + " (cells as {} counts them); send them there with the console's go to starts, "
                  "or continue their last run (fleetctl manager --resume)".format(Path(self.loaded.name).name))
        return ""

    def shown(self, x: float, y: float) -> str:
        """A point of the base grid as the plan's file writes cells (its own coordinates)."""
        (x0, y0), (x1, y1) = self.loaded.show((0, 0)), self.loaded.show((1, 1))
        return "({:.1f}, {:.1f})".format(x0 + (x1 - x0) * x, y0 + (y1 - y0) * y)

    def positions(self) -> List[Coord]:
        """The cell each robot holds for planning (a robot found off the plan: where it stands)."""
        return [self.standing.get(r.agent) or self.driver.position(r) for r in self.fleet]

    # ---- plans ----------------------------------------------------------------------------

    def _engine(self, plan: Plan) -> Engine:
        settings = {"lookahead": self.settings.lookahead} if self.settings.strategy == "adg" else {}
        return Engine(plan, self.settings.strategy, show=self.loaded.show,
                      follow=not self.settings.size.cell_sized, step_time=self.settings.step_time,
                      **settings)

    def _driver(self, engine: Engine) -> Driver:
        size = self.settings.size
        following = Following(engine, self.fleet, None if size.cell_sized else size.safe_cells)
        driver = Driver(engine, self.fleet.robots, self.out, following, self.settings.preturn)
        engine.allow_take_back(driver.take_back)
        return driver

    def _begin(self) -> None:
        """The first records of a run (and of each run after a `load`)."""
        loaded = self.loaded
        self.out.add(NewRunFolder(loaded.text()))
        self.out.record("run", version=FORMAT_VERSION, started=None, source="manager", time_unit="s",
                        plan=plan_file(1), definitions=None, robots=self.fleet.ids,
                        strategy=self.settings.strategy, settings={"lookahead": self.settings.lookahead},
                        plan_name=loaded.name, actions=action_counts(loaded.plan),
                        starts=[list(c) for c in loaded.starts], goals=[list(c) for c in loaded.goals],
                        map=self.grid.name, step_time=self.settings.step_time,
                        size=size_fields(self.settings.size))

    def _resume(self, point: ResumePoint, plan: Plan, now: float) -> None:
        """Go on with the run of `point`'s folder (its manager died): the progress from its
        records, the commands no reply settled sent again with their ids, nothing new until
        the robots are checked (`core.RunCore.resumed`)."""
        self.plan, self.plan_id = plan, point.plan_number
        self.out.add(ResumeRunFolder(point.folder))
        self.engine = self._engine(plan)
        self.driver = self._driver(self.engine)
        fleet, run = self.fleet, self.engine.run
        agents = {r.id: r.agent for r in fleet}
        done = [min(point.completed.get(r.id, 0), run.count(r.agent)) for r in fleet]
        began = [min(point.started.get(r.id, 0), run.count(r.agent)) for r in fleet]
        sent = [min(point.dispatched(r.id), run.count(r.agent)) for r in fleet]
        try:  # the cells' order as the passes of a re-ordering strategy left it, then the progress
            replay_passes(run, [(agents.get(a, -1), k, agents.get(b, -1), j) for a, k, b, j in point.passes])
            dispatches = self.engine.restore(done, began, sent, now)
        except (ValueError, EventError) as err:
            raise FleetError("cannot resume {}: its records do not fit {}: {}".format(
                point.folder, point.plan, err)) from None
        for d in dispatches:
            fleet[d.agent].queue.append(d)
        for robot in fleet:
            robot.next_id = max(robot.next_id, point.next_id.get(robot.id, 1))
        for rid, (why, reason) in sorted(point.out.items()):
            robot = fleet.by_id.get(rid)
            if robot is None:
                continue
            if why == "disabled":
                self.engine.handle(Disabled(robot.agent, now))
                self.driver.drop_pending(robot)
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
        self.started_at = point.began
        self.out.record("resume", started=None, plan=point.plan, completed=done, sent=again,
                        dropped=0, downtime=round(max(0.0, now - point.last_t), 3))
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

    def switch_plan(self, plan: Plan, reason: str, now: float) -> None:
        """Run `plan` from now on (a safe point: nobody mid-move), keeping who is out."""
        old = self.engine
        self.standing.clear()
        self.walls.clear()
        self.plan_id += 1
        self.plan = plan
        engine = self._engine(plan)
        for agent, why in enumerate(old.run.out):
            if why is not None:
                engine.handle((Disabled if why == "disabled" else RobotFailed)(agent, now))
        self._drive(engine)
        name = plan_file(self.plan_id)
        starts = [tuple(int(v) for v in c) for c in plan.positions[0]]
        sol = make_solution(self.grid, self.loaded.solution.map_file or "", plan, starts,
                            [tuple(int(v) for v in c) for c in plan.positions[-1]],
                            "fleetcontrol-replan", True, 0)
        sol.orientation = self.loaded.solution.orientation
        self.out.add(WriteFile(name, format_solution(sol)))
        self.out.record("plan", file=name, robots=self.fleet.ids, reason=reason, at=None,
                        actions=action_counts(plan), starts=[list(c) for c in starts])
        self.out.desk.bump("plan {} ({})".format(self.plan_id, reason))
        self.out.broadcast(self.setup())

    def load(self, loaded: LoadedPlan, now: float) -> None:
        """Another plan (the operator's `load`): a new run, in a new run folder, waiting for Start."""
        summary = self.out.summary.summary()
        self.out.record("end", reason="another plan was loaded", arrived=len(summary.arrived),
                        robots=len(self.fleet), summary=summary.as_dict())
        self.out.summary = SummaryBuilder()
        self.loaded, self.plan = loaded, loaded.plan
        self.started_at = None
        self.plan_id += 1
        old_out = self.engine.run.out
        engine = self._engine(self.plan)
        for agent, why in enumerate(old_out):
            if why == "disabled":  # the operator's choice outlives the plan
                engine.handle(Disabled(agent, now))
        self._begin()
        self._drive(engine)
        self.move("load", "{} loaded; waiting for Start".format(loaded.name))
        self.out.broadcast(self.setup())

    def _drive(self, engine: Engine) -> None:
        """Run `engine` from now on: robots keep their state, not the old plan's queue."""
        for robot in self.fleet:
            robot.queue.clear()
            robot.flight = None
        self.engine = engine
        self.driver = self._driver(engine)

    def setup(self) -> RunSetup:
        return setup(self.grid, self.fleet, self.plan_id, self.plan, self.loaded.name,
                     self.settings.step_time, self.settings.size)


def _ids(ids: List[int]) -> str:
    return ", ".join(str(i) for i in ids)
