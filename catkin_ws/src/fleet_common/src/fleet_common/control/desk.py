"""The manager's end of the console channel: who is connected, the version, the answers.

Pure, in the manner of `fleet_common.wire.connection`: the manager's socket
hands over (peer, bytes) and the desk answers with (peer, bytes) to send and,
for a request that may go ahead, the request itself. The manager carries it
out and calls `answer`. What the desk decides alone:

- a frame that does not decode gets an error `Answer` (id 0 when it has none)
  and nothing else happens; the peer is named in the returned `Refusal` so
  the manager can log it (rate-limited);
- a request from a console that has not said hello is refused;
- a request based on an older `version` than the desk's is refused, naming
  the changes made since (thesis 5.1.1: nobody acts on an outdated picture),
  except a request that only stops motion (`requests.STOPPING`: pause, stop,
  halt), which is safe on any picture;
- heartbeats: a console silent for 1 s is sent one; a console silent for
  `timeout` is forgotten (its socket identity may come back with a hello);
- States go to each console at most once per `min_interval` (`states`),
  whatever asks for them: requests, hellos and news together never make a
  console's stream faster than the manager's configured rate.

The version is the Lamport clock of the controlled state: `bump(why, robot)`
when the manager changes something a decision may rest on, naming the robot
it concerns (None: the whole run: its state, strategy or plan; a reroute
names the robots it gave new paths, `robots`: the others keep theirs, and a
manager rerouting automatically about once a plan step would otherwise make
most requests of a 300-robot run stale). A request
based on an older version is refused when a change since then concerns what
the request acts on: anything that concerns the whole run, or the robot the
request names. So an operator disabling robot 3 is refused if robot 3 failed
(or another console enabled it) since they looked, but not because robot 7's
link blinked; a strategy switch is refused after another switch or a pause,
not because a robot restarted. A console's own changes are no conflict for
it (`acting`: the console whose request the manager is carrying out): it knows
what it asked, so it may act again before the State that shows it arrives,
and that State keeps to the console's rate like any other.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any, Deque, Dict, FrozenSet, Iterable, List, Optional, Tuple

from ..wire.liveness import HEARTBEAT_INTERVAL, PEER_TIMEOUT, Liveness
from . import messages as m
from .codec import ControlProtocolError, decode, encode
from .requests import STOPPING, check_args
from ..schema import SchemaError

__all__ = ["ControlDesk", "Refusal", "Console"]

Peer = bytes
Out = List[Tuple[Peer, bytes]]


@dataclass
class Console:
    name: str
    live: Liveness
    requests: int = 0
    last_state: float = float("-inf")  # when it was last sent a State


@dataclass(frozen=True)
class Refusal:
    """A frame the desk refused, for the manager's log."""

    peer: Peer
    name: str
    reason: str


@dataclass
class Intake:
    """What one received frame led to."""

    out: Out = field(default_factory=list)
    request: Optional[m.Request] = None   # checked; the manager carries it out and answers
    args: Dict[str, Any] = field(default_factory=dict)
    joined: Optional[Peer] = None         # a console said hello: send it the scene
    refusal: Optional[Refusal] = None


class ControlDesk:
    """Consoles, the version clock, and the answers; see the module docstring."""

    def __init__(self, session: str, now: float, history: int = 64,
                 timeout: float = PEER_TIMEOUT, interval: float = HEARTBEAT_INTERVAL) -> None:
        self.session = session
        self.version = 1
        self.consoles: Dict[Peer, Console] = {}
        self.timeout = timeout
        self.interval = interval
        #: (version, why, the robots it concerns (None: the whole run), the console acting)
        self._changes: Deque[Tuple[int, str, Optional[FrozenSet[int]], Optional[Peer]]] = deque(maxlen=history)
        self._now = now
        #: the console whose request is being carried out (its changes are its own)
        self.acting: Optional[Peer] = None

    # ---- the clock ------------------------------------------------------------------------

    def bump(self, why: str, robot: Optional[int] = None, robots: Optional[Iterable[int]] = None) -> int:
        """The controlled state changed (`why`, for refusals), concerning `robot`, or `robots`
        (a reroute's: the robots given new paths), or, with neither, the whole run: the next
        version."""
        self.version += 1
        concerns = frozenset(robots) if robots is not None else None if robot is None else frozenset((robot,))
        self._changes.append((self.version, why, concerns, self.acting))
        return self.version

    def conflicts(self, version: int, robot: Optional[int], peer: Optional[Peer] = None) -> Optional[List[str]]:
        """The changes since `version` that concern a request on `robot` (None: on the whole
        run) from `peer` (its own changes do not count); None when they go back further than
        the desk remembers (all count)."""
        if version < self.version and (not self._changes or self._changes[0][0] > version + 1):
            return None
        return [why for v, why, concerns, by in self._changes
                if v > version and (concerns is None or (robot is not None and robot in concerns))
                and (by is None or by != peer)]

    # ---- frames in ----------------------------------------------------------------------

    def receive(self, peer: Peer, data: bytes, now: float) -> Intake:
        intake = Intake()
        console = self.consoles.get(peer)
        try:
            message = decode(data, m.CONSOLE_MESSAGES)
        except ControlProtocolError as err:
            reason = "not a valid console message: {}".format(err)
            intake.refusal = Refusal(peer, console.name if console else "", reason)
            intake.out.append((peer, encode(m.Answer(0, False, reason, self.version))))
            return intake
        if console is not None:
            console.live.heard(now)
        if isinstance(message, m.Hello):  # a console saying hello again keeps its State pace
            self.consoles[peer] = Console(message.name, Liveness(now, self.interval, self.timeout),
                                          last_state=console.last_state if console else float("-inf"))
            intake.out.append((peer, encode(m.Welcome(self.session, self.version))))
            intake.joined = peer
        elif isinstance(message, m.Bye):
            self.consoles.pop(peer, None)
        elif isinstance(message, m.Request):
            self._request(peer, console, message, intake)
        return intake

    def _request(self, peer: Peer, console: Optional[Console], request: m.Request,
                 intake: Intake) -> None:
        def refuse(reason: str) -> None:
            intake.out.append((peer, encode(m.Answer(request.id, False, reason, self.version))))

        if console is None:
            refuse(m.HELLO_FIRST + " (this manager does not know this console: it restarted, "
                   "or the console was silent too long)")
            intake.refusal = Refusal(peer, "", "request before hello")
            return
        console.requests += 1
        try:
            args = check_args(request.action, request.args)
        except SchemaError as err:
            refuse(str(err))
            return
        if request.based_on < self.version and request.action not in STOPPING:
            robot = args.get("robot") if request.action in ("enable", "disable", "source") else None
            changes = self.conflicts(request.based_on, robot, peer)
            if changes is None or changes:
                what = "; ".join(changes[-3:]) if changes else "older than this manager remembers"
                refuse("refused: the state changed since you looked (version {} -> {}: {}); "
                       "look again and retry".format(request.based_on, self.version, what))
                return
        if request.based_on > self.version:
            refuse("refused: version {} is newer than this manager's {} (a restarted "
                   "manager?); look again and retry".format(request.based_on, self.version))
            return
        intake.request = request
        intake.args = args

    # ---- frames out ---------------------------------------------------------------------

    def answer(self, peer: Peer, request: m.Request, ok: bool, reason: str = "") -> Out:
        return [(peer, encode(m.Answer(request.id, ok, reason, self.version)))]

    def broadcast(self, message: Any, now: Optional[float] = None) -> Out:
        """`message` to every console (encoded once)."""
        if not self.consoles:
            return []
        data = encode(message)
        for console in self.consoles.values():
            console.live.sent(self._now if now is None else now)
        return [(peer, data) for peer in self.consoles]

    def state_due(self, now: float, min_interval: float, only: Optional[Peer] = None) -> bool:
        """Would `states` send anything now (so that a State is built only when it goes out)?"""
        return any((only is None or peer == only) and now - c.last_state >= min_interval - 1e-9
                   for peer, c in self.consoles.items())

    def states(self, state: Any, now: float, min_interval: float, only: Optional[Peer] = None) -> Out:
        """`state` (a State) to every console (or `only`) not sent one in the last `min_interval`
        seconds (encoded once)."""
        due = [(peer, c) for peer, c in self.consoles.items()
               if (only is None or peer == only) and now - c.last_state >= min_interval - 1e-9]
        if not due:
            return []
        data = encode(state)
        for _, console in due:
            console.last_state = now
            console.live.sent(now)
        return [(peer, data) for peer, _ in due]

    def to(self, peer: Peer, message: Any) -> Out:
        return [(peer, encode(message))] if peer in self.consoles else []

    def tick(self, now: float) -> Out:
        """Heartbeats to quiet consoles; forget consoles silent for `timeout`."""
        self._now = now
        out: Out = []
        for peer, console in list(self.consoles.items()):
            if console.live.peer_gone(now):
                del self.consoles[peer]
            elif console.live.heartbeat_due(now):
                console.live.sent(now)
                out.append((peer, encode(m.Heartbeat())))
        return out
