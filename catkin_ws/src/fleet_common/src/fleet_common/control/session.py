"""The console's end of the console channel: what it has seen and what it asked.

Pure: the console's network thread feeds it the manager's frames and sends
what it returns; the Tk thread reads the outcome from a queue. It keeps the
newest run setup, state and proposal, the last notices (by sequence number,
once each), and the requests still waiting for an answer. A request is based on
the newest version seen in any Welcome, State or Answer, so a console that
acts on an old picture is refused by the manager and says so.

A manager silent for `timeout` seconds is lost (`lost(now)`); the console
says so and says hello again (`reset` then `hello`) until one answers. A
manager that does not know the console (it restarted, or forgot a console
silent too long) refuses its requests with `HELLO_FIRST`; the session is then
no longer `connected` and the console says hello again.
"""
from __future__ import annotations

import itertools
from collections import deque
from typing import Any, Deque, Dict, Optional, Tuple

from ..wire.liveness import HEARTBEAT_INTERVAL, PEER_TIMEOUT, Liveness
from . import messages as m
from ..limits import MAX_MANAGER_BYTES
from .codec import decode, encode

__all__ = ["ConsoleSession"]


class ConsoleSession:
    def __init__(self, name: str, now: float, timeout: float = PEER_TIMEOUT,
                 interval: float = HEARTBEAT_INTERVAL, notices: int = 500) -> None:
        self.name = name
        self.timeout, self.interval = timeout, interval
        self.notices: Deque[m.Notice] = deque(maxlen=notices)
        self._ids = itertools.count(1)
        self.reset(now)

    def reset(self, now: float) -> None:
        """Forget the manager (it went away): start over with a hello."""
        self.session: Optional[str] = None
        self.version = 0
        self.setup: Optional[m.RunSetup] = None
        self.state: Optional[m.State] = None
        self.proposal: Optional[m.Proposal] = None
        self.pending: Dict[int, m.Request] = {}
        self.live = Liveness(now, self.interval, self.timeout)
        self._last_notice = 0

    @property
    def connected(self) -> bool:
        return self.session is not None

    def hello(self, now: float) -> bytes:
        self.live.sent(now)
        return encode(m.Hello(self.name))

    def request(self, action: str, now: float, based_on: Optional[int] = None,
                **args: Any) -> Tuple[m.Request, bytes]:
        """A request for `action`; (request, frame). It is based on `based_on`, the version of
        the state the operator looked at (a window shows states a little after they arrive),
        or else on the newest version seen."""
        request = m.Request(next(self._ids), action, dict(args),
                            self.version if based_on is None else based_on)
        self.pending[request.id] = request
        self.live.sent(now)
        return request, encode(request)

    def receive(self, data: bytes, now: float) -> Any:
        """The manager's message in `data` (ControlProtocolError if it is not one); updates
        what the session knows. An `Answer` comes back as (answer, the request it answers)."""
        message = decode(data, m.MANAGER_MESSAGES, MAX_MANAGER_BYTES)
        self.live.heard(now)
        if isinstance(message, m.Welcome):
            if self.session is not None and message.session != self.session:
                self.reset(now)  # another manager process: what we knew is void
                self.live.heard(now)
            self.session = message.session
            self.version = max(self.version, message.version)
        elif isinstance(message, m.RunSetup):
            self.setup = message
            self.proposal = None
        elif isinstance(message, m.State):
            if self.state is None or message.seq > self.state.seq:
                self.state = message
            self.version = max(self.version, message.version)
            if message.run.proposal is None:
                self.proposal = None
        elif isinstance(message, m.Answer):
            self.version = max(self.version, message.version)
            asked = self.pending.pop(message.id, None)
            if not message.ok and message.reason.startswith(m.HELLO_FIRST):
                self.session = None  # the manager forgot us: `connected` is False, say hello again
            return message, asked
        elif isinstance(message, m.Notice):
            if message.seq <= self._last_notice:
                return None  # seen already
            self._last_notice = message.seq
            self.notices.append(message)
        elif isinstance(message, m.Proposal):
            self.proposal = message
        elif isinstance(message, m.Bye):
            self.reset(now)
        return message

    def heartbeat(self, now: float) -> Optional[bytes]:
        """A heartbeat frame if one is due."""
        if self.session is None or not self.live.heartbeat_due(now):
            return None
        self.live.sent(now)
        return encode(m.Heartbeat())

    def lost(self, now: float) -> bool:
        """The manager has been silent for `timeout` seconds."""
        return self.live.peer_gone(now)
