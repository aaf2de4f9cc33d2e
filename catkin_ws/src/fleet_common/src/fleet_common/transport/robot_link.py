"""The manager's connection to one robot, which reconnects by itself.

A `RobotLink` owns a DEALER socket connected to the robot's command port and,
once the robot's `Welcome` names it, a SUB socket on its feedback port. It
keeps the protocol's `Connection` and turns what arrives into events:
`LinkUp`, `LinkDown`, `RobotReply` (the robot's Accepted / Completed /
Failed / Status) and `PoseFeedback`.

Reconnecting: after `PEER_TIMEOUT` of silence, a refused handshake or a
`Bye`, the link drops its socket, opens a new one and says hello again with
the same epoch. Commands not yet settled are sent again: if the robot is the
same process (same session), its executor recognises their ids and only
reports their outcome; if it restarted (new session), commands it may have
been running are reported failed here ("outcome unknown"), and those never
sent go out. A version mismatch or a robot of another id stops the link for
good (`LinkDown(fatal=True)`): retrying cannot help.

Commands may be issued while the link is down; they are sent once it is up.

Keys: until the robot's welcome, the command socket's handshake is watched
(`peers.ClientHandshake`): a robot that refuses our key, or whose public key
is not the one we were given, or that runs without CURVE while we do not,
is logged once a minute with a count, and said once as a `LinkDown` whose
reason the manager shows ("not connected: robots 1, 2 (robot 1 refused our
key ...)").

A hostile or broken robot cannot stop the manager: frames beyond the limits
are dropped by libzmq (MAXMSGSIZE), anything else that does not decode is a
protocol error (the link says bye and reconnects), each frame is handled
inside its own boundary (an unexpected exception is logged with its traceback
and the next frame is served), a call reads at most a budget of frames, and
repeated complaints are logged once a minute per robot, then counted. libzmq
does not reconnect a socket it dropped for an oversized frame, so a command
socket gone quiet is replaced after `PEER_TIMEOUT`, like any silent link, and
so is a pose stream silent that long while the link is up.
"""
from __future__ import annotations

import logging
import time
from collections import OrderedDict
from typing import Callable, List, Optional, Tuple

import zmq

from ..limits import excerpt
from ..ratelimit import RateLimitedLog
from ..robots import RobotDefinition
from ..wire import (Bye, Command, Completed, Connection, DriveToPosition, Failed, GetStatus,
                    Heartbeat, Hello, Liveness, Release, RemoteProtocolError, Role, Status, Stop, Turn,
                    VersionMismatchError, Welcome)
from .curve_keys import ManagerKeys
from ..wire.link_events import OUTCOME_UNKNOWN, LinkDown, LinkEvent, LinkUp, RobotReply
from .peers import ClientHandshake
from .pose_feedback import poses_in, secure_client, subscribe_feedback

__all__ = ["RobotLink", "LinkUp", "LinkDown", "RobotReply", "LinkEvent", "OUTCOME_UNKNOWN"]



_POLLIN = int(zmq.POLLIN)
_SUPERSEDED_RETRY = 5.0  # another manager took the robot: do not fight over it every second
_BUDGET = 100            # frames read per call, so one chatty robot cannot starve the rest


class RobotLink:
    """One robot, seen from the manager. Not thread-safe: use it from one loop."""

    def __init__(self, context: zmq.Context, robot: RobotDefinition, epoch: str, *,
                 keys: Optional[ManagerKeys] = None, host: Optional[str] = None,
                 clock: Callable[[], float] = time.monotonic, retry: float = 1.0,
                 log: Optional[logging.Logger] = None) -> None:
        self.context = context
        self.robot_id = robot.id
        self.host = host or robot.host
        self.address = "tcp://{}:{}".format(self.host, robot.command_port)
        self.epoch = epoch
        self.keys = keys
        self.clock = clock
        self.retry = retry
        self.log = log or logging.getLogger("fleet_manager.robot{}".format(robot.id))
        self.refusals = RateLimitedLog(self.log, clock=clock)
        self.state = "connecting"  # connecting | up | down | failed
        self.session: Optional[str] = None
        self.feedback_port: Optional[int] = None
        self.generation = 0  # counts changes of the sockets, for the loop's poller
        self._feedback: Optional[zmq.Socket] = None
        self._command: Optional[zmq.Socket] = None
        self._feedback_heard = 0.0  # when the pose stream last sent anything
        self.conn = Connection(Role.MANAGER, self.robot_id)
        self.live = Liveness(clock())
        self.retry_at = 0.0
        self._next_id = 1
        # id -> (command, session it was last sent to, None: not sent yet)
        self._unsettled: "OrderedDict[int, Tuple[Command, Optional[str]]]" = OrderedDict()
        self._handshake: Optional[ClientHandshake] = None  # watched until the welcome
        self.key_problem: Optional[str] = None  # why the handshake fails, once known
        self._connect(clock())

    # ---- commands (the thesis's navigation API, remote) ---------------------------

    def drive_to_position(self, x: float, y: float, time: float,
                          hold: Optional[Tuple[float, float]] = None) -> int:
        return self._issue(lambda i: DriveToPosition(i, float(x), float(y), float(time), hold))

    def release(self, drive: int, x: float, y: float) -> int:
        return self._issue(lambda i: Release(i, drive, float(x), float(y)))

    def turn(self, angle: float) -> int:
        return self._issue(lambda i: Turn(i, float(angle)))

    def stop(self) -> int:
        return self._issue(Stop)

    def get_status(self) -> int:
        return self._issue(GetStatus)

    def reconnect(self, reason: str = "asked to reconnect") -> List[LinkEvent]:
        """Drop the connection and start a new one now (same epoch, commands resent)."""
        if self.state == "failed":
            return []
        now = self.clock()
        if self.command is not None and self.conn.can_send(Bye(reason, "shutdown")):
            self._send(Bye(reason, "shutdown"), now)
        events = self._lost(reason, now, retry=0.0)
        self._connect(now)
        return events

    @property
    def unsettled(self) -> List[int]:
        """Ids of commands without a final reply yet."""
        return list(self._unsettled)

    # ---- the loop's side -----------------------------------------------------------

    @property
    def command(self) -> Optional[zmq.Socket]:
        return self._command

    @command.setter
    def command(self, sock: Optional[zmq.Socket]) -> None:
        self._command = sock
        self.generation += 1

    @property
    def feedback(self) -> Optional[zmq.Socket]:
        return self._feedback

    @feedback.setter
    def feedback(self, sock: Optional[zmq.Socket]) -> None:
        self._feedback = sock
        self.generation += 1

    def sockets(self) -> List[zmq.Socket]:
        return [s for s in (self.command, self.feedback) if s is not None]

    def handle(self, sock: zmq.Socket) -> List[LinkEvent]:
        """Events from what is waiting on `sock` (one of `sockets()`). Of the poses waiting
        only the newest counts (each is the robot's whole state), so only that one is decoded:
        a manager that fell behind catches up at once instead of working through old poses."""
        events: List[LinkEvent] = []
        now = self.clock()
        if sock is self.feedback:
            frames = []
            for _ in range(_BUDGET):  # while a frame waits (asking is cheaper than an exception)
                if not sock.getsockopt(zmq.EVENTS) & _POLLIN:
                    break
                try:
                    frames.append(sock.recv(zmq.NOBLOCK))
                except zmq.Again:
                    break
            if frames:
                self._feedback_heard = now
            for data in reversed(frames[-3:]):  # the newest that is a pose (a bad frame skipped)
                poses = poses_in(data, self.robot_id, self.refusals)
                if poses:
                    return poses
            return events
        for _ in range(_BUDGET):
            if sock is not self.command:
                break  # replaced while handling a frame (the link reconnected)
            try:
                data = sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                break
            try:
                events += self._on_command_frame(data, now)
            except Exception:
                self.refusals.event(logging.ERROR, "robot {}".format(self.robot_id), "failures",
                                    "robot %s: failed on frame %s; going on", self.robot_id,
                                    excerpt(data), exc_info=True)
        return events

    def tick(self, now: float) -> Tuple[List[LinkEvent], float]:
        """Heartbeats, timeouts and retries; (events, the next time to call tick)."""
        events: List[LinkEvent] = []
        self.refusals.flush(now)
        if self.state == "failed":
            return events, now + 3600.0
        if self.state == "down":
            if now >= self.retry_at:
                self._connect(now)
            return events, max(self.retry_at, now + 0.05) if self.state == "down" else now
        if self.live.peer_gone(now):
            what = "no welcome" if self.state == "connecting" else "silent"
            events += self._lost("robot {} {} for {:.1f} s".format(
                self.robot_id, what, self.live.timeout), now, retry=0.0)
            return events, now
        if self.state != "up":  # no heartbeats before the welcome: wait for it or give up
            events += self._check_handshake()
            return events, min(self.live.last_heard + self.live.timeout, now + 1.0)
        if self.live.heartbeat_due(now):
            self._send(Heartbeat(), now)
        stream_due = self._feedback_heard + self.live.timeout
        if self.feedback_port is not None and now >= stream_due:
            self.log.info("robot %s: pose feedback silent for %.1f s; subscribing again",
                          self.robot_id, self.live.timeout)
            self._subscribe(self.feedback_port)
            self._feedback_heard = stream_due = now
        return events, min(self.live.next_deadline(), stream_due + self.live.timeout)

    def close(self) -> None:
        self._unwatch()
        if self.command is not None and self.state == "up" and self.conn.can_send(Bye("manager closing")):
            self._send(Bye("manager closing", "shutdown"), self.clock())
        for sock in self.sockets():
            sock.close(linger=100)
        self.command = self.feedback = None
        self.state = "failed"

    # ---- internals -------------------------------------------------------------------

    def send(self, command: Command) -> int:
        """Send `command` as it is, its id chosen by the caller (ids must keep increasing: the
        robot refuses an id at or below one it has seen from this epoch); sent once the link
        is up, and again after a reconnect until it is settled."""
        self._next_id = max(self._next_id, command.id + 1)
        self._unsettled[command.id] = (command, None)
        if self.state == "up":
            self._send_command(command, self.clock())
        return command.id

    def _issue(self, make: Callable[[int], Command]) -> int:
        return self.send(make(self._next_id))

    def _send_command(self, command: Command, now: float) -> None:
        self._unsettled[command.id] = (command, self.session)
        self._send(command, now)

    def _connect(self, now: float) -> None:
        self._unwatch()
        if self.command is not None:
            self.command.close(linger=0)
        sock = self.context.socket(zmq.DEALER)
        sock.linger = 0
        secure_client(sock, self.keys)
        self._handshake = ClientHandshake(sock, self.refusals, "robot {}".format(self.robot_id),
                                          self.keys is not None, "manager.key", "robot.key")
        sock.connect(self.address)
        self.command = sock
        self.conn = Connection(Role.MANAGER, self.robot_id)
        self.live = Liveness(now)
        self.state = "connecting"
        self._send(Hello(self.robot_id, self.epoch), now)

    def _send(self, message: object, now: float) -> None:
        data = self.conn.send(message)
        if self.command is None:
            return
        try:
            self.command.send(data, zmq.NOBLOCK)
        except zmq.Again:
            self.log.warning("robot %s: send queue full; %s dropped", self.robot_id, message)
        self.live.sent(now)

    def _on_command_frame(self, data: bytes, now: float) -> List[LinkEvent]:
        try:
            message = self.conn.receive(data)
        except VersionMismatchError as err:
            self.log.error("robot %s: %s", self.robot_id, err)
            return self._fail(str(err))
        except RemoteProtocolError as err:
            if err.code == "robot-id":
                self.log.error("robot %s: %s", self.robot_id, err)
                return self._fail(str(err))
            self.refusals.event(logging.ERROR, "robot {}".format(self.robot_id), "protocol errors",
                                "robot %s broke the protocol: %s", self.robot_id, err)
            if self.conn.can_send(Bye("", "protocol")):
                self._send(Bye(str(err), err.code), now)
            return self._lost("protocol error: {}".format(err), now, retry=self.retry)
        self.live.heard(now)
        if isinstance(message, Welcome):
            return self._on_welcome(message, now)
        if isinstance(message, Bye) and message.code == "robot-id":
            self.log.error("robot %s refused us: %s", self.robot_id, excerpt(message.reason, 200))
            return self._fail("robot refused the connection: {}".format(excerpt(message.reason, 200)))
        if isinstance(message, Bye):
            # no-session on a link that was up: the robot restarted, say hello at once; in
            # answer to our hello it is a robot that misbehaves: do not spin on it
            retry = _SUPERSEDED_RETRY if message.code == "superseded" else (
                0.0 if message.code == "no-session" and self.state == "up" else self.retry)
            level = logging.WARNING if message.code == "superseded" else logging.INFO
            reason = excerpt(message.reason, 200)
            self.refusals.event(level, "robot {}".format(self.robot_id), "byes",
                                "robot %s said bye (%s): %s", self.robot_id, excerpt(message.code),
                                reason)
            return self._lost("robot said bye: {}".format(reason), now, retry)
        if isinstance(message, (Completed, Failed, Status)):
            self._unsettled.pop(message.id, None)
        if isinstance(message, Heartbeat):
            return []
        return [RobotReply(self.robot_id, message)]

    def _check_handshake(self) -> List[LinkEvent]:
        """A handshake problem newly known, as a LinkDown saying it (once per change)."""
        problem = self._handshake.check() if self._handshake is not None else None
        if problem is None or problem == self.key_problem:
            return []
        self.key_problem = problem
        return [LinkDown(self.robot_id, problem)]

    def _unwatch(self) -> None:
        if self._handshake is not None:
            self._handshake.close()
            self._handshake = None

    def _on_welcome(self, welcome: Welcome, now: float) -> List[LinkEvent]:
        self._unwatch()
        self.key_problem = None
        restarted = self.session is not None and welcome.session != self.session
        self.session = welcome.session
        self.state = "up"
        if restarted or welcome.feedback_port != self.feedback_port:  # (restarted: the old process's
            self._subscribe(welcome.feedback_port)  # poses still on their way are not the new one's)
        events: List[LinkEvent] = [LinkUp(self.robot_id, welcome.session, restarted)]
        for cid, (command, sent_to) in list(self._unsettled.items()):
            if sent_to is not None and sent_to != welcome.session:
                del self._unsettled[cid]
                events.append(RobotReply(self.robot_id, Failed(cid, (
                    "robot {} restarted while command {} was in flight; {}").format(
                        self.robot_id, cid, OUTCOME_UNKNOWN))))
            else:
                self._send_command(command, now)
        self.log.info("robot %s: link up (session %s%s)", self.robot_id, excerpt(welcome.session),
                      ", restarted" if restarted else "")
        return events

    def _subscribe(self, port: int) -> None:
        if self.feedback is not None:
            self.feedback.close(linger=0)
        self.feedback = subscribe_feedback(self.context, self.host, port, self.keys)
        self._feedback_heard = self.clock()
        self.feedback_port = port

    def _lost(self, reason: str, now: float, retry: float) -> List[LinkEvent]:
        was_up = self.state == "up"
        self.state = "down"
        self.retry_at = now + retry
        self._unwatch()
        if self.command is not None:
            self.command.close(linger=0)
            self.command = None
        self.log.info("robot %s: link down: %s", self.robot_id, reason)
        return [LinkDown(self.robot_id, reason)] if was_up else []

    def _fail(self, reason: str) -> List[LinkEvent]:
        self.state = "failed"
        self._unwatch()
        if self.command is not None:
            self.command.close(linger=0)
            self.command = None
        return [LinkDown(self.robot_id, reason, fatal=True)]
