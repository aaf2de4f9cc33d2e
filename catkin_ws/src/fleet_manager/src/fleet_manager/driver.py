"""The engine driver: engine decisions become robot commands, robot replies become engine events.

Theory of operation. The execution engine (fleet_common.execution) decides
which plan action each robot may start; the robots speak the wire protocol
(`turn`, `drive`, `stop`, `get_status`). The driver joins them, one robot at
a time, with one motion command in flight per robot (robots run one command
at a time):

- a dispatched action waits in the robot's queue; when the robot is free it
  is sent a `turn` to face the action's cell if it does not face it, then a
  `drive` to the cell's centre;
- while a robot waits for its next action (a cell not free yet, the step
  barrier), it turns towards it already, in place: it holds its own cell, so
  that is safe, and the move is quicker once allowed;
- the robot's `Accepted` of a drive is the engine's `ActionStarted`, its
  `Completed` the engine's `ActionCompleted` (which may dispatch more); a
  strategy that decides by the plan's clock gets its `Tick` (`tick`);
- a drive or turn that fails because the robot has a fault (bumper) makes the
  robot `RobotFailed` in the engine: it is held, with both cells of a move it
  stopped in, and its dependents wait; when the operator enables it again it
  is sent `stop` (which clears the fault once the bumper is free) and the same
  action again, from wherever it stands;
- a link that drops holds that robot (nothing new is sent) and, through the
  dependency graph, only the robots that need its cells; when the link comes
  back with the same robot process, replies resume as if nothing happened
  (the link resends unsettled command ids, the robot never runs one twice);
  when the robot restarted, the command in flight comes back as failed with
  its outcome unknown, and the driver asks the robot where it is: at the
  action's target cell the action counts as completed, anywhere else the
  same action is sent again (a new command id). No move is run twice or
  skipped.

Followers (robots smaller than a cell, `following.py`): a drive into a cell
another robot is still leaving carries a hold point, moved on by a `Release` at
each pose of the leader and lifted when the leader's move completes.

The driver owns no socket and reads no clock: `now` comes with each call, and
commands go out as values through the `Outbox` (the manager's loop hands them
to the robots' links), with the run log's records and the consoles' lines.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Callable, Optional, Sequence

from fleet_common.angles import heading, wrap_angle
from fleet_common.execution import (ActionCompleted, ActionStarted, Dispatch, Enabled, Engine,
                                    EventError, Pass, RobotFailed, Thaw, Tick)
from fleet_common.execution.handover import renumbered
from fleet_common.grid import Coord
from fleet_common.wire.link_events import OUTCOME_UNKNOWN
from fleet_common.wire import (Accepted, Completed, DriveToPosition, Failed, GetStatus, Release, Status, Stop,
                               Turn)

from .following import Following
from .outbox import Outbox
from .rerouting import held_cell
from .robot import FAULT, HALTED, RECOVER, InFlight, Robot, Seen

__all__ = ["Driver", "TURN_TOLERANCE", "AT_CELL", "MADE_IT"]

#: A robot facing its next cell within this angle (radians) drives without a turn first.
TURN_TOLERANCE = math.radians(20.0)
#: A robot this close (cells) to a cell's centre is on that cell (start checks, planning).
AT_CELL = 0.3
#: A restarted robot this close to its move's target has made the move; farther, it is sent
#: the move again (a few centimetres: a robot's own arrival tolerance).
MADE_IT = 0.05


class Driver:
    """Drives `engine`'s plan through `robots` (one per plan agent, in order)."""

    def __init__(self, engine: Engine, robots: Sequence[Robot], out: Outbox, following: Following,
                 preturn: bool = True, show: Callable[[Coord], Coord] = lambda c: c) -> None:
        if len(robots) != engine.run.num_agents:
            raise ValueError("{} robots for a plan of {} agents".format(len(robots), engine.run.num_agents))
        self.engine = engine
        self.robots = list(robots)
        self.out = out
        self.following = following
        self.preturn = preturn
        #: followers' hold points move on (False while a resumed run checks its robots)
        self.releasing = True
        self.show = show  # base cell -> the plan file's coordinates, for messages
        self._next_tick: Optional[float] = None  # when the strategy's next `Tick` is due

    def tick(self, now: float) -> None:
        """Send the strategy its `Tick` as often as it asks (`Engine.tick_every`, plan steps)
        while the run runs: re-ordering lets a robot pass one that stands still as time passes."""
        every = self.engine.tick_every
        if every <= 0:
            self._next_tick = None
        elif self._next_tick is None:
            self._next_tick = now + every * self.engine.run.clock.step_time
        elif now >= self._next_tick:
            self._next_tick = now + every * self.engine.run.clock.step_time
            self.handle(Tick(now), now)

    # ---- the engine's side ---------------------------------------------------------------

    def handle(self, event: object, now: float) -> None:
        """Give the engine `event` (a control or progress event) and act on what it decides."""
        run = self.engine.run
        waits, forced = self.engine.metrics.last_wait, self.engine.metrics.last_forced
        waits.clear()
        forced.clear()
        passes = len(run.passes)
        dispatches = self.engine.handle(event)
        if len(run.passes) > passes:
            self._passed(run.passes[passes:])
        released = getattr(event, "agent", None) if isinstance(event, (ActionCompleted, Enabled)) else None
        self._queue(dispatches, released, "reroute" if isinstance(event, Thaw) else None)
        if isinstance(event, (ActionStarted, ActionCompleted, RobotFailed, Tick)):
            # progress frees only the robots dispatched now (and the robot itself, for its next turn)
            targets: Sequence[int] = sorted({d.agent for d in dispatches} | (
                {event.agent} if isinstance(event, ActionCompleted) else set()))
        else:  # control (resume, step, switch, enable): anyone may start or turn now
            targets = range(run.num_agents)
        for agent in targets:
            self.pump(self.robots[agent], now)

    def _queue(self, dispatches: Sequence[Dispatch], released: Optional[int], cause: Optional[str] = None) -> None:
        """The engine's decisions into the robots' queues (and the run log; `cause` "reroute": the
        rerouting ended their waits, not the operator)."""
        waits, forced = self.engine.metrics.last_wait, self.engine.metrics.last_forced
        for d in dispatches:
            robot = self.robots[d.agent]
            robot.queue.append(d)
            waited = waits.pop(d.agent, 0.0)  # a robot sent two actions at once waited once
            self.out.record("dispatch", robot=robot.id, index=d.index, step=d.step, src=d.src,
                            dst=d.dst, waited=round(waited, 3), forced=round(forced.pop(d.agent, 0.0), 3),
                            released_by=None if released is None else self.robots[released].id,
                            **({} if cause is None else {"cause": cause}))

    def hand_over(self, engine: Engine, base: Sequence[int], dispatches: Sequence[Dispatch],
                  now: float) -> None:
        """Go on with `engine`, a reroute's (`handover`), whose plan starts robot r with its move
        `base[r]` of the old plan: what the robots were sent is renumbered (nothing is sent
        again), the followers keep their leaders, then the engine's decisions now."""
        self.engine = engine
        self.following.engine = engine
        run = engine.run
        for robot in self.robots:
            robot.queue = deque(renumbered(engine, base, d) for d in robot.queue)
            flight = robot.flight
            if flight is not None and flight.index is not None:
                shifted = flight.index - base[robot.agent]
                # a turn towards an old plan's move beyond the new plan's is a turn for nothing
                flight.index = shifted if 0 <= shifted < run.count(robot.agent) else None
        self._queue(dispatches, None, "reroute")
        for robot in self.robots:
            self.pump(robot, now)

    def _passed(self, passes: Sequence[Pass]) -> None:
        """A re-ordering strategy changed who goes first at cells: record it, tell the operator."""
        table = self.engine.table
        for p in passes:
            robot, other = self.robots[p.agent], self.robots[p.passed]
            cell = table.coord(p.cell)
            run = self.engine.run
            self.out.record("pass", robot=robot.id, passed=other.id, cell=list(cell), taken_back=p.taken_back,
                            index=p.action - run.first[p.agent], passed_index=p.passed_action - run.first[p.passed])
            self.out.tell("pass", robot.id, "robot {} goes before robot {} at {}{}".format(
                robot.id, other.id, cell, " (robot {} gave its move back)".format(other.id) if p.taken_back else ""))

    def pump(self, robot: Robot, now: float) -> None:
        """Send `robot` its next command if it is free to take one."""
        if robot.flight is not None or robot.hold is not None or not robot.link_up:
            return
        agent = robot.agent
        run = self.engine.run
        if robot.queue:
            d = robot.queue[0]
            if run.out[agent] is not None:
                return
            angle = heading(d.src, d.dst)
            if self._needs_turn(robot, angle):
                self._send(robot, "turn", d.index, now, (angle,))
            else:
                self._send(robot, "drive", d.index, now, (float(d.dst[0]), float(d.dst[1])))
            return
        if self.preturn and not self.engine.paused and run.out[agent] is None:
            a = run.next_undispatched(agent)
            if a >= 0 and run.completed[agent] == run.dispatched[agent]:
                table = self.engine.table
                angle = heading(table.coord(run.src[a]), table.coord(run.dst[a]))
                if self._needs_turn(robot, angle):
                    self._send(robot, "turn", a - run.first[agent], now, (angle,))

    def _needs_turn(self, robot: Robot, angle: float) -> bool:
        facing = robot.heading()
        return facing is None or abs(wrap_angle(angle - facing)) > TURN_TOLERANCE

    def _send(self, robot: Robot, kind: str, index: Optional[int], now: float,
              target: Sequence[float]) -> None:
        cid = robot.take_id()
        if kind == "turn":
            self.out.send(robot.id, Turn(cid, float(target[0])))
            self.out.record("command", robot=robot.id, id=cid, type="turn", angle=target[0], action=index)
        elif kind == "drive":
            d = robot.queue[0]
            hold = self.following.hold_for(d)
            self.out.send(robot.id, DriveToPosition(cid, float(target[0]), float(target[1]), 0.0, hold))
            self.following.sent(d, hold)
            self.out.record("command", robot=robot.id, id=cid, type="drive", x=target[0], y=target[1],
                            time=0.0, action=index, **({} if hold is None else {"hold": list(hold)}))
        else:
            self.out.send(robot.id, Stop(cid))
            self.out.record("command", robot=robot.id, id=cid, type="stop", action=None)
        robot.flight = InFlight(cid, kind, index, now, tuple(target))

    # ---- the robots' side ----------------------------------------------------------------

    def link_up(self, robot: Robot, restarted: bool, now: float) -> None:
        self.out.record("link", robot=robot.id, state="up", reason="", restarted=restarted)
        self.out.tell("link", robot.id, "robot {} {}".format(
            robot.id, "is back (restarted)" if restarted else "link up"))
        if restarted:  # a new process has accepted nothing, and its idle poses name no motion until it
            # has ended one: neither those nor its status are older than a motion of the old process
            # (wide dying `faults` 45: a replan waited for ever for a pose that named one; until then
            # a restarted robot's poses all counted, and big wide Vicon `faults` 174 planned from a
            # status taken before the drive it was sent next)
            robot.answered = None
        if robot.hold == RECOVER or restarted:
            self._ask_where(robot)
        self.pump(robot, now)

    def link_down(self, robot: Robot, reason: str, fatal: bool) -> None:
        state = "failed" if fatal else "down"
        self.out.record("link", robot=robot.id, state=state, reason=reason, restarted=False)
        self.out.tell("link", robot.id, "robot {} link {}: {}".format(robot.id, state, reason))

    def faults(self, robot: Robot, faults: Sequence[str]) -> None:
        """The robot's fault list changed (a pose or status said so)."""
        robot.faults = tuple(faults)
        self.out.record("fault", robot=robot.id, faults=list(faults))
        self.out.tell("fault", robot.id, "robot {} {}".format(
            robot.id, "reports " + ", ".join(faults) if faults else "fault cleared"))

    def release_followers(self, leader: Robot) -> None:
        """`leader` moved on (a pose) or completed a move: move its followers' hold points on."""
        if not self.releasing:
            return
        for agent, point in self.following.moved(leader.agent).items():
            robot = self.robots[agent]
            flight, d = robot.flight, robot.queue[0] if robot.queue else None
            if flight is None or flight.kind != "drive" or d is None or flight.index != d.index:
                continue
            x, y = point if point is not None else (float(d.dst[0]), float(d.dst[1]))
            cid = robot.take_id()
            robot.releases.add(cid)
            self.out.send(robot.id, Release(cid, flight.id, float(x), float(y)))

    def reply(self, robot: Robot, reply: object, now: float) -> None:
        if reply.id in robot.releases:  # type: ignore[attr-defined]
            if not isinstance(reply, Accepted):
                robot.releases.discard(reply.id)  # type: ignore[attr-defined]
            return  # a release is done at once: nothing to record, nothing follows from it
        self.out.record("reply", robot=robot.id, id=reply.id, type=reply.TYPE,  # type: ignore[attr-defined]
                        **({"reason": reply.reason} if isinstance(reply, Failed) else {}),
                        **({"duplicate": reply.duplicate} if isinstance(reply, Accepted) else {}))
        if isinstance(reply, Status):
            if reply.id == robot.status_id:
                robot.status_id = None
                robot.own = Seen(reply.pose, now)
                robot.own_current, robot.own_ended = reply.current, robot.answered  # (taken now)
                robot.facing = None
                if tuple(reply.faults) != robot.faults:
                    self.faults(robot, reply.faults)
                if robot.hold == RECOVER:
                    self._recovered(robot, now)
            return
        flight = robot.flight
        if flight is None or reply.id != flight.id:  # type: ignore[attr-defined]
            return  # an outcome of something we stopped caring about (a take-back)
        if flight.kind in ("drive", "turn") and isinstance(reply, Accepted):
            robot.answered = flight.id  # its idle poses from its end on name it (`Robot.pose_settled`)
        if isinstance(reply, Accepted):
            flight.accepted = True
            begun = reply.duplicate and self.engine.run.started[robot.agent] > (flight.index or 0)
            if flight.kind == "drive" and robot.queue and robot.queue[0].index == flight.index and not begun:
                d = robot.queue[0]
                robot.moving_since = flight.sent
                self.out.record("action", robot=robot.id, index=d.index, phase="started",
                                src=d.src, dst=d.dst)
                self._progress(robot, ActionStarted(robot.agent, d.index, now), now)
            return
        robot.flight, robot.ended_at = None, now
        if isinstance(reply, Completed):
            self._completed(robot, flight, now)
        elif isinstance(reply, Failed):
            self._failed(robot, flight, reply.reason, now)

    def _completed(self, robot: Robot, flight: InFlight, now: float) -> None:
        if flight.kind == "turn":
            robot.facing = flight.target[0]
            self.engine.metrics.turned(robot.agent, flight.sent, now)  # own time, but no delay
        elif flight.kind == "drive":
            d = robot.queue.popleft() if robot.queue and robot.queue[0].index == flight.index else None
            if d is not None:
                robot.moving_since = None
                robot.facing = heading(d.src, d.dst)
                self.out.record("action", robot=robot.id, index=d.index, phase="completed",
                                src=d.src, dst=d.dst)
                self._progress(robot, ActionCompleted(robot.agent, d.index, now), now)
                self.release_followers(robot)
                return
        elif flight.kind == "stop" and robot.clear_fault:
            robot.clear_fault = False
        self.pump(robot, now)

    def _failed(self, robot: Robot, flight: InFlight, reason: str, now: float) -> None:
        if OUTCOME_UNKNOWN in reason:
            robot.hold = RECOVER
            robot.hold_reason = reason
            if robot.link_up:
                self._ask_where(robot)
            return
        if flight.kind == "stop":
            self.pump(robot, now)
            return
        if robot.hold == HALTED or reason.startswith("stopped by command"):
            # our own stop (halt): it holds both cells until enabled, then drives on
            robot.hold = None
            self._robot_out(robot, "halted: " + reason, now, hold=HALTED)
            return
        self._robot_out(robot, reason, now, hold=FAULT)

    def hold_out(self, robot: Robot, reason: str, now: float) -> None:
        """Take `robot` out of the run and hold it, as a fault would, until an operator enables
        it (a robot a resumed run found between cells)."""
        self._robot_out(robot, reason, now, hold=FAULT)

    def _robot_out(self, robot: Robot, reason: str, now: float, hold: str) -> None:
        robot.queue.clear()
        robot.moving_since = None
        run = self.engine.run
        disabled = run.out[robot.agent] == "disabled"
        # a robot disabled in the middle of a drive finishes it, unless it fails: the engine
        # takes that move back too (it stays disabled), or it would wait for it for ever
        if run.out[robot.agent] is None or run.started[robot.agent] > run.completed[robot.agent]:
            self._progress(robot, RobotFailed(robot.agent, now), now)
        robot.hold = hold
        robot.hold_reason = reason
        self.out.record("out", robot=robot.id, why="disabled" if disabled else "failed", reason=reason,
                        **({"taken_back": True} if disabled else {}))  # for a manager that resumes
        self.out.tell("fault" if hold == FAULT else "run", robot.id, "robot {} {}: {}".format(
            robot.id, "held" if hold == FAULT else "stopped", reason))

    def _progress(self, robot: Robot, event: object, now: float) -> None:
        try:
            self.handle(event, now)
        except EventError as err:  # a reply the engine cannot place: say so, keep going
            self.out.tell("run", robot.id, "robot {}: ignored {}: {}".format(robot.id, event, err))

    # ---- recovery after a restart --------------------------------------------------------

    def _ask_where(self, robot: Robot) -> None:
        robot.hold = RECOVER
        if robot.status_id is None:
            robot.status_id = robot.take_id()
            self.out.send(robot.id, GetStatus(robot.status_id))

    def _recovered(self, robot: Robot, now: float) -> None:
        """The robot restarted mid-action and said where it is: finish the action or redo it."""
        robot.hold = None
        robot.hold_reason = ""
        pose = robot.own.pose if robot.own is not None else None
        if robot.queue and pose is not None:
            d = robot.queue[0]
            if math.hypot(pose.x - d.dst[0], pose.y - d.dst[1]) <= MADE_IT:
                self.out.tell("link", robot.id, "robot {} restarted at the end of its move to {}: "
                              "counted as done".format(robot.id, self.show(d.dst)))
                if self.engine.run.started[robot.agent] <= d.index:
                    self._progress(robot, ActionStarted(robot.agent, d.index, now), now)
                self._completed(robot, InFlight(-1, "drive", d.index, now, d.dst), now)
                return
            self.out.tell("link", robot.id, "robot {} restarted before reaching {}: {}".format(
                robot.id, self.show(d.dst), "sending the move again" if self.engine.run.out[robot.agent] is None
                else "it is out; the move goes again once it is enabled"))
        self.pump(robot, now)

    # ---- operator actions that need commands ---------------------------------------------

    def halt(self, only: Optional[Sequence[Robot]] = None) -> None:
        """Stop every robot (or those of `only`) where it is, now (the run is paused by the
        caller)."""
        for robot in self.robots if only is None else only:
            if robot.flight is not None and robot.flight.kind in ("drive", "turn"):
                robot.hold = HALTED
                cid = robot.take_id()
                self.out.send(robot.id, Stop(cid))
                self.out.record("command", robot=robot.id, id=cid, type="stop", action=None)

    def enable(self, robot: Robot, now: float) -> None:
        """Take `robot` back into the run (after a fault: clear it with a stop first)."""
        if robot.hold in (FAULT, HALTED):
            if robot.hold == FAULT or robot.faults:
                robot.clear_fault = True
                self._send(robot, "stop", None, now, ())
            robot.hold = None
            robot.hold_reason = ""
        self.handle(Enabled(robot.agent, now), now)

    def take_back(self, agent: int, index: int) -> bool:
        """The engine takes back the robot's actions from `index` on (a re-ordering strategy lets
        another robot pass it): only those not handed to the robot as a drive yet. A turn in
        flight towards the cell is harmless (the robot turns in its own cell)."""
        robot = self.robots[agent]
        flight = robot.flight
        if robot.hold is not None or (flight is not None and flight.kind == "drive" and
                                      flight.index is not None and flight.index >= index):
            return False
        robot.queue = deque(d for d in robot.queue if d.index < index)
        return True

    def drop_pending(self, robot: Robot) -> None:
        """The engine took `robot`'s unsent actions back (disabled): forget them here too. A move
        the robot began stays: a drive in flight finishes, and a move whose outcome the robot lost
        (it restarted: `_recovered`) goes again once it is enabled, since the engine still has it
        under way (in-memory `--faults` 544: disabled while powered off, or by a manager resumed
        after, the robot was enabled to nothing, and the run stood still with no word)."""
        flight = robot.flight
        drive = flight.index if flight is not None and flight.kind == "drive" else None
        begun = self.engine.run.started[robot.agent]
        robot.queue = deque(d for d in robot.queue if d.index == drive or d.index < begun)

    @property
    def moving(self) -> bool:
        return any(r.flight is not None for r in self.robots)

    def position(self, robot: Robot) -> Coord:
        """The cell the robot holds for planning: its last completed action's target."""
        return held_cell(self.engine, robot.agent)
