"""Many robot links in one thread: one zmq.Poller and a heap of due times (and other sockets).

The manager talks to the whole fleet from one loop (300 virtual robots are 600
sockets, not 300 threads). A link replaces its sockets when it reconnects, so
after each call into a link the poller's registrations are brought in line
with its sockets. Only the command sockets are polled: the pose streams (10
frames a second from every robot, so some socket is always readable) are
read every `FEEDBACK_PERIOD` instead, the newest pose of each robot, which
halves what each poll must look at (its cost grows with the sockets).

The set is a boundary: a link that raises (a bug, whatever a robot sent) is
logged (once a minute per robot, then a count) and served again at its next
turn; the other links never notice.
"""
from __future__ import annotations

import heapq
import logging
import math
import time
from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple

import zmq

from ..ratelimit import RateLimitedLog
from .robot_link import LinkEvent, RobotLink

__all__ = ["LinkSet"]

_RETRY = 1.0  # seconds before a link whose tick failed is ticked again
#: Seconds between reads of the robots' pose streams (a pose waits at most this long).
FEEDBACK_PERIOD = 0.05
#: Due times of links on this grid (s): what is due is heartbeats and timeouts, seconds apart,
#: and 300 links' due times spread over a second would otherwise wake the loop hundreds of
#: times a second, each wake-up polling every command socket.
TICK_GRID = 0.05
_POLLIN = int(zmq.POLLIN)


class LinkSet:
    """Polls every link's sockets and ticks each link when it is due."""

    def __init__(self, links: Iterable[RobotLink], clock: Callable[[], float] = time.monotonic,
                 log: Optional[logging.Logger] = None) -> None:
        self.clock = clock
        self.failures = RateLimitedLog(log or logging.getLogger("fleet_common.transport.links"),
                                       clock=clock)
        self.links: Dict[int, RobotLink] = {link.robot_id: link for link in links}
        self.poller = zmq.Poller()
        self._registered: Dict[int, List[zmq.Socket]] = {}
        self._owner: Dict[zmq.Socket, RobotLink] = {}
        self._due: Dict[int, float] = {}
        self._heap: List[Tuple[float, int]] = []
        self._watched: Dict[Any, Callable[[], None]] = {}
        self._generation: Dict[int, int] = {}  # robot id -> its link's sockets as registered
        now = clock()
        self._next_drain = now
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

    def poll(self, max_wait: float = 0.1, drain: bool = True) -> List[LinkEvent]:
        """Wait at most `max_wait` s for traffic or a due link; the events that came of it.
        With `drain`, the pose streams are read too when they are due; without, the caller
        reads them (`drain_poses`) when it has nothing more urgent to do."""
        events: List[LinkEvent] = []
        now = self.clock()
        wait = max_wait if not self._heap else min(max_wait, max(0.0, self._heap[0][0] - now))
        if drain:
            wait = min(wait, max(0.0, self._next_drain - now))
        for sock, _ in self.poller.poll(wait * 1000.0):
            watcher = self._watched.get(sock)
            if watcher is not None:
                try:
                    watcher()
                except Exception:  # a console or Vicon handler's bug: logged, the fleet goes on
                    self.failures.event(logging.ERROR, "watched {!r}".format(sock), "failures",
                                        "%s: handler failed; serving on", sock, exc_info=True)
                continue
            link = self._owner.get(sock)
            if link is not None:
                command = sock is link.command
                events += self._guard(link, "handling a frame", lambda: link.handle(sock)) or []
                self._sync(link)
                if command:  # a welcome or a bye changes what is due; a pose never does
                    self._schedule(link.robot_id, self.clock())
        now = self.clock()
        while self._heap and self._heap[0][0] <= now:
            when, robot_id = heapq.heappop(self._heap)
            if self._due.get(robot_id) != when:
                continue
            del self._due[robot_id]
            link = self.links[robot_id]
            ticked = self._guard(link, "ticking", lambda: link.tick(now))
            more, due = ticked if ticked is not None else ([], now + _RETRY)
            events += more
            self._sync(link)
            self._schedule(robot_id, max(due, now + 0.001))  # never spin on one link
        if drain and now >= self._next_drain:
            events += self.drain_poses()
        self.failures.flush(now)
        return events

    @property
    def next_drain(self) -> float:
        """When the pose streams are next due to be read."""
        return self._next_drain

    def drain_poses(self) -> List[LinkEvent]:
        """The newest pose of each robot whose stream has one waiting."""
        self._next_drain = self.clock() + FEEDBACK_PERIOD
        events: List[LinkEvent] = []
        for link in self.links.values():
            sock = link.feedback
            if sock is None:
                continue
            try:
                # a plain int test: pyzmq's flag enum would cost more than the rest together
                if not int(sock.getsockopt(zmq.EVENTS)) & _POLLIN:
                    continue
                events += link.handle(sock)
            except Exception:
                self.failures.event(logging.ERROR, "robot {}".format(link.robot_id), "failures",
                                    "robot %s: link failed reading poses; serving on",
                                    link.robot_id, exc_info=True)
            self._sync(link)
        return events

    def close(self) -> None:
        for link in self.links.values():
            link.close()
            self._sync(link)

    def _guard(self, link: RobotLink, doing: str, call: Callable[[], Any]) -> Any:
        """`call()`, or None after logging what it raised: one robot's failure is its own."""
        try:
            return call()
        except Exception:
            what = "robot {}".format(link.robot_id)
            self.failures.event(logging.ERROR, what, "failures", "%s: link failed %s; serving on",
                                what, doing, exc_info=True)
            return None

    def _sync(self, link: RobotLink) -> None:
        if self._generation.get(link.robot_id) == link.generation:
            return  # the same sockets as registered
        self._generation[link.robot_id] = link.generation
        now_socks = [link.command] if link.command is not None else []  # see the docstring
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
        when = math.ceil(when / TICK_GRID) * TICK_GRID  # links due together wake the loop once
        if robot_id in self._due and self._due[robot_id] <= when:
            return
        self._due[robot_id] = when
        heapq.heappush(self._heap, (when, robot_id))
