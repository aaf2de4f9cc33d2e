"""Heartbeat timing for one connection, as a pure object fed with clock readings.

Each end sends a `Heartbeat` when it has sent nothing for `interval` seconds,
and gives up on the peer after `timeout` seconds without hearing anything
(any message counts). The transport passes in its clock (`time.monotonic()`),
so tests can run a connection's lifetime without waiting.
"""
from __future__ import annotations

__all__ = ["Liveness", "HEARTBEAT_INTERVAL", "PEER_TIMEOUT"]

#: Seconds of silence after which an end sends a heartbeat.
HEARTBEAT_INTERVAL = 1.0
#: Seconds without a message after which the peer is taken for gone.
PEER_TIMEOUT = 3.5


class Liveness:
    """When to send a heartbeat and when the peer counts as gone."""

    def __init__(self, now: float, interval: float = HEARTBEAT_INTERVAL,
                 timeout: float = PEER_TIMEOUT) -> None:
        if not 0 < interval < timeout:
            raise ValueError("need 0 < interval < timeout, got interval={} timeout={}".format(
                interval, timeout))
        self.interval = interval
        self.timeout = timeout
        self.last_sent = now
        self.last_heard = now

    def sent(self, now: float) -> None:
        self.last_sent = now

    def heard(self, now: float) -> None:
        self.last_heard = now

    def heartbeat_due(self, now: float) -> bool:
        return now - self.last_sent >= self.interval

    def peer_gone(self, now: float) -> bool:
        return now - self.last_heard >= self.timeout

    def next_deadline(self) -> float:
        """The clock reading at which something is next due, for a poll timeout."""
        return min(self.last_sent + self.interval, self.last_heard + self.timeout)
