"""A fleet on this machine: free loopback ports and a robot definitions copy that uses them.

The lab's robot_definitions.txt names the robots' own addresses; a virtual
run (the demo, sweeps' wire cells, tests, benchmarks) needs the same robots on 127.0.0.1. One
block of consecutive free ports serves it: the robots' command ports, then
their pose feedback ports (`fleet_common.wire.ports`: base, base + 1, ...),
then the manager's console port. The block lies below the kernel's ephemeral
range, where the processes' own outgoing connections would take ports, and
starts at an offset that depends on the process id, so runs side by side
rarely meet. Ports are checked free by binding them; another process may
still take one before the fleet does, so callers start the fleet promptly.
"""
from __future__ import annotations

import os
import socket
from pathlib import Path
from typing import Sequence, Tuple

from fleet_common.errors import FleetError
from fleet_common.robots import RobotDefinition, format_robot_definitions

__all__ = ["free_port_block", "local_definitions"]

_LOWEST = 10000


def _ephemeral_start() -> int:
    try:
        return int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768  # Linux's default


def free_port_block(count: int) -> int:
    """The first of `count` consecutive TCP ports free on 127.0.0.1 now, below the ephemeral range."""
    top = _ephemeral_start()
    span = top - _LOWEST - count
    if span <= 0:
        raise FleetError("no room for {} ports below the ephemeral range ({})".format(count, top))
    start = _LOWEST + (os.getpid() * 37) % span
    for base in list(range(start, top - count, count)) + list(range(_LOWEST, start, count)):
        socks = []
        try:
            for port in range(base, base + count):
                s = socket.socket()
                socks.append(s)
                s.bind(("127.0.0.1", port))
            return base
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise FleetError("found no {} consecutive free ports on 127.0.0.1 below {}".format(count, top))


def local_definitions(robots: Sequence[RobotDefinition], path: Path) -> Tuple[Path, int, int]:
    """Write `robots` to `path` on 127.0.0.1 with free command ports; (path, feedback base,
    a free port for the manager's console channel)."""
    n = len(robots)
    base = free_port_block(2 * n + 1)
    local = [RobotDefinition(r.id, "127.0.0.1", base + i, r.ssh_user, r.vicon_name, r.colour)
             for i, r in enumerate(robots)]
    path.write_text("# robot definitions on this machine (made for a local run)\n"
                    + format_robot_definitions(local))
    return path, base + n, base + 2 * n
