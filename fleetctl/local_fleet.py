"""A fleet on this machine: free loopback ports and a robot definitions copy that uses them.

The lab's robot_definitions.txt names the robots' own addresses; a virtual
run (the demo, tests, benchmarks) needs the same robots on 127.0.0.1, each on
a command port nobody else holds, and a block of consecutive free ports for
their pose feedback (`fleet_common.wire.ports`: base, base + 1, ...). Ports
are checked free by binding them; another process may still take one before
the fleet does, so callers start the fleet promptly.
"""
from __future__ import annotations

import random
import socket
from pathlib import Path
from typing import List, Sequence, Tuple

from fleet_common.errors import FleetError
from fleet_common.robots import RobotDefinition, format_robot_definitions

__all__ = ["free_ports", "free_port_block", "local_definitions"]


def free_ports(n: int) -> List[int]:
    """`n` distinct TCP ports free on 127.0.0.1 now (all held until all are chosen)."""
    socks = []
    try:
        for _ in range(n):
            s = socket.socket()
            s.bind(("127.0.0.1", 0))
            socks.append(s)
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def free_port_block(n: int, avoid: Sequence[int] = (), tries: int = 200) -> int:
    """The first of `n` consecutive TCP ports free on 127.0.0.1 now, none of them in `avoid`."""
    rng = random.Random()
    for _ in range(tries):
        base = rng.randrange(20000, 60000 - n)
        if any(p in avoid for p in range(base, base + n)):
            continue
        socks = []
        try:
            for port in range(base, base + n):
                s = socket.socket()
                socks.append(s)
                s.bind(("127.0.0.1", port))
            return base
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise FleetError("found no {} consecutive free ports on 127.0.0.1".format(n))


def local_definitions(robots: Sequence[RobotDefinition], path: Path) -> Tuple[Path, int]:
    """Write `robots` to `path` on 127.0.0.1 with free command ports; (path, feedback base)."""
    ports = free_ports(len(robots))
    local = [RobotDefinition(r.id, "127.0.0.1", port, r.ssh_user, r.vicon_name, r.colour)
             for r, port in zip(robots, ports)]
    path.write_text("# {} on this machine (made for a local run)\n{}".format(
        "robot definitions", format_robot_definitions(local)))
    return path, free_port_block(len(robots), avoid=ports)
