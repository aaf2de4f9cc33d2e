"""What several test modules need: `fleetctl` run as a user runs it, a virtual fleet process,
free loopback ports, a naive rotation checker (the oracle for the vectorised one), a huge broken instance (also
bench/hostile_files.py's).
"""
from __future__ import annotations

from collections import deque
from contextlib import contextmanager
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Dict, Iterator, List, Optional, Set, Tuple

from fleet_common.grid import Coord, Grid
from fleet_common.plan import Plan
from fleet_common.local_fleet import free_port_block  # noqa: F401  (the tests' helper too)


def wait_until(condition: Callable[[], object], timeout: float, what: str) -> None:
    """Wait (bounded) until `condition()` holds; AssertionError naming `what` if it never does."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() >= deadline:
            raise AssertionError("not seen in {:g} s: {}".format(timeout, what))
        time.sleep(0.02)


def fleetctl(*args: object, cwd: Optional[Path] = None, env: Optional[Dict[str, str]] = None,
             timeout: float = 120) -> subprocess.CompletedProcess:
    """`fleetctl ARGS...` in a fresh process of the test's Python; output captured as text."""
    return subprocess.run([sys.executable, "-m", "fleetctl", *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd, env=env)


@contextmanager
def virtual_fleet_process(definitions: Path, keys: Path, feedback: int,
                          log_level: str) -> Iterator[subprocess.Popen]:
    """`fleetctl virtual-fleet` at 10x, output piped as text; killed and reaped on the way out."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "fleetctl", "virtual-fleet", "--definitions", str(definitions),
         "--keys", str(keys), "--time-scale", "10", "--feedback-base", str(feedback),
         "--log-level", log_level], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)
        proc.stdout.close()  # type: ignore[union-attr]
        proc.stderr.close()  # type: ignore[union-attr]


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


class Forwarder:
    """A TCP forwarder on 127.0.0.1 whose server-to-client direction can be held: a slow network
    between a console and its manager, made to order. `port` is where clients connect."""

    def __init__(self, target_port: int) -> None:
        import threading

        self.target = target_port
        self.listener = socket.socket()
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(4)
        self.port = self.listener.getsockname()[1]
        self.held = threading.Event()  # set: nothing flows from the server to the client
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        import select

        pairs: List[Tuple[socket.socket, socket.socket]] = []
        self.listener.settimeout(0.02)
        while not self._stop.is_set():
            try:
                client, _ = self.listener.accept()
                server = socket.create_connection(("127.0.0.1", self.target))
                pairs.append((client, server))
            except (socket.timeout, OSError):
                pass
            for client, server in list(pairs):
                watch = [client] + ([] if self.held.is_set() else [server])
                ready, _, _ = select.select(watch, [], [], 0.01)
                for sock in ready:
                    if sock is server and self.held.is_set():
                        continue  # held while this thread waited in select
                    data = sock.recv(65536)
                    if not data:
                        pairs.remove((client, server))
                        client.close()
                        server.close()
                        break
                    (server if sock is client else client).sendall(data)
        for client, server in pairs:
            client.close()
            server.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.listener.close()


def big_broken_instance(path: Path, size: int = 50_000_000) -> Path:
    """A `size`-byte lab instance whose line 33 puts an agent off the map: 27 good agent
    lines before it, then comment lines to the end, so that a reader that checks cells only
    after reading every line finds line 33 last."""
    from fleet_common.lab import node_table

    free = list(node_table().grid().free_cells())
    flip = [(x, 13 - y) for x, y in free]  # the lab map is 14 high; files are mapf-IR's way up
    good = ["{},{},{},{}\n".format(*flip[i], *flip[27 + i]) for i in range(27)]
    comment = "# " + "-" * 61 + "\n"
    with open(path, "w") as f:
        f.write("map_file=lab.map\nagents=28\nseed=0\nrandom_problem=0\nmax_timestep=100\n")
        f.write("".join(good))
        f.write("99,5,11,5\n")  # line 33: x = 99 on a map 13 wide
        block = comment * 100_000
        while f.tell() < size:
            f.write(block)
    return path


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


def dense_instance(shared_data: Path, folder: Path, agents: int = 400) -> Path:
    """`agents` random starts and goals (seed 0) in random-32-32-20's largest component: LaCAM
    needs some thousands of configurations for its first plan, LaCAM* keeps finding better."""
    import random

    from fleet_common.formats.instance import make_instance, write_instance
    from fleet_common.formats.mapfile import read_map
    from fleet_common.planning.components import component_labels

    grid = read_map(shared_data / "maps" / "random-32-32-20.map").grid
    labels = component_labels(grid)
    cells = [c for c in grid.free_cells() if labels[grid.index(c)] >= 0]
    biggest = max(set(labels[grid.index(c)] for c in cells), key=[labels[grid.index(c)] for c in cells].count)
    cells = [c for c in cells if labels[grid.index(c)] == biggest]
    rng = random.Random(0)
    path = folder / "dense.txt"
    write_instance(make_instance(grid, "random-32-32-20.map", rng.sample(cells, agents), rng.sample(cells, agents),
                                 seed=0, max_timestep=1000, max_comp_time=120000), str(path))
    return path
