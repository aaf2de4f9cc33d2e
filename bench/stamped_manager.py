"""`fleetctl manager` that also notes when it sent each State: for the console's latency figures.

    .venv/bin/python bench/stamped_manager.py STAMPS.tsv -- MANAGER ARGUMENTS...

The manager runs as `fleetctl manager` does; each time it has sent a State to
the consoles it notes (seq, time.monotonic()), and writes the notes to
STAMPS.tsv when it ends. CLOCK_MONOTONIC is one clock for every process on
the machine, so the console's bench compares them with its own readings.
Benchmark scaffolding only: the product never records this.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import List, Tuple

# run as a script, this folder comes first on sys.path; keep it from hiding packages
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

from fleet_manager.manager import Manager  # noqa: E402
from fleetctl.cli import main  # noqa: E402


def run(stamps_path: Path, args: List[str]) -> int:
    stamps: List[Tuple[int, float]] = []
    publish = Manager._publish

    def stamped(self: Manager, now: float) -> None:
        before = self.core._states
        publish(self, now)
        if self.core._states != before:
            stamps.append((self.core._states, time.monotonic()))

    Manager._publish = stamped  # type: ignore[method-assign]
    try:
        return main(["manager"] + args)
    finally:
        stamps_path.write_text("".join("{}\t{:.6f}\n".format(seq, t) for seq, t in stamps))


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[2] != "--":
        raise SystemExit(__doc__)
    raise SystemExit(run(Path(sys.argv[1]), sys.argv[3:]))
