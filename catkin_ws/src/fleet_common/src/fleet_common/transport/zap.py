"""Who may connect: a ZAP handler (ZeroMQ RFC 27) run from the robot's own poll loop.

With CURVE, libzmq asks the context's ZAP handler (a REP socket bound to
inproc://zeromq.zap.01) about every client that completes the handshake,
passing its public key. This handler allows the keys it was given for the
socket's ZAP domain and refuses the rest, logging each refused key (once a
minute per key and domain: a refused client keeps reconnecting). Served from
the caller's loop, not a thread, so one handler serves 300 virtual robots in
one process.
"""
from __future__ import annotations

import logging
from typing import Callable, Dict, List, Set, Tuple

import zmq
from zmq.utils import z85

__all__ = ["ZapHandler", "ZAP_ENDPOINT"]

ZAP_ENDPOINT = "inproc://zeromq.zap.01"
_LOG_EVERY = 60.0


class ZapHandler:
    """Allows, per ZAP domain, only the CURVE public keys given to `allow`."""

    def __init__(self, context: zmq.Context, log: logging.Logger,
                 clock: Callable[[], float]) -> None:
        self.socket = context.socket(zmq.REP)
        self.socket.linger = 0
        self.socket.bind(ZAP_ENDPOINT)  # one per context: a second bind fails loudly
        self.log = log
        self.clock = clock
        self._allowed: Dict[str, Set[bytes]] = {}
        self._logged: Dict[Tuple[str, bytes], float] = {}
        self.refused = 0  # refusals so far, for tests and status

    def allow(self, domain: str, z85_keys: List[bytes]) -> None:
        """Clients of sockets with `zap_domain == domain` must have one of these keys."""
        self._allowed[domain] = {z85.decode(k) for k in z85_keys}

    def handle(self) -> None:
        """Answer every request waiting on the socket (call when it is readable)."""
        while True:
            try:
                frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            self.socket.send_multipart(self._answer(frames))

    def _answer(self, frames: List[bytes]) -> List[bytes]:
        if len(frames) < 6 or frames[0] != b"1.0":
            self.log.error("malformed ZAP request (%d frames); refusing", len(frames))
            request_id = frames[1] if len(frames) > 1 else b""
            return [b"1.0", request_id, b"500", b"malformed request", b"", b""]
        _, request_id, domain_b, address_b, _, mechanism = frames[:6]
        domain, address = domain_b.decode("utf-8", "replace"), address_b.decode("utf-8", "replace")
        key = frames[6] if mechanism == b"CURVE" and len(frames) > 6 else b""
        if key and key in self._allowed.get(domain, ()):
            return [b"1.0", request_id, b"200", b"OK", b"manager", b""]
        self.refused += 1
        shown = z85.encode(key).decode("ascii") if len(key) == 32 else mechanism.decode("ascii", "replace")
        now = self.clock()
        if now - self._logged.get((domain, key), -_LOG_EVERY) >= _LOG_EVERY:
            self._logged[(domain, key)] = now
            self.log.warning("%s: refused a connection from %s with key %s: not the manager key "
                             "it was given; nothing from it is executed", domain, address, shown)
        return [b"1.0", request_id, b"400", b"key not allowed", b"", b""]
