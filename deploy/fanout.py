"""The whole fleet at once: one job per machine in its own thread, one table row per machine.

Every job runs to its end whatever the others do; a job's failure (a
`DeployError`, or anything unexpected, whose traceback goes to its log) becomes
a FAILED row with the reason, and the exit status is 1 if any row failed. Each
machine's output goes to its own log, `<log_dir>/<host>-<server|robotID>.log`,
appended with a header per command.
"""
from __future__ import annotations

import queue
import threading
import time
import traceback
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Callable, List, Optional, Sequence, TextIO

from fleet_common.errors import FleetError

from .targets import Target

__all__ = ["Outcome", "run_all", "format_table", "exit_status"]

Job = Callable[[Target, TextIO], str]   # returns the row's detail; raises on failure


@dataclass(frozen=True)
class Outcome:
    target: Target
    ok: bool
    seconds: float
    detail: str
    log: Optional[Path]


def _one(job: Job, target: Target, title: str, log_dir: Optional[Path]) -> Outcome:
    start = time.monotonic()
    log_path = None if log_dir is None else log_dir / (target.log_name + ".log")
    log: Optional[TextIO] = None
    try:
        if log_path is not None:
            log_path.parent.mkdir(parents=True, exist_ok=True)
            log = log_path.open("a", encoding="utf-8")
            log.write("=== {} {} on {} ({})\n".format(
                datetime.now().isoformat(sep=" ", timespec="seconds"), title, target.name,
                target.address))
            log.flush()
        detail = job(target, log if log is not None else _Discard())
        return Outcome(target, True, time.monotonic() - start, detail, log_path)
    except FleetError as err:
        if log is not None:
            log.write("FAILED: {}\n".format(err))
        return Outcome(target, False, time.monotonic() - start, str(err), log_path)
    except Exception as err:  # noqa: BLE001 - one machine's bug must not stop the others
        if log is not None:
            log.write(traceback.format_exc())
        return Outcome(target, False, time.monotonic() - start,
                       "internal error: {}: {}".format(type(err).__name__, err), log_path)
    finally:
        if log is not None:
            log.close()


class _Discard:
    def write(self, text: str) -> int:
        return len(text)


def run_all(targets: Sequence[Target], job: Job, title: str, log_dir: Optional[Path],
            jobs: int = 0) -> List[Outcome]:
    """Run `job` on every target, `jobs` at a time (0: all at once, 1: one by one);
    the outcomes in the targets' order."""
    width = len(targets) if jobs <= 0 else jobs
    if width <= 1:
        return [_one(job, t, title, log_dir) for t in targets]
    # Daemon threads, not a pool: Ctrl-C must end the command now, not after every step's
    # timeout (the steps on the machines are bounded there by their own `timeout`).
    todo = queue.SimpleQueue()  # type: queue.SimpleQueue[int]
    for index in range(len(targets)):
        todo.put(index)
    outcomes: List[Optional[Outcome]] = [None] * len(targets)

    def worker() -> None:
        while True:
            try:
                index = todo.get_nowait()
            except queue.Empty:
                return
            outcomes[index] = _one(job, targets[index], title, log_dir)

    threads = [threading.Thread(target=worker, name="deploy-{}".format(i), daemon=True)
               for i in range(min(width, len(targets)))]
    for thread in threads:
        thread.start()
    for thread in threads:
        while thread.is_alive():
            thread.join(0.2)  # a bounded join keeps the main thread able to take Ctrl-C
    return [o for o in outcomes if o is not None]


def format_table(outcomes: Sequence[Outcome]) -> str:
    rows = [("TARGET", "ADDRESS", "RESULT", "SECONDS", "DETAIL")]
    for o in outcomes:
        rows.append((o.target.name, o.target.address, "OK" if o.ok else "FAILED",
                     "{:.1f}".format(o.seconds), o.detail))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    lines = []
    for row in rows:
        cells = [row[0].ljust(widths[0]), row[1].ljust(widths[1]), row[2].ljust(widths[2]),
                 row[3].rjust(widths[3]), row[4]]
        lines.append("  ".join(cells).rstrip())
    failed = sum(not o.ok for o in outcomes)
    logs = {str(o.log.parent) for o in outcomes if o.log is not None}
    lines.append("{} of {} OK{}{}".format(
        len(outcomes) - failed, len(outcomes), "; {} FAILED".format(failed) if failed else "",
        "; logs in {}".format(", ".join(sorted(logs))) if logs else ""))
    return "\n".join(lines)


def exit_status(outcomes: Sequence[Outcome]) -> int:
    return 0 if all(o.ok for o in outcomes) else 1
