"""Protocol errors, split the way h11 splits them: who got it wrong.

`LocalProtocolError`: this end misused the protocol object (sent a message its
role may not send now). `RemoteProtocolError`: the peer sent bytes that do not
decode, or a message that is illegal now. Either way the connection's state is
unchanged. Each carries a `code` that the transport repeats in the `Bye` it
sends before dropping a peer, so that both ends log the same cause.
"""
from __future__ import annotations

from fleet_common.errors import FleetError


class ProtocolError(FleetError):
    """Base of the wire protocol's errors; `code` is a short machine-readable cause."""

    def __init__(self, message: str, code: str = "protocol") -> None:
        super().__init__(message)
        self.code = code


class LocalProtocolError(ProtocolError):
    """This end tried to send something the protocol does not allow now."""


class RemoteProtocolError(ProtocolError):
    """The peer sent something undecodable or not allowed now."""


class MalformedFrameError(RemoteProtocolError):
    """The peer's bytes are not a message at all (whatever the connection's state)."""


class VersionMismatchError(RemoteProtocolError):
    """The two ends speak different protocol versions; neither can go on."""

    def __init__(self, message: str, ours: int, theirs: int) -> None:
        super().__init__(message, code="version")
        self.ours = ours
        self.theirs = theirs
