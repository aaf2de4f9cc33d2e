"""The console channel on ZeroMQ: the manager's ROUTER and each console's DEALER.

One endpoint carries everything (requests, answers, the state stream,
events), so an operator needs one address: `fleetctl console --manager
tcp://lab-pc:7100`. The manager binds; consoles connect and say hello; the
manager then pushes to every console it knows (`fleet_common.control.desk`)
and forgets those that fall silent. The ROUTER drops what a slow console
cannot take (its queue is bounded): a console that lags gets the newest
state, not a backlog.

With keys, the channel is a CURVE server with the manager's key pair and
admits only clients holding the console key (checked by the context's ZAP
handler, which the manager serves from its loop); clients that fail the
handshake before ZAP is asked (no key, or not the manager's public key) are
logged from the socket's monitor (`monitor`, which the manager polls too).
Each side logs what the other got wrong once a minute, then a count: the
server's refusals and malformed messages, the console's failed handshakes
(`ConsoleClient.problem`).
"""
from __future__ import annotations

import logging
from typing import List, Optional, Tuple

import zmq

from ..control.messages import DEFAULT_ENDPOINT
from ..errors import FleetError
from ..ratelimit import RateLimitedLog
from .curve_keys import ConsoleKeys, ManagerKeys
from .peers import ClientHandshake, HandshakeMonitor
from .zap import ZapHandler

__all__ = ["ConsoleServer", "ConsoleClient", "DEFAULT_ENDPOINT", "MAX_FRAME"]

#: Larger frames are not the console protocol's: libzmq drops the peer.
MAX_FRAME = 256 * 1024 * 1024
_BUDGET = 200  # frames read per wake-up, so one flooding console cannot starve the fleet
_QUEUE = 200   # frames queued per console before the ROUTER drops


class ConsoleServer:
    """The manager's end: bound ROUTER; (peer, frame) in, (peer, frame) out."""

    def __init__(self, context: zmq.Context, endpoint: str, *, keys: Optional[ManagerKeys] = None,
                 zap: Optional[ZapHandler] = None, max_frame: int = 32 * 1024 * 1024,
                 log: Optional[logging.Logger] = None) -> None:
        self.log = log or logging.getLogger("fleet_manager.consoles")
        self.refusals = RateLimitedLog(self.log)
        self.monitor: Optional[HandshakeMonitor] = None
        self.socket = context.socket(zmq.ROUTER)
        self.socket.linger = 100
        self.socket.setsockopt(zmq.MAXMSGSIZE, max_frame)
        self.socket.setsockopt(zmq.SNDHWM, _QUEUE)
        self.socket.setsockopt(zmq.ROUTER_HANDOVER, 1)  # a console reconnecting keeps its name
        if keys is not None:
            if zap is None:
                raise ValueError("CURVE keys need a ZapHandler, or any client key would do")
            if keys.console_public is None:
                raise FleetError("the key folder has no console.key: run `fleetctl keys` again "
                                 "to add the console's pair (existing keys are kept)")
            zap.allow("consoles", [keys.console_public], "the console key (console.key) it was given")
            self.socket.zap_domain = b"consoles"
            self.socket.curve_secretkey = keys.secret
            self.socket.curve_publickey = keys.public
            self.socket.curve_server = True
        self.monitor = HandshakeMonitor(self.socket, self.refusals, "this manager", keys is not None)
        try:
            self.socket.bind(endpoint)
        except zmq.ZMQError as err:
            self.close()
            raise FleetError("cannot listen for consoles on {}: {}".format(endpoint, err.strerror)) from err
        self.endpoint = self.socket.getsockopt_string(zmq.LAST_ENDPOINT)

    def receive(self) -> List[Tuple[bytes, bytes]]:
        """The frames waiting (up to a budget), as (peer identity, data)."""
        out: List[Tuple[bytes, bytes]] = []
        for _ in range(_BUDGET):
            try:
                frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                break
            if len(frames) == 2:
                out.append((frames[0], frames[1]))
            else:
                peer = frames[0][:16] if frames else b""
                self.refusals.event(logging.WARNING, "console {!r}".format(peer), "refused frames",
                                    "console channel: dropped a message of %d parts from %r",
                                    len(frames), peer)
        return out

    def send(self, peer: bytes, data: bytes) -> None:
        try:
            self.socket.send_multipart([peer, data], zmq.NOBLOCK)
        except zmq.Again:
            pass  # that console's queue is full: it gets the next state instead
        except zmq.ZMQError as err:  # the peer went away between receive and send
            self.log.debug("console channel: send to %r failed: %s", peer[:16], err)

    def close(self) -> None:
        if self.monitor is not None:
            self.monitor.close()
            self.monitor = None
        self.socket.close(linger=100)


_HANDSHAKES: List[RateLimitedLog] = []


def _handshakes() -> RateLimitedLog:
    """One limiter for every client of this process: a console that makes a new client for each
    attempt still logs a failing handshake once a minute per manager."""
    if not _HANDSHAKES:
        _HANDSHAKES.append(RateLimitedLog(logging.getLogger("fleet_console")))
    return _HANDSHAKES[0]


class ConsoleClient:
    """A console's end: DEALER connected to the manager (reconnects by itself, as ZeroMQ does)."""

    def __init__(self, context: zmq.Context, endpoint: str, *,
                 keys: Optional[ConsoleKeys] = None, max_frame: int = MAX_FRAME,
                 log: Optional[logging.Logger] = None) -> None:
        self.endpoint = endpoint
        self.socket = context.socket(zmq.DEALER)
        self.socket.linger = 0
        self.socket.setsockopt(zmq.MAXMSGSIZE, max_frame)
        if keys is not None:
            self.socket.curve_secretkey = keys.secret
            self.socket.curve_publickey = keys.public
            self.socket.curve_serverkey = keys.manager_public
        self.handshake = ClientHandshake(
            self.socket, _handshakes() if log is None else RateLimitedLog(log),
            "the manager at {}".format(endpoint), keys is not None, "console.key_secret", "manager.key")
        try:
            self.socket.connect(endpoint)
        except zmq.ZMQError as err:
            self.close()
            raise FleetError("cannot connect to a manager at {}: {}".format(endpoint, err.strerror)) from err

    @property
    def problem(self) -> Optional[str]:
        """Why the handshake with the manager fails (None: it does not, or not yet known)."""
        return self.handshake.problem

    def receive(self, budget: int = 1000) -> List[bytes]:
        self.handshake.check()  # a failing handshake is logged (once a minute) and kept in `problem`
        out: List[bytes] = []
        for _ in range(budget):
            try:
                out.append(self.socket.recv(zmq.NOBLOCK))
            except zmq.Again:
                break
        return out

    def send(self, data: bytes) -> None:
        try:
            self.socket.send(data, zmq.NOBLOCK)
        except zmq.Again:
            pass  # not connected yet: the session's heartbeat timing notices

    def close(self) -> None:
        self.handshake.close()
        self.socket.close(linger=0)
