"""Many robot links in one thread: one zmq.Poller and a heap of due times (and other sockets).

The manager talks to the whole fleet from one loop (300 virtual robots are 600
sockets, not 300 threads). A link replaces its sockets when it reconnects, so
after each call into a link the poller's registrations are brought in line
with `link.sockets()`.
"""
from __future__ import annotations

import heapq
import time
from typing import Any, Callable, Dict, Iterable, List, Tuple

import zmq

from .robot_link import LinkEvent, RobotLink

__all__ = ["LinkSet"]


class LinkSet:
    """Polls every link's sockets and ticks each link when it is due."""

    def __init__(self, links: Iterable[RobotLink], clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.links: Dict[int, RobotLink] = {link.robot_id: link for link in links}
        self.poller = zmq.Poller()
        self._registered: Dict[int, List[zmq.Socket]] = {}
        self._owner: Dict[zmq.Socket, RobotLink] = {}
        self._due: Dict[int, float] = {}
        self._heap: List[Tuple[float, int]] = []
        self._watched: Dict[Any, Callable[[], None]] = {}
        now = clock()
        for robot_id, link in self.links.items():
            self._sync(link)
            self._schedule(robot_id, now)

    def __getitem__(self, robot_id: int) -> RobotLink:
        return self.links[robot_id]

    def watch(self, sock: Any, on_readable: Callable[[], None]) -> None:
        """Also wait for `sock` (a zmq socket or a file descriptor) in `poll`, and call
        `on_readable()` when it is readable: the manager's one loop serves consoles and
        Vicon beside the robots."""
        self._watched[sock] = on_readable
        self.poller.register(sock, zmq.POLLIN)

    def poll(self, max_wait: float = 0.1) -> List[LinkEvent]:
        """Wait at most `max_wait` s for traffic or a due link; the events that came of it."""
        events: List[LinkEvent] = []
        now = self.clock()
        wait = max_wait if not self._heap else min(max_wait, max(0.0, self._heap[0][0] - now))
        for sock, _ in self.poller.poll(wait * 1000.0):
            watcher = self._watched.get(sock)
            if watcher is not None:
                watcher()
                continue
            link = self._owner.get(sock)
            if link is not None:
                events += link.handle(sock)
                self._sync(link)
                self._schedule(link.robot_id, self.clock())
        now = self.clock()
        while self._heap and self._heap[0][0] <= now:
            when, robot_id = heapq.heappop(self._heap)
            if self._due.get(robot_id) != when:
                continue
            del self._due[robot_id]
            link = self.links[robot_id]
            more, due = link.tick(now)
            events += more
            self._sync(link)
            self._schedule(robot_id, max(due, now + 0.001))  # never spin on one link
        return events

    def close(self) -> None:
        for link in self.links.values():
            link.close()
            self._sync(link)

    def _sync(self, link: RobotLink) -> None:
        now_socks = link.sockets()
        old = self._registered.get(link.robot_id, [])
        for sock in old:
            if not any(sock is s for s in now_socks):
                self.poller.unregister(sock)  # works on a closed socket too
                self._owner.pop(sock, None)
        for sock in now_socks:
            if not any(sock is s for s in old):
                self.poller.register(sock, zmq.POLLIN)
                self._owner[sock] = link
        self._registered[link.robot_id] = list(now_socks)

    def _schedule(self, robot_id: int, when: float) -> None:
        if robot_id in self._due and self._due[robot_id] <= when:
            return
        self._due[robot_id] = when
        heapq.heappush(self._heap, (when, robot_id))
