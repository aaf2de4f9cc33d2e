"""The manager process: one loop that drives the fleet through a plan and serves the consoles.

One thread, one poller (`LinkSet`): the robots' command sockets, the console
channel, the ZAP handler and the Vicon socket are all read as they become
readable, and between them the loop does what is due, one chore a turn so that
replies never wait behind all of them (each costs milliseconds at 300 robots):
read the robots' pose streams (every 50 ms), publish the state (soon after
news, at most 50 times a second, and 20 times a second without), log poses
(10 Hz); and at every turn move a replan on and notice the end of the run.
What happens when:

- a robot's reply or pose arrives: the driver turns it into engine events and
  new commands (`driver.py`); poses also go to `positions.py`;
- a console's frame arrives: the desk checks it (`fleet_common.control.desk`)
  and a request that may go ahead is carried out by `steering.py`, which
  answers it;
- the run is finished: the state says "done"; with `until_done` the loop
  ends and `summary()` says how it went.

Everything the run does is written to its run folder as it happens
(`fleet_common.runlog`); the summary is computed from the same records.
"""
from __future__ import annotations

import logging
import secrets
import time
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple


from fleet_common.control import Bye, Event, PlanData, Proposal, RobotInfo, Scene, Waiting
from fleet_common.execution import Disabled, Engine, RobotFailed
from fleet_common.formats.solution import format_solution, make_solution
from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.robots import RobotDefinition
from fleet_common.runlog import RunLog, new_run_folder
from fleet_common.runlog.records import FORMAT_VERSION, plan_file
from fleet_common.runlog.summary import RunSummary, SummaryBuilder
from fleet_common.control.desk import ControlDesk
from fleet_common.transport.context import fleet_context
from fleet_common.transport.console_channel import DEFAULT_ENDPOINT, ConsoleServer
from fleet_common.transport.curve_keys import ManagerKeys
from fleet_common.transport.link_events import LinkDown, LinkEvent, LinkUp
from fleet_common.transport.links import LinkSet
from fleet_common.transport.robot_link import RobotLink
from fleet_common.transport.zap import ZapHandler
from fleet_common.wire import PoseFeedback

from .driver import Driver, Slot
from .plan_source import LoadedPlan
from .positions import Positions
from .replanning import Replanner
from .snapshot import build_state, robot_waits
from .steering import Steering
from .vicon_watch import ViconWatch

__all__ = ["Manager", "ManagerSettings"]


def _robots_wait(ids: List[int]) -> str:
    if len(ids) == 1:
        return "robot {} waits".format(ids[0])
    return "robots {} wait".format(", ".join(map(str, ids)))


def _utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")

_POSE_LOG_PERIOD = 0.1     # s between `poses` records (10 Hz)
_STALL_GRACE = 3.0         # s a run must stay stalled before --until-done gives up


@dataclass
class ManagerSettings:
    strategy: str = "adg"
    lookahead: int = 1
    bind: str = DEFAULT_ENDPOINT
    log_dir: Optional[Path] = None
    step_time: float = 2.5       # s a plan step is expected to take (the planned-position ghost)
    state_rate: float = 20.0     # state messages per second, at least
    state_max_rate: float = 50.0  # and at most, when news (poses, replies) comes faster
    stale_after: float = 1.0     # s without a pose before a robot's position is stale
    replan_limit: float = 5.0    # s a replan may take
    preturn: bool = True         # robots turn towards their next cell while they wait
    definitions: Optional[Path] = None
    map_dirs: List[Path] = field(default_factory=list)  # where `load` looks for map files
    vicon_port: Optional[int] = None  # Vicon Tracker's UDP stream (None: no Vicon)
    vicon_bind: str = "0.0.0.0"
    frames: Optional[Path] = None     # frames file with vicon_to_base (None: the lab's)


class Manager:
    def __init__(self, loaded: LoadedPlan, robots: Sequence[RobotDefinition],
                 settings: ManagerSettings, *, keys: Optional[ManagerKeys] = None,
                 host: Optional[str] = None, clock: Callable[[], float] = time.monotonic,
                 say: Callable[[str], None] = print, log: Optional[logging.Logger] = None) -> None:
        self.settings = settings
        self.robots = list(robots)
        self.clock = clock
        self.say = say
        self.log = log or logging.getLogger("fleet_manager")
        self.t0 = clock()
        self.step_time = settings.step_time
        self.loaded = loaded
        self.grid: Grid = loaded.grid
        self.goals: List[Coord] = list(loaded.goals)
        self.plan: Plan = loaded.plan
        self.plan_id = 1
        self.run_state = "waiting"
        self.run_reason = "waiting for Start"
        self.started_at: Optional[float] = None
        self.link_reasons: Dict[int, str] = {}
        self.summary_builder = SummaryBuilder()
        self.replanner = Replanner(settings.replan_limit)
        self.positions = Positions([r.id for r in self.robots], stale_after=settings.stale_after)
        self._event_seq = 0
        self._seq = 0
        self._last_waits: Optional[Dict[int, Waiting]] = None
        self._stalled_since: Optional[float] = None
        self.context = fleet_context(len(self.robots))
        self.runlog: Optional[RunLog] = None
        self.folder: Optional[Path] = None
        try:
            self._open_log(loaded)
            self.zap = ZapHandler(self.context, self.log, clock) if keys is not None else None
            # bind before connecting: the links' outgoing connections take ephemeral ports
            self.consoles = ConsoleServer(self.context, settings.bind, keys=keys, zap=self.zap,
                                          log=self.log)
            epoch = secrets.token_hex(8)
            self.links = LinkSet([RobotLink(self.context, r, epoch, keys=keys, host=host, clock=clock,
                                            log=self.log) for r in self.robots], clock=clock)
            self.vicon = None if settings.vicon_port is None else ViconWatch(
                self.robots, self.positions, settings.vicon_port, settings.vicon_bind,
                settings.frames, self.now, self.note, self.tell, clock, self.log)
        except BaseException:
            self._close_sockets()
            if self.runlog is not None:
                self.runlog.close()
            raise
        self.links.watch(self.consoles.socket, self._console_frames)
        if self.zap is not None:
            self.links.watch(self.zap.socket, self.zap.handle)
        if self.vicon is not None:
            self.links.watch(self.vicon.provider.fileno(), self._vicon_readable)
        self.desk = ControlDesk(secrets.token_hex(8), self.now())
        self.engine = self._new_engine(self.plan)
        self.driver = self._new_driver(self.engine, None)
        self.steering = Steering(self)
        self._next_state = self._next_poses = self.now()
        self._last_state = self.now()
        self._fresh = False  # something arrived that the consoles have not been sent yet
        self._state_cost = 0.0  # seconds a state takes to build and send (smoothed)

    # ---- time -------------------------------------------------------------------------------

    def now(self) -> float:
        """Seconds since the manager started (the run log's clock)."""
        return self.clock() - self.t0

    def clock_now(self, now: float) -> float:
        """Seconds since the run started (0 before Start)."""
        return 0.0 if self.started_at is None else max(0.0, now - self.started_at)

    # ---- setting up ---------------------------------------------------------------------

    def _open_log(self, loaded: LoadedPlan) -> None:
        if self.settings.log_dir is not None:
            self.folder = new_run_folder(self.settings.log_dir)
            self.runlog = RunLog(self.folder, clock=self.clock)
            self.runlog.start = self.t0
            self.runlog.write_text(plan_file(1), loaded.text())
        definitions = None
        if self.runlog is not None and self.settings.definitions is not None:
            definitions = self.runlog.copy_in(self.settings.definitions)
        self.note("run", version=FORMAT_VERSION, started=_utc_now(), source="manager", time_unit="s",
                  plan=plan_file(1), definitions=definitions, robots=[r.id for r in self.robots],
                  strategy=self.settings.strategy, settings={"lookahead": self.settings.lookahead},
                  plan_name=loaded.name, actions=self._action_counts(loaded.plan),
                  starts=[list(c) for c in loaded.starts], goals=[list(c) for c in loaded.goals],
                  map=self.grid.name, step_time=self.step_time)

    def _action_counts(self, plan: Plan) -> List[int]:
        pos = plan.positions
        return [int((pos[1:, i] != pos[:-1, i]).any(axis=1).sum()) for i in range(plan.num_agents)]

    def _new_engine(self, plan: Plan) -> Engine:
        settings = {"lookahead": self.settings.lookahead} if self.settings.strategy == "adg" else {}
        return Engine(plan, self.settings.strategy, show=self.loaded.show, **settings)

    def _new_driver(self, engine: Engine, old: Optional[Driver]) -> Driver:
        if old is None:
            slots = [Slot(i, r.id, self.links[r.id]) for i, r in enumerate(self.robots)]
        else:
            slots = old.slots
            for s in slots:
                s.queue.clear()
                s.flight = None
        driver = Driver(engine, slots, self.note, self.tell)
        driver.preturn = self.settings.preturn
        if old is not None:
            driver.trace = old.trace
        return driver

    # ---- what the run writes and tells ----------------------------------------------------

    def note(self, kind: str, **fields: object) -> None:
        """A run log record (also fed to the summary)."""
        t = round(self.now(), 4)
        self.summary_builder.feed(dict(fields, k=kind, t=t))
        if self.runlog is not None:
            self.runlog.record(kind, t=t, **fields)

    def tell(self, kind: str, robot: Optional[int], text: str) -> None:
        """An event for the consoles' event lists (and the terminal)."""
        self._event_seq += 1
        event = Event(self._event_seq, round(self.now(), 3), kind, robot, text)
        self._send(self.desk.broadcast(event, self.clock()))
        if kind in ("fault", "link", "run", "plan", "strategy", "operator", "vicon"):
            self.say("[{:7.1f} s] {}".format(self.now(), text))
        if kind in ("link", "fault", "run", "plan") and robot is not None:
            self.desk.bump(text, robot)

    def set_state(self, state: str, reason: str = "") -> None:
        if (state, reason) == (self.run_state, self.run_reason):
            return
        self.run_state, self.run_reason = state, reason
        self.desk.bump("run {}{}".format(state, ": " + reason if reason else ""))
        self.note("state", run=state, reason=reason)

    # ---- the loop ---------------------------------------------------------------------------

    def run(self, should_stop: Callable[[], bool], until_done: bool = False,
            time_limit: Optional[float] = None) -> Optional[str]:
        """Serve until `should_stop()`; with `until_done`, until the run is over. The reason it
        could not go on (None: done, or stopped from outside)."""
        deadline = None if time_limit is None else self.now() + time_limit
        while not should_stop():
            now = self.now()
            due = min(chore for chore, _ in self._chores())
            for event in self.links.poll(max(0.0, min(0.05, due - now)), drain=False):
                self._link_event(event)
            now = self.now()
            self._chore(now)
            self._timers(now)
            if until_done:
                if self.run_state == "done":
                    return None
                failure = self._cannot_go_on(now)
                if failure is not None:
                    return failure
                if deadline is not None and now >= deadline:
                    return "not done after the time limit of {:g} s".format(time_limit)
        return None

    def _chores(self) -> List[Tuple[float, Callable[[float], None]]]:
        """The loop's periodic work, each with when it is due."""
        return [(self.links.next_drain - self.t0, self._read_poses),  # the links' clock
                (min(self._next_state, self._state_due()), self._publish),
                (self._next_poses, self._log_poses)]

    def _chore(self, now: float) -> None:
        """The most overdue chore, one per turn: each costs milliseconds with 300 robots, and
        between two of them the loop reads the robots' replies (a reply waiting behind all
        three would wait three times as long)."""
        due, chore = min(self._chores(), key=lambda c: c[0])
        if due <= now:
            chore(now)

    def _read_poses(self, now: float) -> None:
        for event in self.links.drain_poses():
            self._link_event(event)

    def _timers(self, now: float) -> None:
        message = self.replanner.poll(self)
        if message is not None:
            self._replan_progress(message)
        if self.run_state == "running" and self.all_arrived() and not self.driver.moving:
            self.set_state("done", "every robot taking part is at its goal")
            self.tell("run", None, "run done: {}".format("; ".join(self.summary().lines()[:2])))
            self._publish(now)
        self._send(self.desk.tick(self.clock()))

    def _state_due(self) -> float:
        """When news (a pose, a reply) goes out: at once, but at most `state_max_rate` times a
        second, and at most a tenth of the loop's time (a state of 300 robots costs a few ms
        to build and send); without news the state still goes out `state_rate` times a second."""
        if not self._fresh:
            return float("inf")
        return self._last_state + max(1.0 / self.settings.state_max_rate, 10.0 * self._state_cost)

    def _vicon_readable(self) -> None:
        self.vicon.readable()  # type: ignore[union-attr]
        self._fresh = True

    def _link_event(self, event: LinkEvent) -> None:
        self._fresh = True
        now = self.now()
        if isinstance(event, PoseFeedback):
            self.positions.from_robot(event.robot_id, event.pose, now)
        elif isinstance(event, LinkDown):
            self.link_reasons[event.robot_id] = event.reason
        elif isinstance(event, LinkUp):
            self.link_reasons.pop(event.robot_id, None)
        self.driver.on_link_event(event, now)

    def _publish(self, now: float) -> None:
        began = time.perf_counter()
        self._next_state = now + 1.0 / self.settings.state_rate
        self._last_state, self._fresh = now, False
        waits = robot_waits(self)
        if waits != self._last_waits:
            self._last_waits = waits
            self.note("waits", w=[[rid, list(w.on), None if w.cell is None else list(w.cell), w.reason]
                                  for rid, w in sorted(waits.items())])
        if self.desk.consoles:
            self._seq += 1
            self._send(self.desk.broadcast(build_state(self, now, self._seq, waits), self.clock()))
        self._state_cost = 0.8 * self._state_cost + 0.2 * (time.perf_counter() - began)

    def _log_poses(self, now: float) -> None:
        self._next_poses = now + _POSE_LOG_PERIOD
        if self.vicon is not None:
            self.vicon.check(now)
        rows = []
        for r in self.robots:
            seen = self.positions.seen(r.id)
            if seen is None:
                continue
            p = seen.pose
            rows.append([r.id, round(p.x, 3), round(p.y, 3), round(p.theta, 3),
                         self.positions.source[r.id], round(now - seen.at, 3)])
        if rows:
            self.note("poses", p=rows)  # the summary builder finds the closest pair in it

    @property
    def min_distance(self) -> Optional[float]:
        """The smallest distance between two robots in the run so far (cells)."""
        found = self.summary_builder.min_distance
        return None if found is None else round(found, 3)

    @property
    def collisions(self) -> int:
        return self.summary_builder.collisions

    def all_arrived(self) -> bool:
        """Every robot not disabled by an operator is at its goal (a robot held by a fault
        has not arrived: it still takes part, and waits for someone to clear the fault)."""
        run = self.engine.run
        return all(run.out[r] == "disabled" or run.finished_robot(r) for r in range(run.num_robots))

    def stuck(self) -> bool:
        """Running, not everyone arrived, and nothing can happen without an operator."""
        run = self.engine.run
        return (self.run_state == "running" and not self.engine.paused and not self.all_arrived()
                and not run.moving and not self.driver.moving and not self.replanner.busy
                and not any(s.hold == "recover" or not s.link_up for s in self.driver.slots))

    def _cannot_go_on(self, now: float) -> Optional[str]:
        """Why an unattended run (--until-done) cannot finish, once that has lasted a while."""
        if not self.stuck():
            self._stalled_since = None
            return None
        if self._stalled_since is None:
            self._stalled_since = now
            return None
        if now - self._stalled_since < _STALL_GRACE:
            return None
        blocked = self.engine.blocked_by()
        parts = []
        for agent, waiting in sorted(blocked.items()):
            slot = self.driver.slots[agent]
            why = self.engine.run.out[agent]
            parts.append("robot {} is {}{}{}".format(
                slot.robot_id, "held by a fault" if why == "failed" else "disabled",
                " ({})".format(slot.hold_reason) if slot.hold_reason else "",
                "; {} for it".format(_robots_wait([self.driver.slots[a].robot_id for a in waiting]))
                if waiting else ""))
        return "the run cannot go on without an operator: " + ("; ".join(parts) or "nothing can move")

    # ---- consoles ---------------------------------------------------------------------------

    def _console_frames(self) -> None:
        for peer, data in self.consoles.receive():
            try:
                self._console_frame(peer, data)
            except Exception:  # one bad request must not take the fleet down
                self.log.exception("console %r: request failed", peer[:16])

    def _console_frame(self, peer: bytes, data: bytes) -> None:
        intake = self.desk.receive(peer, data, self.clock())
        self._send(intake.out)
        if intake.refusal is not None:
            self.log.warning("console %s%r: %s", intake.refusal.name + " " if intake.refusal.name else "",
                             peer[:16], intake.refusal.reason)
        if intake.joined is not None:
            self._send(self.desk.to(intake.joined, self.scene()))
            pending = self.replanner.pending if self.replanner.proposal_id is not None else None
            if pending is not None:
                self._send(self.desk.to(intake.joined, self._proposal_message(pending)))
            self._send(self.desk.to(intake.joined, build_state(self, self.now(), self._seq)))
        if intake.request is not None:
            console = self.desk.consoles.get(peer)
            name = console.name if console is not None else "?"
            ok, reason = self.steering.apply(intake.request.action, intake.args, name)
            self.note("operator", console=name, action=intake.request.action, args=intake.args,
                      ok=ok, reason=reason)
            if ok:
                self.tell("operator", None, "{}: {}{}".format(name, intake.request.action,
                                                               " " + reason if reason else ""))
            self._send(self.desk.answer(peer, intake.request, ok, reason))
            self._publish(self.now())

    def _send(self, out: List) -> None:
        for peer, data in out:
            self.consoles.send(peer, data)

    def scene(self) -> Scene:
        rows = tuple("".join("." if self.grid.free[y, x] else "@" for x in range(self.grid.width))
                     for y in range(self.grid.height - 1, -1, -1))
        robots = tuple(RobotInfo(r.id, r.colour, r.vicon_name) for r in self.robots)
        from fleet_common.execution import STRATEGIES
        return Scene(self.grid.name or "map", rows, robots, self._plan_data(self.plan_id, self.plan),
                     tuple(STRATEGIES), self.step_time)

    def _plan_data(self, plan_id: int, plan: Plan) -> PlanData:
        return PlanData(plan_id, tuple(r.id for r in self.robots), plan.positions, self.loaded.name)

    # ---- replanning and switching plans ---------------------------------------------------

    def _replan_progress(self, message: str) -> None:
        self.tell("plan", None, message)
        pending = self.replanner.pending
        if self.replanner.proposal_id is not None and pending is not None:
            self.desk.bump("replan {} proposed".format(pending.id))
            self._send(self.desk.broadcast(self._proposal_message(pending), self.clock()))
        elif not self.replanner.busy:
            self.desk.bump(message)
            if self.replanner.was_running:
                self.steering.resume()

    def _proposal_message(self, pending) -> Proposal:
        plan = pending.result.plan
        unreachable = tuple(self.driver.slots[a].robot_id for a in sorted(pending.result.unreachable))
        return Proposal(pending.id, self._plan_data(pending.id + 1000, plan), pending.result.message,
                        int(plan.soc), int(plan.makespan), unreachable)

    def switch_plan(self, plan: Plan, reason: str) -> None:
        """Run `plan` from now on (a safe point: nobody mid-move), keeping who is out."""
        old = self.engine
        self.plan_id += 1
        self.plan = plan
        engine = self._new_engine(plan)
        now = self.now()
        for agent, why in enumerate(old.run.out):
            if why is not None:
                engine.handle((Disabled if why == "disabled" else RobotFailed)(agent, now))
        self.engine = engine
        self.driver = self._new_driver(engine, self.driver)
        name = plan_file(self.plan_id)
        starts = [tuple(int(v) for v in c) for c in plan.positions[0]]
        if self.runlog is not None:
            sol = make_solution(self.grid, self.loaded.solution.map_file or "", plan, starts,
                                [tuple(int(v) for v in c) for c in plan.positions[-1]],
                                "fleetcontrol-replan", True, 0)
            sol.orientation = self.loaded.solution.orientation
            self.runlog.write_text(name, format_solution(sol))
        self.note("plan", file=name, robots=[r.id for r in self.robots], reason=reason,
                  at=None, actions=self._action_counts(plan), starts=[list(c) for c in starts])
        self.desk.bump("plan {} ({})".format(self.plan_id, reason))
        self._send(self.desk.broadcast(self.scene(), self.clock()))

    @property
    def map_dirs(self) -> List[Path]:
        return self.settings.map_dirs

    def start_new_run(self, loaded: LoadedPlan) -> None:
        """Another plan (the operator's `load`): a new run, in a new run folder, waiting for Start."""
        self.note("end", reason="another plan was loaded", arrived=len(self.summary().arrived),
                  robots=len(self.robots), summary=self.summary().as_dict())
        if self.runlog is not None:
            self.runlog.close()
            self.runlog = None
        self.loaded, self.grid, self.goals, self.plan = loaded, loaded.grid, list(loaded.goals), loaded.plan
        self.summary_builder = SummaryBuilder()
        self.started_at = None
        self._open_log(loaded)
        self.plan_id += 1
        old_out = self.engine.run.out
        self.engine = self._new_engine(self.plan)
        now = self.now()
        for agent, why in enumerate(old_out):
            if why == "disabled":  # the operator's choice outlives the plan
                self.engine.handle(Disabled(agent, now))
        self.driver = self._new_driver(self.engine, self.driver)
        self.driver.trace = []
        self.run_state, self.run_reason = "", ""
        self.set_state("waiting", "{} loaded; waiting for Start".format(loaded.name))
        self._send(self.desk.broadcast(self.scene(), self.clock()))

    # ---- the end --------------------------------------------------------------------------

    def summary(self) -> RunSummary:
        return self.summary_builder.summary()

    def stop_robots(self) -> None:
        """Tell every connected robot to stop now, and give the messages a moment to leave."""
        for link in self.links.links.values():
            if link.state == "up":
                link.stop()
        end = self.clock() + 0.3
        while self.clock() < end:
            self.links.poll(0.05)

    def close(self, reason: str) -> None:
        summary = self.summary()
        self.note("end", reason=reason, arrived=len(summary.arrived), robots=summary.robots,
                  summary=summary.as_dict())
        self._send(self.desk.broadcast(Event(self._event_seq + 1, round(self.now(), 3), "run", None,
                                             "manager stopping: " + reason), self.clock()))
        # consoles learn at once that this manager is gone (not after 3.5 s of silence)
        self._send(self.desk.broadcast(Bye("manager stopping: " + reason), self.clock()))
        if self.runlog is not None:
            self.runlog.close()
        self._close_sockets()

    def _close_sockets(self) -> None:
        for name in ("links", "consoles", "vicon"):
            part = getattr(self, name, None)
            if part is not None:
                part.close()
        zap = getattr(self, "zap", None)
        if zap is not None:
            zap.socket.close(linger=0)
        self.context.destroy(linger=200)
