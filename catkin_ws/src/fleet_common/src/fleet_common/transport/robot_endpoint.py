"""The robot side of the wire protocol on ZeroMQ: the thin layer with the sockets.

A `RobotEndpoint` is one robot's server. It binds a ROUTER socket on its
command port (robots are servers, thesis 6.4) and a PUB socket on its
feedback port, and joins them to the pure parts: one `Connection` per manager
connection (a ROUTER identity), one `CommandExecutor` for the robot, one
`Liveness` per connection. With `RobotKeys` both sockets are CURVE servers and
the context's `ZapHandler` admits only the manager key.

Connections: the newest successful Hello wins; any older connection gets
`Bye(code="superseded")`. A message from a connection that never said hello
(the manager's, after this robot restarted) gets `Bye(code="no-session")`, which
tells the manager to say hello again. A peer silent for `PEER_TIMEOUT` is dropped.

Hostile peers: every frame is handled inside its own boundary, so that
nothing a peer sends, and no bug it triggers, stops the robot: a frame that
breaks the protocol gets a `Bye` and is logged with the peer's address, an
unexpected exception is logged with its traceback, and the next frame is
served. Refusals are logged through a `RateLimitedLog` (one line per peer a
minute, then a count). With CURVE, clients that fail the handshake before ZAP
is asked (no key, or not this robot's key) are logged from a socket monitor.
Drives and turns are checked against the robot's world (`CommandCheck`)
before the navigator sees them.

`RobotLoop` (robot_loop.py) runs any number of endpoints in one thread, so
300 virtual robots cost one process, not 300 threads.
"""
from __future__ import annotations

import logging
import secrets
import time
from typing import Callable, Dict, Optional, Tuple

import zmq

from ..errors import FleetError
from ..limits import MAX_FRAME_BYTES, excerpt
from ..ratelimit import RateLimitedLog
from ..wire.codec import encode
from ..wire.command_check import CommandCheck
from ..wire.connection import Connection
from ..wire.errors import MalformedFrameError, RemoteProtocolError, VersionMismatchError
from ..wire.executor import CommandExecutor, Routed
from ..wire.liveness import Liveness
from ..wire.messages import (COMMAND_TYPES, Bye, Command, Heartbeat, Hello, Message, PoseFeedback,
                             Welcome)
from ..wire.navigator import PollingNavigator
from ..wire.states import Role, State
from .curve_keys import RobotKeys
from .peers import HandshakeMonitor, peer_of
from .zap import ZapHandler

__all__ = ["RobotEndpoint"]

_BUDGET = 100           # frames read per wake-up, so one chatty peer cannot starve the rest
_RUNNING_POLL = 0.02    # how often a running motion is polled when the navigator gives no hint


class RobotEndpoint:
    """One robot's command and feedback sockets, speaking the protocol."""

    def __init__(self, context: zmq.Context, robot_id: int, navigator: PollingNavigator,
                 command_port: int, feedback_port: int, *, bind: str = "*",
                 keys: Optional[RobotKeys] = None, zap: Optional[ZapHandler] = None,
                 clock: Callable[[], float] = time.monotonic,
                 log: Optional[logging.Logger] = None, feedback_rate: float = 10.0,
                 check: Optional[CommandCheck] = None,
                 on_execute: Optional[Callable[[str, Command], None]] = None) -> None:
        self.robot_id = robot_id
        self.navigator = navigator
        self.executor = CommandExecutor(navigator, check=check, on_execute=on_execute)
        self.session = secrets.token_hex(8)  # new each start: the manager sees a restart
        self.feedback_port = feedback_port
        self.clock = clock
        self.log = log or logging.getLogger("fleet_common.wire.robot{}".format(robot_id))
        self.refusals = RateLimitedLog(self.log, clock=clock,
                                       prefix="robot {}: ".format(robot_id))
        self.period = 1.0 / feedback_rate
        self.peers: Dict[bytes, Tuple[Connection, Liveness]] = {}
        self.by_epoch: Dict[str, bytes] = {}
        self.seq = 0
        self.next_feedback = clock()
        self.command = self._socket(context, zmq.ROUTER, keys, zap)
        self.feedback = self._socket(context, zmq.PUB, keys, zap)
        self.command.setsockopt(zmq.ROUTER_HANDOVER, 1)
        #: with CURVE: who failed the handshake (the loop polls `monitor.socket`)
        self.monitor = HandshakeMonitor(self.command, self.refusals) if keys is not None else None
        for sock, port in ((self.command, command_port), (self.feedback, feedback_port)):
            endpoint = "tcp://{}:{}".format(bind, port)
            try:
                sock.bind(endpoint)
            except zmq.ZMQError as err:
                self.close(send_bye=False)
                raise FleetError("robot {}: cannot listen on {}: {}".format(
                    robot_id, endpoint, err.strerror)) from err

    def _socket(self, context: zmq.Context, kind: int, keys: Optional[RobotKeys],
                zap: Optional[ZapHandler]) -> zmq.Socket:
        sock = context.socket(kind)
        sock.linger = 100  # long enough to flush a goodbye, short enough to exit promptly
        sock.setsockopt(zmq.MAXMSGSIZE, MAX_FRAME_BYTES)  # libzmq drops a peer that sends more
        if keys is not None:
            if zap is None:
                raise ValueError("CURVE keys need a ZapHandler, or any client key would do")
            domain = "robot {}".format(self.robot_id)
            zap.allow(domain, [keys.manager_public])
            sock.zap_domain = domain.encode("utf-8")
            sock.curve_secretkey = keys.secret
            sock.curve_publickey = keys.public
            sock.curve_server = True
        return sock

    # ---- events from the loop ----------------------------------------------------

    def handle_readable(self) -> None:
        """Read and act on the command frames waiting (up to a budget), each on its own:
        whatever one frame does, the next is served."""
        now = self.clock()
        for _ in range(_BUDGET):
            try:
                frames = self.command.recv_multipart(zmq.NOBLOCK, copy=False)
            except zmq.Again:
                return
            try:
                if len(frames) == 2:
                    self._on_frame(frames[0].bytes, frames[1].bytes, now, frames[1])
                else:  # a DEALER sends one part; anything else is not our manager
                    self._refused(frames[-1], "frames of {} parts".format(len(frames) - 1))
            except Exception:
                self.refusals.event(logging.ERROR, peer_of(frames[-1]), "failures",
                                    "failed on a frame from %s (%s); going on", peer_of(frames[-1]),
                                    excerpt(frames[-1].bytes), exc_info=True)

    def tick(self, now: float) -> float:
        """Motion outcomes, heartbeats, dead peers, pose feedback; the next due time."""
        for routed in self.executor.poll():
            self._route(routed, now)
        self.refusals.flush(now)
        due = now + 1.0
        for identity, (conn, live) in list(self.peers.items()):
            if live.peer_gone(now):
                self.log.info("robot %s: manager connection silent for %.1f s; dropped",
                              self.robot_id, live.timeout)
                self._drop(identity)
                continue
            if live.heartbeat_due(now) and conn.state is State.OPEN:
                self._send(identity, Heartbeat(), now)
            due = min(due, live.next_deadline())
        if now >= self.next_feedback:
            self.publish_pose()
            # keep the rate, but do not burst to catch up after a stall
            self.next_feedback = max(self.next_feedback + self.period, now + self.period / 2)
        due = min(due, self.next_feedback)
        if self.executor.current is not None:
            hint = getattr(self.navigator, "seconds_to_change", None)
            wait = hint() if callable(hint) else _RUNNING_POLL
            due = min(due, now + max(0.0, wait))
        return due

    def publish_pose(self) -> None:
        message = PoseFeedback(self.robot_id, self.seq, self.navigator.pose(),
                               self.executor.current, tuple(self.navigator.faults()), self.executor.ended)
        self.seq += 1
        try:
            self.feedback.send(encode(message), zmq.NOBLOCK)
        except zmq.Again:
            pass  # no room for a slow subscriber: the next pose supersedes this one

    def close(self, send_bye: bool = True) -> None:
        """Say goodbye to connected managers (unless this is a simulated power cut) and
        close the sockets; the navigator is halted."""
        if send_bye:
            now = self.clock()
            for identity in list(self.peers):
                self._send(identity, Bye("robot {} is shutting down".format(self.robot_id),
                                         "shutdown"), now)
        self.peers.clear()
        if self.monitor is not None:
            self.monitor.close()
            self.monitor = None
        for name in ("command", "feedback"):
            sock = getattr(self, name, None)
            if sock is not None:
                sock.close(linger=100 if send_bye else 0)
        self.navigator.halt()

    # ---- internals ---------------------------------------------------------------

    def _on_frame(self, identity: bytes, data: bytes, now: float, frame: zmq.Frame) -> None:
        conn, live = self.peers.get(identity) or (Connection(Role.ROBOT, self.robot_id), None)
        try:
            message = conn.receive(data)
        except VersionMismatchError as err:
            self.refusals.event(logging.ERROR, peer_of(frame), "refused frames",
                                "%s (from %s)", err, peer_of(frame))
            self._refuse(identity, conn, str(err), err.code, now)
            return
        except RemoteProtocolError as err:
            if (conn.state is State.START and err.code == "protocol"
                    and not isinstance(err, MalformedFrameError)):  # a message, not a hello
                reason = ("robot {} has no session for this connection (it may have restarted); "
                          "say hello first".format(self.robot_id))
                self.refusals.event(logging.INFO, peer_of(frame), "messages without a session",
                                    "no session for the connection from %s (%s); told it to "
                                    "say hello", peer_of(frame), err)
                self._refuse(identity, conn, reason, "no-session", now)
            else:
                self._refused(frame, err)
                self._refuse(identity, conn, str(err), err.code, now)
            return
        if live is None:
            live = Liveness(now)
            self.peers[identity] = (conn, live)
        live.heard(now)
        self._on_message(identity, conn, message, now, frame)

    def _on_message(self, identity: bytes, conn: Connection, message: Message, now: float,
                    frame: zmq.Frame) -> None:
        if isinstance(message, Hello):
            for other in [i for i in self.peers if i != identity]:
                self._send(other, Bye("another manager connection took over robot {}".format(
                    self.robot_id), "superseded"), now)
                self._drop(other)
            self.by_epoch = {message.epoch: identity}
            self._send(identity, Welcome(self.robot_id, self.session, self.feedback_port), now)
            self.log.info("robot %s: manager connected from %s (epoch %s)", self.robot_id,
                          peer_of(frame), excerpt(message.epoch))
        elif message.TYPE in COMMAND_TYPES:
            for routed in self.executor.handle(conn.epoch or "", message):
                self._route(routed, now)
        elif isinstance(message, Bye):
            self.log.info("robot %s: manager said bye: %s", self.robot_id, excerpt(message.reason, 200))
            self._drop(identity)

    def _refused(self, frame: zmq.Frame, why: object) -> None:
        self.refusals.event(logging.WARNING, peer_of(frame), "refused frames",
                            "refused a frame from %s: %s", peer_of(frame), why)

    def _refuse(self, identity: bytes, conn: Connection, reason: str, code: str, now: float) -> None:
        bye = Bye(reason, code)
        if conn.can_send(bye):
            self._put(identity, conn.send(bye))
        self._drop(identity)

    def _route(self, routed: Routed, now: float) -> None:
        epoch, reply = routed
        identity = self.by_epoch.get(epoch)
        peer = self.peers.get(identity) if identity is not None else None
        if peer is not None and peer[0].can_send(reply):
            self._send(identity, reply, now)
        else:  # its manager is gone or never resent it here; a resend gets the outcome
            self.log.debug("robot %s: %s not delivered (no connection expects it)",
                           self.robot_id, reply)

    def _send(self, identity: bytes, message: Message, now: float) -> None:
        conn, live = self.peers[identity]
        self._put(identity, conn.send(message))
        live.sent(now)

    def _put(self, identity: bytes, data: bytes) -> None:
        try:
            self.command.send_multipart([identity, data], zmq.NOBLOCK)
        except zmq.Again:
            self.log.warning("robot %s: send queue full; a message was dropped", self.robot_id)

    def _drop(self, identity: bytes) -> None:
        self.peers.pop(identity, None)
        self.by_epoch = {e: i for e, i in self.by_epoch.items() if i != identity}

