"""ManagerLink: the console's network thread, its only door to the manager.

The thread owns the ZeroMQ socket (`fleet_common.transport.console_channel.
ConsoleClient`) and the protocol state (`fleet_common.control.ConsoleSession`);
nothing else touches either. It says hello, passes every decoded message to
the `LiveFeed` for the Tk thread, sends heartbeats, and sends the requests the
Tk thread hands over with `request()` (which only appends to a deque, so a
button press never waits on the network).

Theory of operation, the connection's life:

- not connected: a hello every `hello_every` seconds, each on a fresh socket,
  so hellos never pile up in a socket's queue while no manager listens; when
  nothing has answered for `no_answer` seconds the console says that the port
  or the keys are wrong (a CurveZMQ manager drops a console without the right
  keys in silence, exactly as an empty port does), and keeps trying;
- Welcome: connected (the session remembers the manager's session id);
- silence for the session's timeout, or a Bye: lost. Requests still waiting
  get a Reply saying they were never answered, the session is reset, and
  the hellos start again, so a restarted manager is found by itself.

The thread polls its socket with a short timeout (`poll_s`): a State is
passed on as soon as it arrives, a request waits at most that long. Of
several States waiting at once only the newest is decoded (`newest_states`).
"""
from __future__ import annotations

import logging
import threading
import time
from collections import deque
from typing import Any, Callable, Deque, Dict, List, Optional, Tuple

import zmq

from fleet_common.control import Answer, Bye, ControlProtocolError, Request, Welcome
from fleet_common.control.session import ConsoleSession
from fleet_common.errors import FleetError
from fleet_common.transport.console_channel import ConsoleClient
from fleet_common.transport.curve_keys import ConsoleKeys
from fleet_common.wire.liveness import PEER_TIMEOUT

from .feed import CONNECTED, CONNECTING, LOST, LinkStatus, LiveFeed, Reply, Trouble

__all__ = ["ManagerLink", "NO_ANSWER"]

log = logging.getLogger(__name__)

#: Seconds of unanswered hellos before the console says the port or the keys are wrong.
NO_ANSWER = 5.0


class ManagerLink:
    def __init__(self, endpoint: str, feed: LiveFeed, *, keys: Optional[ConsoleKeys] = None,
                 name: str = "console", hello_every: float = 1.0, poll_s: float = 0.01,
                 timeout: float = PEER_TIMEOUT, clock: Callable[[], float] = time.monotonic,
                 no_answer: float = NO_ANSWER) -> None:
        self.endpoint = endpoint
        self.feed = feed
        self.keys = keys
        self.name = name
        self.hello_every = hello_every
        self.poll_s = poll_s
        self.timeout = timeout  # seconds of silence after which the manager counts as lost
        self.no_answer = no_answer  # seconds of hellos unanswered before the console says why
        self.clock = clock
        self._outbox: Deque[Tuple[str, Optional[int], Dict[str, Any]]] = deque()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="manager-link", daemon=True)

    # ---- the Tk thread's side ---------------------------------------------------------------

    def start(self) -> "ManagerLink":
        self._thread.start()
        return self

    def request(self, action: str, based_on: Optional[int] = None, **args: Any) -> None:
        """Ask the manager for `action`, based on the version of the state the operator saw
        (None: the newest this thread has); the answer comes back on the feed as a `Reply`."""
        self._outbox.append((action, based_on, args))

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)

    # ---- the network thread -----------------------------------------------------------------

    def _run(self) -> None:
        context = zmq.Context()
        client: Optional[ConsoleClient] = None
        try:
            now = self.clock()
            session = ConsoleSession(self.name, now, timeout=self.timeout)
            self._offer(LinkStatus(CONNECTING, "connecting to the manager at {}".format(self.endpoint)), now)
            next_hello = now
            was_connected = False
            asking_since: Optional[float] = now  # hellos unanswered since
            while not self._stop.is_set():
                now = self.clock()
                if not session.connected and now >= next_hello:
                    client = self._fresh(context, client)
                    if client is None:
                        return  # an endpoint that cannot be: said, and nothing more to try
                    client.send(session.hello(now))
                    next_hello = now + self.hello_every
                if session.connected:
                    asking_since = None
                elif asking_since is None:
                    asking_since = now
                elif now - asking_since >= self.no_answer:
                    asking_since = float("inf")  # said once until a manager answers
                    self._offer(LinkStatus(LOST if was_connected else CONNECTING, self._silence()), now)
                if client is not None and client.socket.poll(int(self.poll_s * 1000), zmq.POLLIN):
                    for frame in newest_states(client.receive()):
                        was_connected = self._receive(session, frame, was_connected)
                now = self.clock()
                if client is not None:
                    self._send_requests(session, client, now)
                    beat = session.heartbeat(now)
                    if beat is not None:
                        client.send(beat)
                if session.connected and session.lost(now):
                    self._lose(session, "manager lost: nothing heard for {:g} s; reconnecting".format(
                        session.timeout), now)
                    next_hello = now
        except Exception:  # the thread must say why it ended, not vanish
            log.exception("the manager link failed")
            self._offer(LinkStatus(LOST, "console network thread failed (see the log)"), self.clock())
        finally:
            if client is not None:
                client.close()
            context.destroy(linger=0)

    def _fresh(self, context: zmq.Context, old: Optional[ConsoleClient]) -> Optional[ConsoleClient]:
        if old is not None:
            old.close()
        try:
            return ConsoleClient(context, self.endpoint, keys=self.keys)
        except FleetError as err:
            self._offer(LinkStatus(LOST, "{} (a manager endpoint is HOST:PORT or tcp://HOST:PORT)".format(err)),
                        self.clock())
            return None

    def _silence(self) -> str:
        """Why nothing answers, as far as a console can tell."""
        keys = ("or the manager does not take this console's keys (console.key_secret, and the "
                "manager's manager.key)" if self.keys is not None else
                "or the manager uses CurveZMQ keys and this console runs without (--no-curve)")
        return ("no answer from a manager at {} for {:g} s: is it running on that port? {}; "
                "still trying".format(self.endpoint, self.no_answer, keys))

    def _receive(self, session: ConsoleSession, frame: bytes, was_connected: bool) -> bool:
        now = self.clock()
        asked = session.pending  # a Bye resets the session, which starts a new dict
        try:
            message = session.receive(frame, now)
        except ControlProtocolError as err:
            self._offer(Trouble("a message from the manager was not valid: {}".format(err)), now)
            return was_connected
        if message is None:
            return was_connected
        if isinstance(message, Welcome):
            self._offer(LinkStatus(CONNECTED, "{} the manager at {} (session {})".format(
                "reconnected to" if was_connected else "connected to", self.endpoint,
                message.session)), now)
            return True
        if isinstance(message, tuple):  # (Answer, the request it answers)
            answer, request = message
            self._offer(_reply(answer, request), now)
            return was_connected
        if isinstance(message, Bye):
            self._offer(message, now)
            self._lose(session, "manager said goodbye ({}); reconnecting".format(message.reason), now,
                       list(asked.values()))
            return was_connected
        self._offer(message, now)
        return was_connected

    def _send_requests(self, session: ConsoleSession, client: ConsoleClient, now: float) -> None:
        while self._outbox:
            action, based_on, args = self._outbox.popleft()
            if not session.connected:
                self._offer(Reply(action, args, False, "not connected to a manager", sent=False), now)
                continue
            _, frame = session.request(action, now, based_on, **args)
            client.send(frame)

    def _lose(self, session: ConsoleSession, text: str, now: float,
              pending: Optional[List[Request]] = None) -> None:
        if pending is None:
            pending = list(session.pending.values())
            session.reset(now)
        for request in pending:
            self._offer(Reply(request.action, dict(request.args), False,
                              "no answer: the manager was lost"), now)
        self._offer(LinkStatus(LOST, text), now)

    def _offer(self, item: Any, now: float) -> None:
        self.feed.offer(item, now)


_STATE = b'{"t":"state",'  # how every State frame begins (the codec writes "t" first)


def newest_states(frames: List[bytes]) -> List[bytes]:
    """`frames` without the States a later State in the same batch supersedes: a console that
    fell behind decodes only the newest (a 300-robot State takes milliseconds to check), and
    every other message, in order."""
    last = max((k for k, f in enumerate(frames) if f.startswith(_STATE)), default=-1)
    return [f for k, f in enumerate(frames) if k >= last or not f.startswith(_STATE)]


def _reply(answer: Answer, request: Optional[Request]) -> Reply:
    if request is None:  # the manager could not read a frame of ours (id 0) or a forgotten id
        return Reply("?", {}, answer.ok, answer.reason)
    return Reply(request.action, dict(request.args), answer.ok, answer.reason)
