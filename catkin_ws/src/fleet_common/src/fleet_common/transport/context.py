"""A ZeroMQ context sized for a fleet.

libzmq refuses a context's 1,024th socket ("Too many open files", whatever the
process's file limit). A virtual fleet of 300 robots holds over a thousand
(each robot's command and feedback sockets, and the handshake monitor's pair),
and the manager two or more per robot: they ask for a context sized for what
they will open, with some room to spare.
"""
from __future__ import annotations

import zmq

__all__ = ["fleet_context", "SOCKETS_PER_ROBOT"]

#: Generous: command, feedback, a monitor's two ends, a reconnect's overlap.
SOCKETS_PER_ROBOT = 8


def fleet_context(robots: int) -> zmq.Context:
    """A new context that can hold the sockets of `robots` robots (set before any socket)."""
    context = zmq.Context()
    context.set(zmq.MAX_SOCKETS, max(1024, SOCKETS_PER_ROBOT * robots + 64))
    return context
