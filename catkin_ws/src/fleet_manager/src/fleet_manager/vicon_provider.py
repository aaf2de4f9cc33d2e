"""The manager's Vicon position provider: Tracker's UDP stream -> robot poses in cells.

`ViconProvider` owns one non-blocking UDP socket (Tracker's port 51001 unless
told otherwise) and exposes `fileno()`, so the manager's zmq.Poller waits on it
with the robots' sockets. When it is readable, `handle_readable(now)` drains a
bounded number of datagrams through `fleet_common.vicon.ViconStream` and
returns the robots whose pose changed; `poses(now)` is every robot Vicon has
seen, with its age and whether it is stale. Objects are matched to robots by
the vicon_name column of robot_definitions.txt; other objects are counted, not
reported. Datagrams from hosts outside `sources` (when given) are refused.
"""
from __future__ import annotations

import logging
import socket
import time
from typing import Callable, Collection, Dict, List, Optional, Sequence

from fleet_common.errors import FleetError
from fleet_common.robots import RobotDefinition
from fleet_common.transform2d import Transform2D
from fleet_common.vicon.base_grid import ViconFix, fix_of
from fleet_common.limits import VICON_MAX_DATAGRAMS as MAX_DATAGRAMS
from fleet_common.vicon.stream import ViconCounters, ViconStream

from .settings import STALE_AFTER

__all__ = ["ViconProvider", "ViconFix", "DEFAULT_PORT", "DEFAULT_STALE_AFTER"]

#: Tracker's default UDP Object Stream port.
DEFAULT_PORT = 51001
#: Seconds without a sighting after which a robot's Vicon pose is stale (50 frames at 100 Hz), as
#: for a robot's own poses.
DEFAULT_STALE_AFTER = STALE_AFTER
_RECEIVE_BYTES = 65535  # a whole datagram: an oversized one is refused by size, not cut


class ViconProvider:
    """See the module's docstring. Close it when done (it holds a bound socket)."""

    def __init__(self, robots: Sequence[RobotDefinition], to_base_transform: Transform2D,
                 port: int = DEFAULT_PORT, bind: str = "0.0.0.0",
                 stale_after: float = DEFAULT_STALE_AFTER,
                 sources: Optional[Collection[str]] = None,
                 clock: Callable[[], float] = time.monotonic,
                 log: Optional[logging.Logger] = None) -> None:
        if (to_base_transform.source, to_base_transform.target) != ("vicon", "base"):
            raise ValueError("need a vicon -> base transform, got {}".format(
                to_base_transform.name()))
        self.ids: Dict[str, int] = {r.vicon_name: r.id for r in robots}
        self.to_base = to_base_transform
        self.stale_after = stale_after
        self.sources = set(sources) if sources else None
        self.clock = clock
        self.log = log or logging.getLogger("fleet_manager.vicon")
        self.stream = ViconStream()
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
            self.sock.setblocking(False)
            self.sock.bind((bind, port))
        except OSError as err:
            self.sock.close()
            raise FleetError("cannot listen on UDP {}:{}: {}".format(
                bind, port, err.strerror or err)) from err
        self.address = self.sock.getsockname()

    @property
    def counters(self) -> ViconCounters:
        return self.stream.counters

    def fileno(self) -> int:
        return self.sock.fileno()

    def handle_readable(self, now: Optional[float] = None) -> List[ViconFix]:
        """Read what has arrived; the robots whose Vicon pose changed (latest fix each)."""
        now = self.clock() if now is None else now
        updated: Dict[int, ViconFix] = {}
        for _ in range(MAX_DATAGRAMS):
            try:
                data, sender = self.sock.recvfrom(_RECEIVE_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as err:  # e.g. an ICMP error queued on the socket: not fatal
                self.log.warning("vicon: receive failed: %s", err)
                break
            if self.sources is not None and sender[0] not in self.sources:
                self.stream.refuse("source")
                continue
            for sighting in self.stream.receive(data, now):
                robot_id = self.ids.get(sighting.obj.name)
                if robot_id is not None:
                    updated[robot_id] = fix_of(self.to_base, sighting, now,
                                               self.stale_after, robot_id)
        return list(updated.values())

    def poses(self, now: Optional[float] = None) -> Dict[int, ViconFix]:
        """robot id -> its latest Vicon fix, for every robot seen since the start."""
        return {f.robot_id: f for f in self.objects(now) if f.robot_id is not None}

    def objects(self, now: Optional[float] = None) -> List[ViconFix]:
        """Every object seen since the start, robots and others (robot_id None), by name."""
        now = self.clock() if now is None else now
        return [fix_of(self.to_base, s, now, self.stale_after, self.ids.get(name))
                for name, s in sorted(self.stream.sightings.items())]

    def close(self) -> None:
        self.sock.close()
