"""The manager's run core wired to robots and consoles in memory, on a fake clock (no sockets).

As h11 tests a connection by wiring two of them together, `MemoryFleet` wires
a `RunCore` to one robot per definition, each the robot's own command
executor (`fleet_common.wire.CommandExecutor`) driving the virtual fleet's
kinematics (`virtual_fleet.kinematics.VirtualNavigator`), and to consoles
that speak the console protocol's bytes. Time moves only when a test says so
(`advance`), and everything the core asks for happens at once: commands reach
their robot, replies and poses come back at the next tick, planning jobs and
looks for a reroute are run in place (a look by the function the manager's
worker runs). The manager may die (`kill_manager`: the robots go on, what
they answer is lost) and another take over from the records it left
(`resume_manager`), as `fleetctl manager --resume` does from a run folder.
With a `MemoryVicon`, Vicon sees the robots from outside too, as the manager's
stream does (`vicon`: frames of their true poses, late, some lost).
"""
from __future__ import annotations

import math
import random
from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Deque, Dict, List, Optional, Sequence, Set, Tuple

from fleet_common.errors import FleetError
from fleet_common.control import codec
from fleet_common.limits import MAX_MANAGER_BYTES
from fleet_common.control import messages as m
from fleet_common.plan import Plan
from fleet_common.planning.replan import replan
from fleet_common.robots import RobotDefinition
from fleet_common.vicon.base_grid import ViconFix
from fleet_common.wire import CommandExecutor, Completed, Failed, Pose, PoseFeedback, Status
from fleet_common.wire.link_events import OUTCOME_UNKNOWN, LinkDown, LinkUp, RobotReply
from pathlib import Path

from fleet_common.runlog.reader import RunFolder
from fleet_manager.core import RunCore
from fleet_manager.resume import read_resume
from fleet_manager.outbox import (LoadJob, NewRunFolder, PlanJob, Record, RerouteJob, ResumeRunFolder, Say, Send,
                                  ToConsole, WriteFile)
from fleet_manager.plan_requests import solve_requested
from fleet_manager.rerouting import look
from fleet_common.plan_loading import LoadedPlan
from fleet_manager.settings import ManagerSettings
from virtual_fleet.kinematics import VirtualNavigator

EPOCH = "memory"


class FakeClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class MemoryRobot:
    """One robot: its executor and kinematics; `up` while its link is."""

    def __init__(self, robot_id: int, pose: Pose, clock: FakeClock, speed: float, turn_speed: float) -> None:
        self.id = robot_id
        self.navigator = VirtualNavigator(pose, speed=speed, turn_speed=turn_speed, clock=clock)
        self.executor = CommandExecutor(self.navigator)
        self.session = "s1"
        self.up = False
        self.seq = 0
        self.commands: List[object] = []  # everything it was sent while up, in order
        #: ids its manager's connection sent: a reply to anything else would be refused on the
        #: wire ("not in flight"), so it is not delivered (a new manager sends again what it needs)
        self.sent_ids: Set[int] = set()
        #: sent while its link was down: they go out when it is up again (as a robot link's do)
        self.queued: List[object] = []
        #: ids delivered and not settled (no Completed, Failed or Status yet) -> the session they
        #: reached: a robot restarted since never answers them (its link says so, `link_up`)
        self.unsettled: Dict[int, str] = {}

    def restart(self) -> None:
        """A new process where the robot stands: an empty command memory, a new session."""
        self.executor = CommandExecutor(self.navigator)
        self.session = "s{}".format(int(self.session[1:]) + 1)

    def settled(self, reply: object) -> None:
        if isinstance(reply, (Completed, Failed, Status)):
            self.unsettled.pop(reply.id, None)


class MemoryVicon:
    """Vicon Tracker as the manager's stream gives it (`ViconProvider.handle_readable`): every
    `period` s a frame with each robot's true pose, heard a `latency` later (drawn per frame, in
    order, as over one UDP path); a frame is lost now and then (`drops`), and a robot occluded
    (`occlude`) is in no frame. Its draws are its own (`rng`): a fleet's other draws stay."""

    def __init__(self, rng: random.Random, period: float = 0.01, latency: Tuple[float, float] = (0.005, 0.03),
                 drops: float = 0.03) -> None:
        self.rng = rng
        self.period = period
        self.latency = latency
        self.drops = drops
        self.next_frame = 0.0
        self.frame = 0
        self.occluded: Dict[int, float] = {}  # robot id -> until when no frame has it
        self.in_flight: Deque[Tuple[float, List[ViconFix]]] = deque()  # (heard at, the frame's robots)

    def occlude(self, robot_id: int, until: float) -> None:
        self.occluded[robot_id] = max(until, self.occluded.get(robot_id, until))

    def next_event(self) -> float:
        """When a frame is next taken or heard."""
        return min(self.next_frame, self.in_flight[0][0] if self.in_flight else float("inf"))

    def take_frame(self, robots: Dict[int, "MemoryRobot"], names: Dict[int, str], now: float) -> None:
        """A frame of the robots not occluded, where they really are (taken `now`)."""
        self.frame += 1
        self.next_frame = now + self.period
        if self.rng.random() < self.drops:
            return
        fixes = [ViconFix(names[rid], r.navigator.true_pose(), self.frame, 0.0, False, rid)
                 for rid, r in robots.items() if self.occluded.get(rid, -1.0) <= now]
        heard = now + self.rng.uniform(*self.latency)
        if self.in_flight:  # one path: a frame never overtakes the one before it
            heard = max(heard, self.in_flight[-1][0])
        self.in_flight.append((heard, fixes))

    def heard(self, now: float) -> List[ViconFix]:
        """The frames heard by `now`: each robot's latest fix in them (as a read of the socket)."""
        latest: Dict[int, ViconFix] = {}
        while self.in_flight and self.in_flight[0][0] <= now + 1e-9:
            for fix in self.in_flight.popleft()[1]:
                latest[fix.robot_id] = fix  # type: ignore[index]
        return list(latest.values())


@dataclass
class MemoryConsole:
    """A console: what it received, decoded; what it asked and the answers."""

    peer: bytes
    name: str
    received: List[object] = field(default_factory=list)
    next_id: int = 1
    last_sent: float = 0.0

    @property
    def states(self) -> List[m.State]:
        return [x for x in self.received if isinstance(x, m.State)]

    @property
    def state(self) -> Optional[m.State]:
        states = self.states
        return states[-1] if states else None

    @property
    def version(self) -> int:
        versioned = [x.version for x in self.received if isinstance(x, (m.State, m.Answer, m.Welcome))]
        return max(versioned, default=0)

    def answers(self) -> List[m.Answer]:
        return [x for x in self.received if isinstance(x, m.Answer)]

    def notices(self) -> List[m.Notice]:
        return [x for x in self.received if isinstance(x, m.Notice)]


class MemoryFleet:
    def __init__(self, loaded: LoadedPlan, definitions: Sequence[RobotDefinition],
                 settings: Optional[ManagerSettings] = None, poses: Optional[Dict[int, Pose]] = None,
                 speed: float = 2.0, turn_speed: float = 6.0, pose_lag: float = 0.0,
                 vicon: Optional[MemoryVicon] = None) -> None:
        self.clock = FakeClock()
        self.settings = settings or ManagerSettings(step_time=0.5)
        self.loaded = loaded
        self.definitions = list(definitions)
        #: Vicon's stream, if the manager reads one (as `--vicon PORT`: the core's ViconWatch)
        self.vicon = vicon
        self._vicon_names = {d.id: d.vicon_name for d in definitions}
        self.core: Optional[RunCore] = RunCore(loaded, definitions, self.settings, "session-1", 0.0,
                                               vicon=vicon is not None)
        starts = loaded.starts
        self.robots: Dict[int, MemoryRobot] = {}
        for i, d in enumerate(definitions):
            pose = (poses or {}).get(d.id, Pose(float(starts[i][0]), float(starts[i][1]), 0.0))
            self.robots[d.id] = MemoryRobot(d.id, pose, self.clock, speed, turn_speed)
        self.consoles: Dict[bytes, MemoryConsole] = {}
        self.records: List[Tuple[str, float, dict]] = []
        #: each run folder's records (a reset or Go to starts opens a new one); the one written to
        self.folder_records: List[List[Tuple[str, float, dict]]] = []
        #: each run folder's first plan, and the plan it runs or drives the robots to the starts of
        self.folder_plans: List[Plan] = []
        self.folder_targets: List[LoadedPlan] = []
        self._folder = -1
        self._resumed = -1  # the folder a resumed manager goes on writing to
        self.files: Dict[str, str] = {}
        self.replans: Dict[str, object] = {}  # plan-N.txt -> the plan it holds
        self.said: List[str] = []
        self._replies: List[RobotReply] = []
        self.solve: Callable[[PlanJob], object] = lambda job: replan(
            job.grid, job.current, job.goals, job.out, deadline=job.time_limit, method=job.method)
        self.hold_plans = False  # keep planning jobs until `finish_plans` (a replan under way)
        self.jobs: List[PlanJob] = []
        self.hold_looks = False  # keep looks for a reroute until `finish_looks`
        self.looks: List[RerouteJob] = []
        self.hold_loads = False  # keep instances to load until `finish_loads` (a solve under way)
        self.loads: List[LoadJob] = []
        #: poses reach the manager this late (a slow network, a busy robot): (t, feedback) queued
        self.pose_lag = pose_lag
        self._poses: List[Tuple[float, PoseFeedback]] = []
        #: the closest two robots really came, at any step or Vicon frame: (cells, id, id, time)
        self.closest: Optional[Tuple[float, int, int, float]] = None
        #: called after each batch of the core's effects is carried out (its records written)
        self.after_batch: Optional[Callable[[], None]] = None
        self.pump()

    @property
    def folders(self) -> int:
        """Run folders opened so far."""
        return len(self.folder_records)

    @property
    def now(self) -> float:
        return self.clock.t

    # ---- wiring ---------------------------------------------------------------------------

    def kill_manager(self) -> None:
        """The manager dies (SIGKILL): no goodbye; the robots go on with what they run, and
        what they answer reaches nobody."""
        self.pump()
        self.core = None  # type: ignore[assignment]
        self._replies.clear()
        # the poses on their way reach no socket either: a new manager hears only what the robots
        # send once it is there (wide Vicon `faults` 256: a pose from before the death, heard late,
        # had a robot that drove on while no manager ran back where it had been)
        self._poses.clear()
        if self.vicon is not None:  # its datagrams reach no socket
            self.vicon.in_flight.clear()
        for robot in self.robots.values():
            robot.up = False
        self.consoles.clear()

    def resume_manager(self, settings: Optional[ManagerSettings] = None,
                       up: Optional[Sequence[int]] = None) -> None:
        """A new manager on the records the dead one left (its run folder), at the same time;
        robots connect at once (those of `up`, if given: the others later, `link_up`)."""
        # as `fleetctl manager --resume` alone: the newest folder of a run of the plan, or of a way
        # to its starts (the new manager drives it on, the plan waiting for Start after it)
        runs = [k for k, folder in enumerate(self.folder_records)
                if folder and folder[0][0] == "run" and self.folder_targets[k].name == self.loaded.name]
        self._resumed = runs[-1] if runs else 0
        records = [dict(fields, k=kind, t=t) for kind, t, fields in self.folder_records[self._resumed]]
        records[0].setdefault("started", None)
        point = read_resume(RunFolder(Path("memory-run"), records, torn=False))
        plan = self.folder_plans[self._resumed] if point.plan == "plan-1.txt" else self.replans[point.plan]
        self.core = RunCore(self.folder_targets[self._resumed], self.definitions, settings or self.settings,
                            "session-2", self.now, vicon=self.vicon is not None, resume=(point, plan))
        for robot in self.robots.values():  # new links come up; the commands sent again reach them
            robot.sent_ids.clear()
            robot.unsettled.clear()  # (the dead manager's link was waiting for those)
            robot.queued.clear()  # the dead manager's
            if up is None or robot.id in up:
                robot.up = True
                self.core.link_event(LinkUp(robot.id, robot.session, False), self.now)
        self.pump()
        self.feedback()
        self.pump()

    def pump(self) -> None:
        """Carry out what the core asked for, until it asks for nothing more."""
        if self.core is None:
            return
        while True:
            effects = self.core.take()
            if not effects and not self._replies:
                return
            for effect in effects:
                self._carry_out(effect)
            if self.after_batch is not None:  # the records of a batch are what a killed manager leaves
                self.after_batch()
            replies, self._replies = self._replies, []
            for reply in replies:
                self.core.link_event(reply, self.now)

    def _carry_out(self, effect: object) -> None:
        if isinstance(effect, Send):
            robot = self.robots[effect.robot]
            if robot.up:
                self._deliver(robot, effect.command)
            else:
                robot.queued.append(effect.command)
        elif isinstance(effect, Record):
            self.records.append((effect.kind, effect.t, effect.fields))
            if self._folder >= 0:
                self.folder_records[self._folder].append((effect.kind, effect.t, effect.fields))
        elif isinstance(effect, ToConsole):
            console = self.consoles.get(effect.peer)
            if console is not None:
                console.received.append(codec.decode(effect.data, m.MANAGER_MESSAGES,
                                                     MAX_MANAGER_BYTES))
        elif isinstance(effect, Say):
            self.said.append(effect.text)
        elif isinstance(effect, PlanJob):
            self.jobs.append(effect)
            if not self.hold_plans:
                self.finish_plans()
        elif isinstance(effect, RerouteJob):
            self.looks.append(effect)
            if not self.hold_looks:
                self.finish_looks()
        elif isinstance(effect, LoadJob):
            self.loads.append(effect)
            if not self.hold_loads:
                self.finish_loads()
        elif isinstance(effect, NewRunFolder):
            self.folder_records.append([])
            self.folder_plans.append(self.core.run.plan)
            self.folder_targets.append(self.core.run.target)
            self._folder = len(self.folder_records) - 1
        elif isinstance(effect, ResumeRunFolder):
            self._folder = self._resumed
        elif isinstance(effect, WriteFile):
            self.files[effect.name] = effect.text
            self.replans[effect.name] = self.core.run.plan

    def _deliver(self, robot: MemoryRobot, command: object) -> None:
        robot.commands.append(command)
        robot.sent_ids.add(command.id)  # type: ignore[attr-defined]
        robot.unsettled[command.id] = robot.session  # type: ignore[attr-defined]
        for _, reply in robot.executor.handle(EPOCH, command):  # type: ignore[arg-type]
            robot.settled(reply)
            self._replies.append(RobotReply(robot.id, reply))

    def finish_plans(self) -> None:
        jobs, self.jobs = self.jobs, []
        for job in jobs:
            self.core.plan_ready(job.id, self.solve(job), None, self.now)

    def finish_looks(self) -> None:
        """The looks for a reroute asked for, each run by the function the manager's worker runs."""
        looks, self.looks = self.looks, []
        for job in looks:
            self.core.reroute_ready(job.id, look(job), None, self.now)

    def finish_loads(self) -> None:
        """The instances asked to be loaded, each solved by the function the manager's worker runs."""
        loads, self.loads = self.loads, []
        for job in loads:
            try:
                loaded, error = solve_requested(job.requested), None
            except FleetError as err:  # as the manager's worker says it
                loaded, error = None, "{}: {}".format(type(err).__name__, err)
            self.core.load_ready(job.id, loaded, error, self.now)

    def link_up(self, robot_id: Optional[int] = None, restarted: bool = False) -> None:
        """The link comes (back) up; `restarted`: to a robot that restarted (`power_cut`) since,
        whose link then fails what the old process never answered, as the robot link does."""
        for robot in self._chosen(robot_id):
            robot.up = True
            if restarted:  # the link subscribes afresh: the old process's poses on their way are lost
                self._poses = [(t, p) for t, p in self._poses if p.robot_id != robot.id]
            queued, robot.queued = robot.queued, []
            for command in queued:
                self._deliver(robot, command)
            self.core.link_event(LinkUp(robot.id, robot.session, restarted), self.now)
            for cid, session in list(robot.unsettled.items()):
                if session != robot.session:  # (replies are handed to the core after the LinkUp)
                    del robot.unsettled[cid]
                    self._replies.append(RobotReply(robot.id, Failed(cid, "robot {} restarted while command {} "
                                                                          "was in flight; {}".format(
                                                                              robot.id, cid, OUTCOME_UNKNOWN))))
        self.feedback()
        self.pump()

    def power_cut(self, robot_id: int) -> None:
        """Robot `robot_id` alone loses power: it stops where it stands, its link drops, and it
        comes back (`link_up(robot_id, restarted=True)`) a new process that remembers nothing."""
        robot = self.robots[robot_id]
        robot.navigator.halt()
        robot.restart()
        self.link_down(robot_id, "silent for 3.5 s")

    def link_down(self, robot_id: int, reason: str = "silent for 3.5 s") -> None:
        self.robots[robot_id].up = False
        self.core.link_event(LinkDown(robot_id, reason), self.now)
        self.pump()

    def feedback(self) -> None:
        """Every robot whose link is up reports its pose (heard `pose_lag` later)."""
        for robot in self.robots.values():
            if robot.up:
                robot.seq += 1
                self._poses.append((self.now, PoseFeedback(robot.id, robot.seq, robot.navigator.pose(),
                                                           robot.executor.current, robot.navigator.faults(),
                                                           robot.executor.ended)))
        due = [p for t, p in self._poses if t <= self.now - self.pose_lag + 1e-9]
        self._poses = [(t, p) for t, p in self._poses if t > self.now - self.pose_lag + 1e-9]
        for pose in due:
            self.core.link_event(pose, self.now)

    def _chosen(self, robot_id: Optional[int]) -> List[MemoryRobot]:
        return list(self.robots.values()) if robot_id is None else [self.robots[robot_id]]

    # ---- time -----------------------------------------------------------------------------

    def advance(self, seconds: float, step: float = 0.05) -> None:
        """Let `seconds` pass: robots move and report, the core does what is due."""
        end = self.now + seconds
        while self.now < end - 1e-9:
            self._vicon_until(min(end, self.now + step))
            self.clock.t = min(end, self.now + step)
            self._poll_robots()
            if self.core is None:
                continue
            self.pump()
            self.feedback()
            for console in self.consoles.values():  # a live console's heartbeat
                if self.now - console.last_sent >= 1.0:
                    self._frame(console, m.Heartbeat())
            self.core.tick(self.now)
            self.core.log_poses(self.now)
            self.core.publish(self.now)
            self.pump()

    def _poll_robots(self) -> None:
        """The robots' replies so far; and how close two of them really came (`closest`)."""
        for robot in self.robots.values():  # (a robot's motion goes on unpolled: it keeps time)
            if robot.up:
                for _, reply in robot.executor.poll():
                    if reply.id in robot.sent_ids:
                        robot.settled(reply)
                        self._replies.append(RobotReply(robot.id, reply))
        truth = [(rid, r.navigator.true_pose()) for rid, r in self.robots.items()]
        for i, (a, p) in enumerate(truth):
            for b, q in truth[i + 1:]:
                d = math.hypot(p.x - q.x, p.y - q.y)
                if self.closest is None or d < self.closest[0]:
                    self.closest = (d, a, b, self.now)

    def _vicon_until(self, t: float) -> None:
        """Vicon's frames taken and heard before `t`, each at its own time (a hundred a second,
        between the fleet's steps): the manager's loop reads Vicon's socket as soon as it is
        readable. The robots are polled first, so a bumper stops a robot where Vicon sees it."""
        vicon = self.vicon
        if vicon is None:
            return
        while vicon.next_event() < t - 1e-9:
            self.clock.t = max(self.now, vicon.next_event())
            self._poll_robots()
            if vicon.next_frame <= self.now + 1e-9:
                vicon.take_frame(self.robots, self._vicon_names, self.now)
            fixes = vicon.heard(self.now)
            if self.core is not None:
                if fixes:
                    self.core.vicon(fixes, self.now)
                self.pump()

    def run_until(self, condition: Callable[[], bool], limit: float = 120.0) -> bool:
        """Advance until `condition()` (True) or `limit` seconds have passed (False)."""
        end = self.now + limit
        while not condition():
            if self.now >= end:
                return False
            self.advance(0.1)
        return True

    # ---- consoles -------------------------------------------------------------------------

    def console(self, name: str = "ops") -> MemoryConsole:
        peer = "console-{}".format(len(self.consoles) + 1).encode()
        console = self.consoles[peer] = MemoryConsole(peer, name)
        self._frame(console, m.Hello(name))
        return console

    def ask(self, console: MemoryConsole, action: str, based_on: Optional[int] = None,
            **args: object) -> m.Answer:
        """`console` asks for `action`; the manager's answer."""
        request = m.Request(console.next_id, action, dict(args),
                            console.version if based_on is None else based_on)
        console.next_id += 1
        self._frame(console, request)
        return next(a for a in reversed(console.answers()) if a.id == request.id)

    def _frame(self, console: MemoryConsole, message: object) -> None:
        console.last_sent = self.now
        self.core.console_frame(console.peer, codec.encode(message), self.now)
        self.pump()

    # ---- what happened --------------------------------------------------------------------

    def kinds(self, kind: str) -> List[dict]:
        return [fields for k, _, fields in self.records if k == kind]

    def sent(self, robot_id: int, kind: str) -> List[object]:
        return [c for c in self.robots[robot_id].commands if getattr(c, "TYPE", "") == kind]

    @property
    def phase(self) -> str:
        return self.core.run.phase.phase

    def at_goals(self) -> bool:
        goals = self.core.run.loaded.goals
        return all(abs(r.navigator.true_pose().x - g[0]) < 1e-6 and abs(r.navigator.true_pose().y - g[1]) < 1e-6
                   for r, g in zip(self.robots.values(), goals))


def lab_fleet(n: int = 5) -> List[RobotDefinition]:
    colours = ["red", "green", "blue", "orange", "purple", "cyan", "magenta", "yellow"]
    return [RobotDefinition(i + 1, "127.0.0.1", 9000 + i, "u", "tb{}".format(i + 1), colours[i % len(colours)])
            for i in range(n)]
