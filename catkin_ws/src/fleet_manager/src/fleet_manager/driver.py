"""The engine driver: engine decisions become robot commands, robot replies become engine events.

Theory of operation. The execution engine (fleet_common.execution) decides
which plan action each robot may start; the robots speak the wire protocol
(`turn`, `drive_to_position`, `stop`, `get_status`). The driver joins them,
one robot at a time, with one motion command in flight per robot (robots run
one command at a time):

- a dispatched action waits in the robot's queue; when the robot is free it
  is sent a `turn` to face the action's cell if it does not face it, then a
  `drive_to_position` to the cell's centre;
- while a robot waits for its next action (a cell not free yet, the step
  barrier), it turns towards it already, in place: it holds its own cell, so
  that is safe, and the move is quicker once allowed;
- the robot's `Accepted` of a drive is the engine's `ActionStarted`, its
  `Completed` the engine's `ActionCompleted` (which may dispatch more);
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

The driver owns no socket and reads no clock: `now` comes with each call, and
commands go out through the robots' links (anything with the `RobotLink`
command methods). What it did is reported through `note(kind, **fields)`
(the run log's records) and `tell(kind, robot, text)` (the console's events).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Callable, Deque, Dict, List, Optional, Sequence, Tuple

from fleet_common.execution import (ActionCompleted, ActionStarted, Dispatch, Enabled, Engine,
                                    EventError, RobotFailed)
from fleet_common.grid import Coord
from fleet_common.transport.link_events import LinkDown, LinkEvent, LinkUp, RobotReply
from fleet_common.transport.robot_link import OUTCOME_UNKNOWN
from fleet_common.wire import Accepted, Completed, Failed, Pose, PoseFeedback, Status

__all__ = ["Driver", "Slot", "TURN_TOLERANCE", "AT_CELL"]

#: A robot facing its next cell within this angle (radians) drives without a turn first.
TURN_TOLERANCE = math.radians(20.0)
#: A robot this close (cells) to a cell's centre is on that cell (start checks, planning).
AT_CELL = 0.3
#: A restarted robot this close to its move's target has made the move; farther, it is sent
#: the move again (a few centimetres: a robot's own arrival tolerance).
MADE_IT = 0.05

Note = Callable[..., None]
Tell = Callable[[str, Optional[int], str], None]


def wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def heading(src: Coord, dst: Coord) -> float:
    return math.atan2(dst[1] - src[1], dst[0] - src[0])


@dataclass
class InFlight:
    """The motion command a robot is carrying out (or was last sent)."""

    id: int
    kind: str                # "turn" | "drive" | "stop"
    index: Optional[int]     # plan action it serves (None: a stop)
    sent: float
    target: Tuple[float, ...]
    accepted: bool = False


@dataclass
class Slot:
    """One robot as the driver sees it; `agent` is its index in the plan."""

    agent: int
    robot_id: int
    link: object
    queue: Deque[Dispatch] = field(default_factory=deque)
    flight: Optional[InFlight] = None
    status_id: Optional[int] = None
    pose: Optional[Pose] = None
    faults: Tuple[str, ...] = ()
    hold: Optional[str] = None      # None, "recover" (asked where it is), "fault", "halted"
    hold_reason: str = ""
    clear_fault: bool = False       # a stop is on its way to clear the fault (enable)

    @property
    def link_up(self) -> bool:
        return getattr(self.link, "state", "up") == "up"


class Driver:
    """Drives `engine`'s plan through the robots of `slots` (one per plan agent, in order)."""

    def __init__(self, engine: Engine, slots: Sequence[Slot], note: Note, tell: Tell) -> None:
        if len(slots) != engine.run.num_robots:
            raise ValueError("{} robots for a plan of {} agents".format(len(slots), engine.run.num_robots))
        self.engine = engine
        self.slots = list(slots)
        self.by_robot: Dict[int, Slot] = {s.robot_id: s for s in self.slots}
        self.note = note
        self.tell = tell
        self.preturn = True
        self.moving_since: Dict[int, float] = {}  # agent -> when its drive was sent (trace)
        self.trace: List[Tuple[int, float, float, Coord, Coord]] = []  # agent, start, end, src, dst

    # ---- the engine's side ---------------------------------------------------------------

    def handle(self, event: object, now: float) -> None:
        """Give the engine `event` (a control or progress event) and act on what it decides."""
        run = self.engine.run
        waits = self.engine.metrics.last_wait
        waits.clear()
        dispatches = self.engine.handle(event)
        released = getattr(event, "robot", None) if isinstance(event, (ActionCompleted, Enabled)) else None
        for d in dispatches:
            slot = self.slots[d.robot]
            slot.queue.append(d)
            waited = waits.pop(d.robot, 0.0)  # a robot sent two actions at once waited once
            self.note("dispatch", robot=slot.robot_id, index=d.index, step=d.step, src=d.src,
                      dst=d.dst, waited=round(waited, 3),
                      released_by=None if released is None else self.slots[released].robot_id)
        if isinstance(event, (ActionStarted, ActionCompleted, RobotFailed)):
            # progress frees only the robots dispatched now (and the robot itself, for its next turn)
            targets = sorted({d.robot for d in dispatches} | (
                {event.robot} if isinstance(event, ActionCompleted) else set()))
        else:  # control (resume, step, switch, enable): anyone may start or turn now
            targets = range(run.num_robots)
        for r in targets:
            self.pump(self.slots[r], now)

    def pump_all(self, now: float) -> None:
        for slot in self.slots:
            self.pump(slot, now)

    def pump(self, slot: Slot, now: float) -> None:
        """Send `slot`'s robot its next command if it is free to take one."""
        if slot.flight is not None or slot.hold is not None or not slot.link_up:
            return
        r = slot.agent
        run = self.engine.run
        if slot.queue:
            d = slot.queue[0]
            if run.out[r] is not None:
                return
            angle = heading(d.src, d.dst)
            if self._needs_turn(slot, angle):
                self._send(slot, "turn", d.index, now, (angle,))
            else:
                self._send(slot, "drive", d.index, now, (float(d.dst[0]), float(d.dst[1])))
            return
        if self.preturn and not self.engine.paused and run.out[r] is None:
            a = run.next_undispatched(r)
            if a >= 0 and run.completed[r] == run.dispatched[r]:
                table = self.engine.table
                angle = heading(table.coord(run.src[a]), table.coord(run.dst[a]))
                if self._needs_turn(slot, angle):
                    self._send(slot, "turn", a - run.first[r], now, (angle,))

    def _needs_turn(self, slot: Slot, angle: float) -> bool:
        return slot.pose is None or abs(wrap(angle - slot.pose.theta)) > TURN_TOLERANCE

    def _send(self, slot: Slot, kind: str, index: Optional[int], now: float,
              target: Tuple[float, ...]) -> None:
        link = slot.link
        if kind == "turn":
            cid = link.turn(target[0])  # type: ignore[attr-defined]
            self.note("command", robot=slot.robot_id, id=cid, type="turn", angle=target[0], action=index)
        elif kind == "drive":
            cid = link.drive_to_position(target[0], target[1], 0.0)  # type: ignore[attr-defined]
            self.note("command", robot=slot.robot_id, id=cid, type="drive", x=target[0], y=target[1],
                      time=0.0, action=index)
        else:
            cid = link.stop()  # type: ignore[attr-defined]
            self.note("command", robot=slot.robot_id, id=cid, type="stop", action=None)
        slot.flight = InFlight(cid, kind, index, now, target)

    # ---- the robots' side ----------------------------------------------------------------

    def on_link_event(self, event: LinkEvent, now: float) -> None:
        slot = self.by_robot.get(event.robot_id)
        if slot is None:
            return
        if isinstance(event, PoseFeedback):
            slot.pose = event.pose
            if tuple(event.faults) != slot.faults:
                self._faults(slot, tuple(event.faults), now)
        elif isinstance(event, RobotReply):
            self._reply(slot, event.reply, now)
        elif isinstance(event, LinkUp):
            self.note("link", robot=slot.robot_id, state="up", reason="", restarted=event.restarted)
            if event.restarted:
                self.tell("link", slot.robot_id, "robot {} is back (restarted)".format(slot.robot_id))
            else:
                self.tell("link", slot.robot_id, "robot {} link up".format(slot.robot_id))
            if slot.hold == "recover" or event.restarted:
                self._ask_where(slot, now)
            self.pump(slot, now)
        elif isinstance(event, LinkDown):
            self.note("link", robot=slot.robot_id, state="failed" if event.fatal else "down",
                      reason=event.reason, restarted=False)
            self.tell("link", slot.robot_id, "robot {} link {}: {}".format(
                slot.robot_id, "failed" if event.fatal else "down", event.reason))

    def _reply(self, slot: Slot, reply: object, now: float) -> None:
        self.note("reply", robot=slot.robot_id, id=reply.id, type=reply.TYPE,  # type: ignore[attr-defined]
                  **({"reason": reply.reason} if isinstance(reply, Failed) else {}),
                  **({"duplicate": reply.duplicate} if isinstance(reply, Accepted) else {}))
        if isinstance(reply, Status):
            if reply.id == slot.status_id:
                slot.status_id = None
                slot.pose = reply.pose
                if tuple(reply.faults) != slot.faults:
                    self._faults(slot, tuple(reply.faults), now)
                if slot.hold == "recover":
                    self._recovered(slot, now)
            return
        flight = slot.flight
        if flight is None or reply.id != flight.id:  # type: ignore[attr-defined]
            return  # an outcome of something we stopped caring about (a take-back)
        if isinstance(reply, Accepted):
            flight.accepted = True
            if flight.kind == "drive" and slot.queue and slot.queue[0].index == flight.index:
                d = slot.queue[0]
                self.moving_since[slot.agent] = flight.sent
                self.note("action", robot=slot.robot_id, index=d.index, phase="started",
                          src=d.src, dst=d.dst)
                self._progress(slot, ActionStarted(slot.agent, d.index, now), now)
            return
        slot.flight = None
        if isinstance(reply, Completed):
            self._completed(slot, flight, now)
        elif isinstance(reply, Failed):
            self._failed(slot, flight, reply.reason, now)

    def _completed(self, slot: Slot, flight: InFlight, now: float) -> None:
        if flight.kind == "turn" and slot.pose is not None:
            slot.pose = Pose(slot.pose.x, slot.pose.y, flight.target[0])
        elif flight.kind == "drive":
            d = slot.queue.popleft() if slot.queue and slot.queue[0].index == flight.index else None
            if d is not None:
                self.trace.append((slot.agent, self.moving_since.pop(slot.agent, flight.sent), now,
                                   d.src, d.dst))
                slot.pose = Pose(float(d.dst[0]), float(d.dst[1]), heading(d.src, d.dst))
                self.note("action", robot=slot.robot_id, index=d.index, phase="completed",
                          src=d.src, dst=d.dst)
                self._progress(slot, ActionCompleted(slot.agent, d.index, now), now)
                return
        elif flight.kind == "stop" and slot.clear_fault:
            slot.clear_fault = False
        self.pump(slot, now)

    def _failed(self, slot: Slot, flight: InFlight, reason: str, now: float) -> None:
        if OUTCOME_UNKNOWN in reason:
            slot.hold = "recover"
            slot.hold_reason = reason
            if slot.link_up:
                self._ask_where(slot, now)
            return
        if flight.kind == "stop":
            self.pump(slot, now)
            return
        if slot.hold == "halted" or reason.startswith("stopped by command"):
            # our own stop (halt): it holds both cells until enabled, then drives on
            slot.hold = None
            self._robot_out(slot, "halted: " + reason, now, hold="halted")
            return
        self._robot_out(slot, reason, now, hold="fault")

    def _robot_out(self, slot: Slot, reason: str, now: float, hold: str) -> None:
        run = self.engine.run
        slot.queue.clear()
        self.moving_since.pop(slot.agent, None)
        if run.out[slot.agent] is None:
            self._progress(slot, RobotFailed(slot.agent, now), now)
        slot.hold = hold
        slot.hold_reason = reason
        self.note("out", robot=slot.robot_id, why="failed", reason=reason)
        self.tell("fault" if hold == "fault" else "run", slot.robot_id,
                  "robot {} {}: {}".format(slot.robot_id, "held" if hold == "fault" else "stopped",
                                           reason))

    def _faults(self, slot: Slot, faults: Tuple[str, ...], now: float) -> None:
        slot.faults = faults
        self.note("fault", robot=slot.robot_id, faults=list(faults))
        if faults:
            self.tell("fault", slot.robot_id, "robot {} reports {}".format(slot.robot_id, ", ".join(faults)))
        else:
            self.tell("fault", slot.robot_id, "robot {} fault cleared".format(slot.robot_id))

    def _progress(self, slot: Slot, event: object, now: float) -> None:
        try:
            self.handle(event, now)
        except EventError as err:  # a reply the engine cannot place: say so, keep going
            self.tell("run", slot.robot_id, "robot {}: ignored {}: {}".format(slot.robot_id, event, err))

    # ---- recovery after a restart --------------------------------------------------------

    def _ask_where(self, slot: Slot, now: float) -> None:
        slot.hold = "recover"
        if slot.status_id is None:
            slot.status_id = slot.link.get_status()  # type: ignore[attr-defined]

    def _recovered(self, slot: Slot, now: float) -> None:
        """The robot restarted mid-action and said where it is: finish the action or redo it."""
        slot.hold = None
        slot.hold_reason = ""
        if slot.queue and slot.pose is not None:
            d = slot.queue[0]
            if math.hypot(slot.pose.x - d.dst[0], slot.pose.y - d.dst[1]) <= MADE_IT:
                self.tell("link", slot.robot_id, "robot {} restarted at the end of its move to {}: "
                          "counted as done".format(slot.robot_id, d.dst))
                run = self.engine.run
                if run.started[slot.agent] <= d.index:
                    self._progress(slot, ActionStarted(slot.agent, d.index, now), now)
                self._completed(slot, InFlight(-1, "drive", d.index, now, d.dst), now)
                return
            self.tell("link", slot.robot_id, "robot {} restarted before reaching {}: sending the "
                      "move again".format(slot.robot_id, d.dst))
        self.pump(slot, now)

    # ---- operator actions that need commands ---------------------------------------------

    def halt(self, now: float) -> None:
        """Stop every robot where it is, now (the run is paused by the caller)."""
        for slot in self.slots:
            if slot.flight is not None and slot.flight.kind in ("drive", "turn"):
                slot.hold = "halted"
                slot.link.stop()  # type: ignore[attr-defined]
                self.note("command", robot=slot.robot_id, id=-1, type="stop", action=None)

    def enable(self, slot: Slot, now: float) -> None:
        """Take `slot`'s robot back into the run (after a fault: clear it with a stop first)."""
        if slot.hold in ("fault", "halted"):
            if slot.hold == "fault" or slot.faults:
                slot.clear_fault = True
                self._send(slot, "stop", None, now, ())
            slot.hold = None
            slot.hold_reason = ""
        self.handle(Enabled(slot.agent, now), now)

    def drop_pending(self, slot: Slot) -> None:
        """The engine took `slot`'s unsent actions back (disabled): forget them here too."""
        if slot.flight is not None and slot.flight.kind == "drive":
            keep = [d for d in slot.queue if d.index == slot.flight.index]
        else:
            keep = []
        slot.queue = deque(keep)

    @property
    def moving(self) -> bool:
        return any(s.flight is not None for s in self.slots)

    def position(self, slot: Slot) -> Coord:
        """The cell the robot holds for planning: its last completed action's target."""
        run = self.engine.run
        r = slot.agent
        done = run.completed[r]
        table = self.engine.table
        if done == 0:
            return table.start(r)
        return table.coord(run.dst[run.first[r] + done - 1])
