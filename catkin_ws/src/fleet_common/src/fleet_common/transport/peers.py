"""Who is on the other end of a socket, for the logs: peer addresses, the clients the CURVE
handshake refused (the server's side), and why our own handshake failed (the client's side).

libzmq tells a received frame's peer address ("Peer-Address" metadata). A
client that fails the CURVE handshake itself (it has no key, or not the
server's public key) never reaches the ZAP handler and sends no frame, so the
only trace of it is an event on the socket's monitor; libzmq 4.3 does not
say the client's address there, only the port it came to and why it failed
(or, when the client hung up first, as a keyless one may, not even that).

The client learns as much from its own monitor (`ClientHandshake`): the
server's ZAP handler refused its key (status 400), one side runs without
CURVE (a mechanism mismatch), or the server could not read its hello (the
server's public key it was given is not the server's: libzmq reports no
detail). Both sides log each cause once a minute, then a count.
"""
from __future__ import annotations

import logging
from typing import Optional

import zmq
from zmq.utils.monitor import parse_monitor_message

from ..ratelimit import RateLimitedLog

__all__ = ["peer_of", "HandshakeMonitor", "ClientHandshake"]

# handshake failures libzmq reports before ZAP is asked (ZAP logs its own refusals)
_EVENTS = zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
_CLIENT_EVENTS = _EVENTS | zmq.EVENT_HANDSHAKE_FAILED_AUTH | zmq.EVENT_HANDSHAKE_SUCCEEDED


def peer_of(frame: zmq.Frame) -> str:
    """The IP address a received frame came from, as libzmq knows it."""
    try:
        return frame.get("Peer-Address")
    except (zmq.ZMQError, AttributeError, TypeError):  # not a TCP peer (inproc)
        return "an unknown address"


class HandshakeMonitor:
    """Logs, through `refusals`, each client the handshake on `sock` refused (`server` names
    whose public key a client lacked: "this robot", "this manager")."""

    def __init__(self, sock: zmq.Socket, refusals: RateLimitedLog, server: str = "this robot",
                 curve: bool = True) -> None:
        self._watched: Optional[zmq.Socket] = sock
        self.socket = sock.get_monitor_socket(_EVENTS)
        self.refusals = refusals
        self.refused = 0  # for tests and status
        self._why = {
            zmq.PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH: "without a CURVE key" if curve else
            "with CURVE keys ({} runs without: --no-curve)".format(server),
            zmq.PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC: "that does not have {}'s public key".format(server),
        }

    def handle(self) -> None:
        """Log the events waiting (call when `socket` is readable)."""
        while True:
            try:
                frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                event = parse_monitor_message(frames)
            except Exception:  # libzmq's own frames; never let one stop the robot
                continue
            self.refused += 1
            if event["event"] == zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL:
                # the client gave up first: one without a key does when it sees the server's (which
                # end notices first is a race: one cause, one line)
                why = self._why[zmq.PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH]
            else:
                why = self._why.get(event["value"], "that failed the CURVE handshake")
            self.refusals.event(
                logging.WARNING, "clients " + why, "refused clients",
                "refused a client %s on %s; nothing from it is executed (libzmq does not say "
                "its address)", why, str(event["endpoint"], "utf-8", "replace"))

    def close(self) -> None:
        if self._watched is not None and not self._watched.closed:
            self._watched.disable_monitor()
        self._watched = None
        self.socket.close(linger=0)


class ClientHandshake:
    """Why the handshake of client socket `sock` with `server` (a name for the logs) fails, from
    the socket's monitor: `check()` logs each cause through `refusals` (once a minute, then a
    count) and keeps the last in `problem` (None once a handshake succeeds). `key` and
    `server_key` name the key files the client used, for the advice."""

    def __init__(self, sock: zmq.Socket, refusals: RateLimitedLog, server: str, curve: bool,
                 key: str = "our key", server_key: str = "its public key") -> None:
        self._watched: Optional[zmq.Socket] = sock
        self.socket = sock.get_monitor_socket(_CLIENT_EVENTS)
        self.refusals = refusals
        self.server = server
        self.curve = curve
        self.key, self.server_key = key, server_key
        self.problem: Optional[str] = None
        self.failures = 0  # for tests and status

    def check(self) -> Optional[str]:
        """Read the monitor's events; the newest problem (None: none, or a handshake succeeded)."""
        while True:
            try:
                frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return self.problem
            except zmq.ZMQError:
                return self.problem
            try:
                event = parse_monitor_message(frames)
            except Exception:  # libzmq's own frames; never let one stop the caller
                continue
            if event["event"] == zmq.EVENT_HANDSHAKE_SUCCEEDED:
                self.problem = None
                continue
            self.failures += 1
            self.problem = self._describe(event["event"], event["value"])
            self.refusals.event(logging.WARNING, "{} ({})".format(self.server, self.problem),  # each cause
                                "failed handshakes", "%s", self.problem)

    def _describe(self, kind: int, value: int) -> str:
        if kind == zmq.EVENT_HANDSHAKE_FAILED_AUTH:
            return "{} refused our key (status {}): {} is not a key it was given".format(
                self.server, value, self.key)
        mismatch = kind == zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL and value == zmq.PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH
        if mismatch or (kind == zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL and not self.curve):
            # (without keys, which end notices first is a race: the server may just hang up)
            return ("{} {}: both sides need CURVE keys, or both --no-curve".format(
                self.server, "runs without CURVE keys and we have them" if self.curve
                else "wants CURVE keys and we run without (--no-curve)"))
        if kind == zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL:
            return ("the CURVE handshake with {} failed: {} is probably not its public key (or "
                    "it holds another key pair)".format(self.server, self.server_key))
        return "the handshake with {} failed (libzmq event {}, {})".format(self.server, kind, value)

    def close(self) -> None:
        if self._watched is not None and not self._watched.closed:
            try:
                self._watched.disable_monitor()
            except zmq.ZMQError:
                pass
        self._watched = None
        self.socket.close(linger=0)
