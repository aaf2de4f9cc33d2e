"""The protocol's state machine as data: every legal step is a row here.

A connection is in one `State`; a message sent by a `Role` moves it along
`CONNECTION_TRANSITIONS`, and anything not in the table is illegal. Within an
open connection each command in flight has a `Phase`; a reply moves it along
`COMMAND_TRANSITIONS` (None: the command is settled and forgotten). Both ends
keep the same machine and check every message against it: what an end sends
(else LocalProtocolError) and what it receives (else RemoteProtocolError).
"""
from __future__ import annotations

import enum
from typing import Dict, Optional, Tuple


class Role(enum.Enum):
    MANAGER = "manager"  # connects, says hello, sends commands
    ROBOT = "robot"      # binds, welcomes, replies


class State(enum.Enum):
    START = "start"          # nothing said yet
    HANDSHAKE = "handshake"  # hello sent, welcome not yet
    OPEN = "open"            # commands and replies flow
    CLOSED = "closed"        # a bye was sent or received; nothing more


class Phase(enum.Enum):
    SENT = "sent"            # command sent, no reply yet
    ACCEPTED = "accepted"    # running on the robot


M, R = Role.MANAGER, Role.ROBOT

_OPEN_BY_MANAGER = ("drive", "turn", "stop", "release", "get_status", "heartbeat")
_OPEN_BY_ROBOT = ("accepted", "completed", "failed", "status", "heartbeat")

#: (state, sender, message type) -> next state.
CONNECTION_TRANSITIONS: Dict[Tuple[State, Role, str], State] = {
    (State.START, M, "hello"): State.HANDSHAKE,
    (State.HANDSHAKE, R, "welcome"): State.OPEN,
}
CONNECTION_TRANSITIONS.update({(State.OPEN, M, t): State.OPEN for t in _OPEN_BY_MANAGER})
CONNECTION_TRANSITIONS.update({(State.OPEN, R, t): State.OPEN for t in _OPEN_BY_ROBOT})
# either side may end a connection that has not ended, at any point
CONNECTION_TRANSITIONS.update({
    (s, role, "bye"): State.CLOSED
    for s in (State.START, State.HANDSHAKE, State.OPEN) for role in (M, R)
})

_ACTIONS = ("drive", "turn", "stop", "release")

#: (command type, phase, reply type) -> next phase; None = settled.
COMMAND_TRANSITIONS: Dict[Tuple[str, Phase, str], Optional[Phase]] = {
    ("get_status", Phase.SENT, "status"): None,
}
for _action in _ACTIONS:
    COMMAND_TRANSITIONS.update({
        (_action, Phase.SENT, "accepted"): Phase.ACCEPTED,
        (_action, Phase.SENT, "failed"): None,        # refused
        (_action, Phase.ACCEPTED, "completed"): None,
        (_action, Phase.ACCEPTED, "failed"): None,    # did not finish
    })


def replies_expected(command: str, phase: Phase) -> Tuple[str, ...]:
    """The reply types legal for a `command` in `phase`, for error messages."""
    return tuple(sorted(r for (c, p, r) in COMMAND_TRANSITIONS if c == command and p == phase))


def messages_allowed(state: State, sender: Role) -> Tuple[str, ...]:
    """The message types `sender` may send in `state`, for error messages."""
    return tuple(sorted(t for (s, r, t) in CONNECTION_TRANSITIONS if s == state and r == sender))
