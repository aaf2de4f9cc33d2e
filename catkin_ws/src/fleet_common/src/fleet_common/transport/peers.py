"""Who is on the other end of a robot's socket, for the logs: peer addresses and the clients
the CURVE handshake refused.

libzmq tells a received frame's peer address ("Peer-Address" metadata). A
client that fails the CURVE handshake itself (it has no key, or not this
robot's public key) never reaches the ZAP handler and sends no frame, so the
only trace of it is an event on the socket's monitor; libzmq 4.3 does not
say the client's address there, only the port it came to and why it failed
(or, when the client hung up first, as a keyless one may, not even that).
"""
from __future__ import annotations

import logging
from typing import Optional

import zmq
from zmq.utils.monitor import parse_monitor_message

from ..ratelimit import RateLimitedLog

__all__ = ["peer_of", "HandshakeMonitor"]

# handshake failures libzmq reports before ZAP is asked (ZAP logs its own refusals)
_EVENTS = zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
_WHY = {
    zmq.PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH: "without a CURVE key",
    zmq.PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC: "that does not have this robot's public key",
}


def peer_of(frame: zmq.Frame) -> str:
    """The IP address a received frame came from, as libzmq knows it."""
    try:
        return frame.get("Peer-Address")
    except (zmq.ZMQError, AttributeError, TypeError):  # not a TCP peer (inproc)
        return "an unknown address"


class HandshakeMonitor:
    """Logs, through `refusals`, each client the handshake on `sock` refused."""

    def __init__(self, sock: zmq.Socket, refusals: RateLimitedLog) -> None:
        self._watched: Optional[zmq.Socket] = sock
        self.socket = sock.get_monitor_socket(_EVENTS)
        self.refusals = refusals
        self.refused = 0  # for tests and status

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
                # the client gave up first: one without a key does when it sees the robot's
                why = "that broke off the CURVE handshake (as one without a key does)"
            else:
                why = _WHY.get(event["value"], "that failed the CURVE handshake")
            self.refusals.event(
                logging.WARNING, "clients " + why, "refused clients",
                "refused a client %s on %s; nothing from it is executed (libzmq does not say "
                "its address)", why, str(event["endpoint"], "utf-8", "replace"))

    def close(self) -> None:
        if self._watched is not None and not self._watched.closed:
            self._watched.disable_monitor()
        self._watched = None
        self.socket.close(linger=0)
