"""`fleetctl manager` with its loop's parts timed in CPU time: where the manager's core goes.

    .venv/bin/python bench/profiled_manager.py PROFILE.tsv -- MANAGER ARGUMENTS...

The manager runs as `fleetctl manager` does; the parts of its loop (reading the robots'
poses, their replies and what the run does with them, the State sent to consoles, the
run log, the links' timers) are wrapped to add up their calls and the CPU time of the
loop's thread (CLOCK_THREAD_CPUTIME_ID: time the thread ran, not time it waited for a
core, so the figures hold on a machine others share), written to PROFILE.tsv when it ends:
part, calls, CPU seconds (inclusive: a part called inside another counts in both), counted
from the run's start (state "running") to its end (the first state after it), and the
running phase's wall seconds and the loop thread's CPU seconds in it.
Benchmark scaffolding only: the product never records this.
"""
from __future__ import annotations

import functools
import sys
import time
from pathlib import Path
from typing import Callable, Dict, List, Tuple

# run as a script, this folder comes first on sys.path; keep it from hiding packages
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

from fleet_common.runlog.writer import RunLog  # noqa: E402
from fleet_common.transport.links import LinkSet  # noqa: E402
from fleet_common.transport.robot_link import RobotLink  # noqa: E402
from fleet_manager.core import RunCore  # noqa: E402
from fleet_manager.manager import Manager  # noqa: E402
from fleet_manager.run_phase import RUNNING, RunPhase  # noqa: E402
from fleetctl.cli import main  # noqa: E402

#: (class, method, label): the loop's parts, outermost first.
PARTS: List[Tuple[type, str, str]] = [
    (LinkSet, "poll", "replies: reading the command sockets and what follows"),
    (RunCore, "link_event", "  every event: the engine, commands sent, the log"),
    (LinkSet, "drain_poses", "poses: the newest of each robot's stream"),
    (Manager, "_publish", "State: build and send to consoles"),
    (Manager, "_log_poses", "run log: every robot's pose"),
    (Manager, "_timers", "timers: plans ready, the core's tick"),
    (RunCore, "tick", "  the core's tick: safe points, the run's end, console desk"),
    (RobotLink, "tick", "  link timers (heartbeats, reconnects), per robot"),
    (RobotLink, "_send", "  frames encoded and sent to robots"),
    (RunLog, "record", "  run-log records written"),
]


def _timed(fn: Callable, spent: Dict[str, List[float]], label: str) -> Callable:
    @functools.wraps(fn)
    def wrapper(*args: object, **kwargs: object) -> object:
        began = time.thread_time()
        try:
            return fn(*args, **kwargs)
        finally:
            entry = spent[label]
            entry[0] += 1
            entry[1] += time.thread_time() - began
    return wrapper


def run(profile: Path, args: List[str]) -> int:
    spent: Dict[str, List[float]] = {label: [0, 0.0] for _, _, label in PARTS}
    for cls, name, label in PARTS:
        setattr(cls, name, _timed(getattr(cls, name), spent, label))
    marks: List[Tuple[float, float, Dict[str, List[float]]]] = []  # (wall, thread CPU, counters)
    move = RunPhase.move

    def marked(self: RunPhase, trigger: str, reason: str = "") -> bool:
        changed = move(self, trigger, reason)
        if (self.phase == RUNNING) == (not marks) and len(marks) < 2:  # the run starts, then ends
            marks.append((time.monotonic(), time.thread_time(), {k: list(v) for k, v in spent.items()}))
        return changed

    RunPhase.move = marked  # type: ignore[method-assign]
    try:
        return main(["manager"] + args)
    finally:
        if len(marks) == 1:
            marks.append((time.monotonic(), time.thread_time(), {k: list(v) for k, v in spent.items()}))
        if len(marks) == 2:
            (w0, c0, a), (w1, c1, b) = marks
            lines = ["running\t{:.6f}\t{:.6f}\n".format(w1 - w0, c1 - c0)]
            lines += ["{}\t{:d}\t{:.6f}\n".format(k, int(b[k][0] - a[k][0]), b[k][1] - a[k][1]) for k in spent]
            profile.write_text("".join(lines))


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[2] != "--":
        raise SystemExit(__doc__.strip().splitlines()[2].strip())
    sys.exit(run(Path(sys.argv[1]), sys.argv[3:]))
