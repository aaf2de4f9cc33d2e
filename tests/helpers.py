"""What several test modules need: `fleetctl` run as a user runs it, free loopback ports,
a naive rotation checker (the oracle for the vectorised one).
"""
from __future__ import annotations

import os
from collections import deque
import socket
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Optional, Set, Tuple

from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan


def fleetctl(*args: object, cwd: Optional[Path] = None, env: Optional[Dict[str, str]] = None,
             timeout: float = 120) -> subprocess.CompletedProcess:
    """`fleetctl ARGS...` in a fresh process of the test's Python; output captured as text."""
    return subprocess.run([sys.executable, "-m", "fleetctl", *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd, env=env)


def free_ports(n: int) -> List[int]:
    """`n` distinct TCP ports free on 127.0.0.1 right now (all held open until all are chosen)."""
    socks = []
    for _ in range(n):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        socks.append(s)
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def free_port() -> int:
    return free_ports(1)[0]


def free_port_block(count: int) -> int:
    """`count` consecutive ports free now, below the kernel's ephemeral range (32768 and up,
    where the processes' own outgoing connections would take them), from a per-process
    offset so that test runs side by side rarely meet."""
    base = 10000 + (os.getpid() * 37) % 20000
    while base + count < 32768:
        socks = []
        try:
            for port in range(base, base + count):
                s = socket.socket()
                socks.append(s)
                s.bind(("127.0.0.1", port))
            return base
        except OSError:
            base += count
        finally:
            for s in socks:
                s.close()
    raise RuntimeError("no {} consecutive free ports".format(count))


def naive_rotations(plan: Plan, min_length: int = 3) -> Set[Tuple[int, Tuple[int, ...]]]:
    """(step, agents from the smallest, in cycle order) of every cycle of movers each entering
    the cell the next one leaves, found by walking each mover; `min_length=2` counts swaps too."""
    found = set()
    pos = plan.positions
    for t in range(plan.makespan):
        at = {tuple(p): i for i, p in enumerate(pos[t].tolist())}
        follows = {}
        for i in range(plan.num_agents):
            j = at.get(tuple(pos[t + 1, i].tolist()))
            if j is not None and j != i and (pos[t + 1, j] != pos[t, j]).any():
                follows[i] = j
        for i in follows:
            cycle, k = [i], follows[i]
            while k != i and k in follows and len(cycle) <= plan.num_agents:
                cycle.append(k)
                k = follows[k]
            if k == i and len(cycle) >= min_length and i == min(cycle):
                found.add((t + 1, tuple(cycle)))
    return found


def python_bfs(grid: Grid, goal: Coord) -> List[int]:
    """Moves from every cell to `goal` (cell id = y * width + x), -1 where it cannot be reached."""
    adj = grid.adjacency()
    d = [-1] * grid.num_cells
    if not grid.is_free(goal):
        return d
    s = grid.index(goal)
    d[s] = 0
    q = deque([s])
    while q:
        u = q.popleft()
        for v in adj[u]:
            if d[v] < 0:
                d[v] = d[u] + 1
                q.append(v)
    return d
