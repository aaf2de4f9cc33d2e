"""Many robot endpoints served from one thread: one zmq.Poller and a heap of due times.

Each endpoint says when it next needs a `tick` (a heartbeat, a pose to
publish, a motion about to end); the loop sleeps in `poll` until a socket is
readable or the earliest due time, so idle robots cost nothing. The context's
ZAP handler is served from the same loop.
"""
from __future__ import annotations

import heapq
import time
from typing import TYPE_CHECKING, Callable, Dict, List, Optional, Tuple

import zmq

from .zap import ZapHandler

if TYPE_CHECKING:
    from .robot_endpoint import RobotEndpoint

__all__ = ["RobotLoop"]


class RobotLoop:
    """Runs endpoints (and the ZAP handler) in the calling thread."""

    def __init__(self, zap: Optional[ZapHandler] = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.zap = zap
        self.clock = clock
        self.poller = zmq.Poller()
        self.by_socket: Dict[zmq.Socket, RobotEndpoint] = {}
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
        self._schedule(key, self.clock())

    def remove(self, endpoint: RobotEndpoint) -> None:
        """Stop serving `endpoint` (closing it is the caller's business)."""
        key = id(endpoint)
        self.endpoints.pop(key, None)
        self.due.pop(key, None)
        if self.by_socket.pop(endpoint.command, None) is not None:
            self.poller.unregister(endpoint.command)

    def run_once(self, max_wait: float = 0.1) -> None:
        """Wait (at most `max_wait` s) for a socket or a due time, and serve it."""
        now = self.clock()
        wait = max_wait if not self.heap else min(max_wait, max(0.0, self.heap[0][0] - now))
        for sock, _ in self.poller.poll(wait * 1000.0):
            if self.zap is not None and sock is self.zap.socket:
                self.zap.handle()
                continue
            endpoint = self.by_socket.get(sock)
            if endpoint is not None:
                endpoint.handle_readable()
                self._schedule(id(endpoint), self.clock())  # replies and new motions: tick now
        now = self.clock()
        while self.heap and self.heap[0][0] <= now:
            when, key = heapq.heappop(self.heap)
            if self.due.get(key) != when:
                continue  # rescheduled or removed since
            del self.due[key]
            self._schedule(key, max(self.endpoints[key].tick(now), now + 0.001))

    def run(self, should_stop: Callable[[], bool], max_wait: float = 0.1) -> None:
        while not should_stop():
            self.run_once(max_wait)

    def _schedule(self, key: int, when: float) -> None:
        if key in self.due and self.due[key] <= when:
            return  # already due sooner
        self.due[key] = when
        heapq.heappush(self.heap, (when, key))
