"""Who may connect: a ZAP handler (ZeroMQ RFC 27) run from the robot's own poll loop.

With CURVE, libzmq asks the context's ZAP handler (a REP socket bound to
inproc://zeromq.zap.01) about every client that completes the handshake,
passing its public key. This handler allows the keys it was given for the
socket's ZAP domain and refuses the rest, logging each refused address
with the key it offered (a refused client keeps reconnecting, perhaps with a
new key each time: once a minute per domain and address, then a count,
through `RateLimitedLog`; `flush` says the counts, so call it now and then). A request it cannot read,
or a failure of its own, is answered 500 and logged: the REP socket must
always answer, or no client would ever be admitted again. Served from the
caller's loop, not a thread, so one handler serves 300 virtual robots in one
process.

Clients that fail the CURVE handshake itself (no key at all, or not this
robot's public key) never reach ZAP; the robot endpoint logs those from its
socket monitor.
"""
from __future__ import annotations

import logging
from typing import Callable, Dict, List, Set

import zmq
from zmq.utils import z85

from ..ratelimit import RateLimitedLog

__all__ = ["ZapHandler", "ZAP_ENDPOINT"]

ZAP_ENDPOINT = "inproc://zeromq.zap.01"


class ZapHandler:
    """Allows, per ZAP domain, only the CURVE public keys given to `allow`."""

    def __init__(self, context: zmq.Context, log: logging.Logger,
                 clock: Callable[[], float]) -> None:
        self.socket = context.socket(zmq.REP)
        self.socket.linger = 0
        self.socket.bind(ZAP_ENDPOINT)  # one per context: a second bind fails loudly
        self.log = log
        self.clock = clock
        self.refusals = RateLimitedLog(log, clock=clock)
        self._allowed: Dict[str, Set[bytes]] = {}
        self._expected: Dict[str, str] = {}
        self.refused = 0  # refusals so far, for tests and status

    def allow(self, domain: str, z85_keys: List[bytes], expected: str = "the manager key it was given") -> None:
        """Clients of sockets with `zap_domain == domain` must have one of these keys (`expected`
        says which, for the log)."""
        self._allowed[domain] = {z85.decode(k) for k in z85_keys}
        self._expected[domain] = expected

    def handle(self) -> None:
        """Answer every request waiting on the socket (call when it is readable)."""
        while True:
            try:
                frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:
                answer = self._answer(frames)
            except Exception:  # never leave the REP socket without its answer
                self.log.exception("ZAP handler failed on a request; refusing it")
                answer = self._refusal(frames, b"500", b"internal error")
            self.socket.send_multipart(answer)

    def flush(self) -> None:
        """Log the counts of refusals held back (call now and then)."""
        self.refusals.flush()

    def _answer(self, frames: List[bytes]) -> List[bytes]:
        if len(frames) < 6 or frames[0] != b"1.0":
            self.refusals.event(logging.ERROR, "ZAP", "malformed ZAP requests",
                                "malformed ZAP request (%d frames); refusing", len(frames))
            return self._refusal(frames, b"500", b"malformed request")
        _, request_id, domain_b, address_b, _, mechanism = frames[:6]
        # domain, address and mechanism come from libzmq, not from the client
        domain, address = domain_b.decode("utf-8", "replace"), address_b.decode("utf-8", "replace")
        key = frames[6] if mechanism == b"CURVE" and len(frames) > 6 else b""
        if key and key in self._allowed.get(domain, ()):
            return [b"1.0", request_id, b"200", b"OK", b"manager", b""]
        self.refused += 1
        shown = (z85.encode(key).decode("ascii") if len(key) == 32
                 else "(mechanism {})".format(mechanism.decode("ascii", "replace")))
        self.refusals.event(
            logging.WARNING, "{} to {}".format(address, domain),
            "refused connections", "%s: refused a connection from %s with key %s: not %s; "
            "nothing from it is executed", domain, address, shown,
            self._expected.get(domain, "a key it was given"))
        return [b"1.0", request_id, b"400", b"key not allowed", b"", b""]

    @staticmethod
    def _refusal(frames: List[bytes], status: bytes, text: bytes) -> List[bytes]:
        request_id = frames[1] if len(frames) > 1 else b""
        return [b"1.0", request_id, status, text, b"", b""]
