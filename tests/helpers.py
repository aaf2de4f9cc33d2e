"""What several test modules need: `fleetctl` run as a user runs it, free loopback ports."""
from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Optional


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
