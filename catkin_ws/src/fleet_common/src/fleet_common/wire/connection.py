"""One manager <-> robot connection as a sans-I/O object, in the manner of h11.

Theory of operation
-------------------
A `Connection` owns no socket. Each end makes one, with its role and the
robot's id, and feeds it what crosses the wire:

    data = conn.send(message)     # our message -> bytes to put on the socket
    message = conn.receive(data)  # bytes from the socket -> the peer's message

Both calls check the message against the table in `states.py` before touching
anything: a message our role may not send now raises `LocalProtocolError`, one
the peer may not send now (or bytes that do not decode) raises
`RemoteProtocolError`, and in both cases the connection is exactly as before,
so the caller can log, answer with a `Bye`, and drop the peer.

The connection also tracks every command in flight (sent and not yet settled),
so a reply for a command that was never sent, or a `Completed` before an
`Accepted`, is caught here and not deep in the manager. It does not time
anything (see `liveness.py`) and does not execute anything (see `executor.py`).

Versions: `Hello` and `Welcome` carry each end's protocol version. A robot that
receives a hello of another version raises `VersionMismatchError`; it should
answer with `Bye(code="version")`, and a manager that receives that bye raises
`VersionMismatchError` with the robot's explanation, so both logs say it.
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

from .codec import decode, encode
from .errors import LocalProtocolError, ProtocolError, RemoteProtocolError, VersionMismatchError
from .messages import (COMMAND_TYPES, PROTOCOL_VERSION, Bye, Hello, Message, Welcome)
from .states import (COMMAND_TRANSITIONS, CONNECTION_TRANSITIONS, Phase, Role, State,
                     messages_allowed, replies_expected)

__all__ = ["Connection"]

_ROLE_NAMES = {Role.MANAGER: "manager", Role.ROBOT: "robot"}


class Connection:
    """The protocol state of one connection, seen from `our_role`'s end."""

    def __init__(self, our_role: Role, robot_id: int, version: int = PROTOCOL_VERSION) -> None:
        self.our_role = our_role
        self.their_role = Role.ROBOT if our_role is Role.MANAGER else Role.MANAGER
        self.robot_id = robot_id
        self.version = version
        self.state = State.START
        #: command id -> (command type, phase), for commands sent and not settled
        self.in_flight: Dict[int, Tuple[str, Phase]] = {}
        self.epoch: Optional[str] = None      # the manager's, from Hello
        self.session: Optional[str] = None    # the robot's, from Welcome
        self.feedback_port: Optional[int] = None
        self.bye: Optional[Bye] = None        # how it ended, either way

    # ---- the two entry points ----------------------------------------------------

    def send(self, message: Message) -> bytes:
        """Bytes for `message`; LocalProtocolError (and no change) if we may not send it."""
        step = self._check(message, self.our_role, LocalProtocolError)
        data = encode(message, self.version)
        self._apply(message, step)
        return data

    def receive(self, data: bytes) -> Message:
        """The peer's message in `data`; RemoteProtocolError (and no change) if illegal."""
        try:
            message = decode(data, self.version)
        except VersionMismatchError as err:
            raise self._mismatch(err.theirs) from err
        step = self._check(message, self.their_role, RemoteProtocolError)
        self._apply(message, step)
        if isinstance(message, Bye) and message.code == "version":
            # legal, but the end of the road: make the cause as loud here as over there
            raise VersionMismatchError(
                "robot {} refused the connection: {}".format(self.robot_id, message.reason),
                ours=self.version, theirs=-1)
        return message

    def can_send(self, message: Message) -> bool:
        """Whether `send(message)` would succeed now."""
        try:
            self._check(message, self.our_role, LocalProtocolError)
        except LocalProtocolError:
            return False
        return True

    # ---- checking and applying ---------------------------------------------------

    def _check(self, message: Message, sender: Role, error: type) -> Tuple[State, Optional[Phase]]:
        """The (next state, next command phase) `message` leads to, or raise `error`."""
        kind = message.TYPE
        who = _ROLE_NAMES[sender]
        next_state = CONNECTION_TRANSITIONS.get((self.state, sender, kind))
        if next_state is None:
            raise error("the {} may not send {!r} while the connection is {}; allowed: {}".format(
                who, kind, self.state.value,
                ", ".join(messages_allowed(self.state, sender)) or "nothing"))
        if isinstance(message, (Hello, Welcome)):
            self._check_handshake(message, sender, error)
        next_phase: Optional[Phase] = None
        if kind in COMMAND_TYPES:
            if message.id in self.in_flight:
                raise error("command {} is already in flight on this connection".format(message.id))
            next_phase = Phase.SENT
        elif hasattr(message, "id"):  # a reply
            if message.id not in self.in_flight:
                raise error("{} for command {}, which is not in flight".format(kind, message.id))
            command, phase = self.in_flight[message.id]
            key = (command, phase, kind)
            if key not in COMMAND_TRANSITIONS:
                raise error("{} for command {} ({}, {}); expected {}".format(
                    kind, message.id, command, phase.value,
                    " or ".join(replies_expected(command, phase))))
            next_phase = COMMAND_TRANSITIONS[key]
        return next_state, next_phase

    def _check_handshake(self, message: Message, sender: Role, error: type) -> None:
        if message.version != self.version:
            if sender is self.our_role:
                raise error("this end speaks version {}, cannot send a {} of version {}".format(
                    self.version, message.TYPE, message.version))
            raise self._mismatch(message.version)
        if message.robot_id != self.robot_id:
            err = error("{} names robot {}, but this connection is to robot {}{}".format(
                message.TYPE, message.robot_id, self.robot_id,
                " (is robot_definitions.txt the same on both ends?)"))
            err.code = "robot-id"
            raise err

    def _apply(self, message: Message, step: Tuple[State, Optional[Phase]]) -> None:
        next_state, next_phase = step
        self.state = next_state
        if isinstance(message, Hello):
            self.epoch = message.epoch
        elif isinstance(message, Welcome):
            self.session = message.session
            self.feedback_port = message.feedback_port
        elif isinstance(message, Bye):
            self.bye = message
        elif message.TYPE in COMMAND_TYPES:
            self.in_flight[message.id] = (message.TYPE, Phase.SENT)
        elif hasattr(message, "id"):
            if next_phase is None:
                del self.in_flight[message.id]
            else:
                self.in_flight[message.id] = (self.in_flight[message.id][0], next_phase)

    def _mismatch(self, theirs: int) -> ProtocolError:
        manager, robot = ((self.version, theirs) if self.our_role is Role.MANAGER
                          else (theirs, self.version))
        return VersionMismatchError(
            "wire protocol version mismatch: the manager speaks version {}, robot {} speaks "
            "version {}; update the older side".format(manager, self.robot_id, robot),
            ours=self.version, theirs=theirs)
