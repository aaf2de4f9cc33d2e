"""How much memory a search may take before it stops as it does at its deadline.

LaCAM keeps every configuration it reaches, and LaCAM* keeps searching until its time limit:
its memory grows for as long as it runs (about 10 bytes per agent and configuration; 200 MB
in 10 s on 400 agents, gigabytes in minutes on thousands). A search that the kernel's OOM
killer ends loses the plan it had already found, so the search also watches the process's
resident memory and, at the limit, stops and returns its best plan.

The default limit is half of the memory the process may use: the machine's, or its cgroup's
(a container) when that is smaller. Linux only, like the rest of the robots' and server's code.
"""
from __future__ import annotations

import os
from typing import Optional

#: The share of the usable memory a search may take by default.
DEFAULT_SHARE = 0.5
_CGROUP_LIMITS = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes")


def usable_mb() -> float:
    """The memory this process may use, in MB: physical memory or the cgroup's limit if lower."""
    usable = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    for path in _CGROUP_LIMITS:
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit():  # "max" (or a huge number) when unlimited
            usable = min(usable, int(text))
    return usable / 2.0**20


def default_limit_mb() -> float:
    return DEFAULT_SHARE * usable_mb()


def rss_mb() -> float:
    """The process's resident memory now, in MB.

    Not getrusage's ru_maxrss: Linux carries the peak of the process image that exec replaced
    over to the new program, so a `fleetctl` started by a large process (a test runner, the
    console) would start at that process's peak."""
    with open("/proc/self/statm") as f:
        resident_pages = int(f.read().split()[1])
    return resident_pages * os.sysconf("SC_PAGE_SIZE") / 2.0**20


class MemoryLimit:
    """`reached()`: whether the process's memory has reached `limit_mb` (None: the default)."""

    __slots__ = ("limit_mb",)

    def __init__(self, limit_mb: Optional[float] = None) -> None:
        if limit_mb is not None and not limit_mb > 0:
            raise ValueError("a memory limit must be positive, got {}".format(limit_mb))
        self.limit_mb = default_limit_mb() if limit_mb is None else float(limit_mb)

    def reached(self) -> bool:
        return rss_mb() >= self.limit_mb
