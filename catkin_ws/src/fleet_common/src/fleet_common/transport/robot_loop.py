"""Many robot endpoints served from one thread: one zmq.Poller and a heap of due times.

Each endpoint says when it next needs a `tick` (a heartbeat, a pose to
publish, a motion about to end); the loop sleeps in `poll` until a socket is
readable or the earliest due time, so idle robots cost nothing. The context's
ZAP handler and the endpoints' handshake monitors are served from the same loop.

The loop is the last boundary: an endpoint that raises (a bug, a navigator
that fails) is logged and served again at its next turn; the others never
notice.
"""
from __future__ import annotations

import heapq
import logging
import math
import time
from typing import TYPE_CHECKING, Any, Callable, Dict, List, Optional, Tuple

import zmq

from ..ratelimit import RateLimitedLog
from .zap import ZapHandler

if TYPE_CHECKING:
    from .robot_endpoint import RobotEndpoint

__all__ = ["RobotLoop", "QUANTUM"]

#: Due times are rounded up to this grid (s): 300 robots publishing poses 10 times a second
#: each would otherwise wake the loop 3,000 times a second, each wake-up polling every
#: socket; on the grid they share at most 200 wake-ups, for at most 5 ms of lateness.
QUANTUM = 0.005

_RETRY = 1.0  # seconds before an endpoint whose tick failed is ticked again


class RobotLoop:
    """Runs endpoints (and the ZAP handler) in the calling thread."""

    def __init__(self, zap: Optional[ZapHandler] = None,
                 clock: Callable[[], float] = time.monotonic,
                 log: Optional[logging.Logger] = None) -> None:
        self.zap = zap
        self.clock = clock
        self.failures = RateLimitedLog(log or logging.getLogger("fleet_common.transport.robot_loop"),
                                       clock=clock)
        self.poller = zmq.Poller()
        self.by_socket: Dict[zmq.Socket, RobotEndpoint] = {}
        self.monitors: Dict[zmq.Socket, RobotEndpoint] = {}
        self._next_flush = clock()
        self.due: Dict[int, float] = {}
        self.endpoints: Dict[int, RobotEndpoint] = {}
        self.heap: List[Tuple[float, int]] = []
        if zap is not None:
            self.poller.register(zap.socket, zmq.POLLIN)

    def add(self, endpoint: RobotEndpoint) -> None:
        key = id(endpoint)
        self.endpoints[key] = endpoint
        self.by_socket[endpoint.command] = endpoint
        self.poller.register(endpoint.command, zmq.POLLIN)
        if endpoint.monitor is not None:
            self.monitors[endpoint.monitor.socket] = endpoint
            self.poller.register(endpoint.monitor.socket, zmq.POLLIN)
        self._schedule(key, self.clock())

    def remove(self, endpoint: RobotEndpoint) -> None:
        """Stop serving `endpoint` (closing it is the caller's business)."""
        key = id(endpoint)
        self.endpoints.pop(key, None)
        self.due.pop(key, None)
        if self.by_socket.pop(endpoint.command, None) is not None:
            self.poller.unregister(endpoint.command)
        for sock in [s for s, e in self.monitors.items() if e is endpoint]:
            del self.monitors[sock]
            self.poller.unregister(sock)

    def run_once(self, max_wait: float = 0.1) -> None:
        """Wait (at most `max_wait` s) for a socket or a due time, and serve it."""
        now = self.clock()
        wait = max_wait if not self.heap else min(max_wait, max(0.0, self.heap[0][0] - now))
        for sock, _ in self.poller.poll(wait * 1000.0):
            if self.zap is not None and sock is self.zap.socket:
                self._guard(None, self.zap.handle)
            elif sock in self.monitors:
                self._guard(self.monitors[sock], self.monitors[sock].monitor.handle)
            elif sock in self.by_socket:
                endpoint = self.by_socket[sock]
                self._guard(endpoint, endpoint.handle_readable)
                self._schedule(id(endpoint), self.clock())  # replies and new motions: tick now
        now = self.clock()
        while self.heap and self.heap[0][0] <= now:
            when, key = heapq.heappop(self.heap)
            if self.due.get(key) != when:
                continue  # rescheduled or removed since
            del self.due[key]
            endpoint = self.endpoints[key]
            due = self._guard(endpoint, lambda: endpoint.tick(now))
            self._schedule(key, max(now + _RETRY if due is None else due, now + 0.001))
        if now >= self._next_flush:
            self._next_flush = now + 1.0
            self.failures.flush(now)
            if self.zap is not None:
                self._guard(None, self.zap.flush)

    def run(self, should_stop: Callable[[], bool], max_wait: float = 0.1) -> None:
        while not should_stop():
            self.run_once(max_wait)

    def _guard(self, endpoint: Optional["RobotEndpoint"], call: Callable[[], Any]) -> Any:
        """`call()`, or None after logging what it raised: one robot's failure is its own
        (logged once a minute per robot, then counted)."""
        try:
            return call()
        except Exception:
            what = "the ZAP handler" if endpoint is None else "robot {}".format(endpoint.robot_id)
            self.failures.event(logging.ERROR, what, "failures", "%s failed; serving on", what,
                                exc_info=True)
            return None

    def _schedule(self, key: int, when: float) -> None:
        when = math.ceil(when / QUANTUM) * QUANTUM  # robots due together wake the loop once
        if key in self.due and self.due[key] <= when:
            return  # already due sooner
        self.due[key] = when
        heapq.heappush(self.heap, (when, key))
