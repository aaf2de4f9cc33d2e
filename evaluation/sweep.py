"""Running a sweep's cells: in this process, on all local cores, or on a Dask cluster.

Cells already in OUT/results.csv are not run again (resume); the others run
in any order and are appended as they finish; at the end the table is
written in cell order (CSV and Parquet). `jobs=1` runs in this process; by
default a process pool uses every local core; `scheduler="tcp://HOST:PORT"`
sends the cells to a Dask distributed scheduler (its workers need this
package installed), with each plan sent to the workers once.
"""
from __future__ import annotations

import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterator, List, Optional, TextIO

from fleet_common.plan_loading import LoadedPlan

from .cell import run_cell
from .plans import load_plans
from .row import Row
from .spec import Cell, Experiment
from .table import CSV_NAME, CsvAppender, read_csv, write_tables


@dataclass
class SweepResult:
    rows: List[Row]
    ran: int            # cells run now
    resumed: int        # cells found done
    seconds: float      # wall time of the cells run now
    moves: int          # simulated robot moves of the cells run now
    workers: int

    @property
    def moves_per_second(self) -> float:
        return self.moves / self.seconds if self.seconds > 0 else 0.0


class Progress:
    """A progress line on stderr: redrawn in place on a terminal, every 10 % otherwise."""

    def __init__(self, name: str, total: int, done: int, stream: Optional[TextIO]) -> None:
        self.name, self.total, self.done, self.stream = name, total, done, stream
        self.began = time.monotonic()
        self.first = done
        self._tty = bool(stream is not None and getattr(stream, "isatty", lambda: False)())
        self._shown = -1.0
        self.show()

    def step(self) -> None:
        self.done += 1
        self.show()

    def show(self) -> None:
        if self.stream is None:
            return
        now = time.monotonic()
        frac = self.done / self.total if self.total else 1.0
        if self._tty and now - self._shown < 0.1 and self.done < self.total:
            return
        if not self._tty and self.done < self.total and int(frac * 10) == int(self._shown) and self._shown >= 0:
            return
        self._shown = now if self._tty else float(int(frac * 10))
        ran, spent = self.done - self.first, now - self.began
        left = "" if ran == 0 or self.done >= self.total else ", about {:.0f} s left".format(
            spent / ran * (self.total - self.done))
        width = 30
        bar = "#" * int(frac * width) + "." * (width - int(frac * width))
        line = "{} [{}] {}/{} cells{}{}".format(self.name, bar, self.done, self.total,
                                             ", {:.0f} s".format(spent), left)
        self.stream.write(("\r" + line + ("\n" if self.done >= self.total else "")) if self._tty else line + "\n")
        self.stream.flush()


def run_sweep(exp: Experiment, out: Path, jobs: Optional[int] = None, scheduler: Optional[str] = None,
              progress: Optional[TextIO] = sys.stderr) -> SweepResult:
    out.mkdir(parents=True, exist_ok=True)
    plans = load_plans(exp.plans, out)
    keys = {c.key for c in exp.cells}
    done: Dict[str, Row] = {}
    if (out / CSV_NAME).is_file():
        done = {r["key"]: r for r in read_csv(out / CSV_NAME) if r["key"] in keys}
        write_tables(out, [done[c.key] for c in exp.cells if c.key in done])  # drops a torn line
    todo = [c for c in exp.cells if c.key not in done]
    bar = Progress(exp.name, len(exp.cells), len(done), progress)
    appender = CsvAppender(out / CSV_NAME)
    began, moves = time.perf_counter(), 0
    workers = 1 if jobs == 1 and scheduler is None else (jobs or os.cpu_count() or 1)
    try:
        if scheduler is not None:
            rows, workers = _dask(todo, plans, scheduler)
        elif workers == 1:
            rows = (run_cell(c, plans[c.plan]) for c in todo)
        else:
            rows = _pool(todo, plans, workers)
        for row in rows:
            appender.add(row)
            done[row["key"]] = row
            moves += row["moves"]
            bar.step()
    finally:
        appender.close()
    seconds = time.perf_counter() - began
    ordered = [done[c.key] for c in exp.cells]
    write_tables(out, ordered)
    return SweepResult(ordered, len(todo), len(exp.cells) - len(todo), seconds, moves, workers)


_PLANS: Dict[str, LoadedPlan] = {}


def _init_worker(plans: Dict[str, LoadedPlan]) -> None:
    _PLANS.update(plans)


def _run_here(cell: Cell) -> Row:
    return run_cell(cell, _PLANS[cell.plan])


def _pool(todo: List[Cell], plans: Dict[str, LoadedPlan], workers: int) -> Iterator[Row]:
    with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker, initargs=(plans,)) as pool:
        futures = [pool.submit(_run_here, c) for c in todo]
        try:
            for future in as_completed(futures):
                yield future.result()
        except BaseException:
            for f in futures:
                f.cancel()
            raise


def _dask(todo: List[Cell], plans: Dict[str, LoadedPlan], address: str):
    from dask.distributed import Client, as_completed as dask_completed

    client = Client(address, timeout=30, set_as_default=False)
    workers = max(1, sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values()))

    def rows() -> Iterator[Row]:
        try:
            sent = {name: client.scatter(plan, broadcast=True) for name, plan in plans.items()
                    if any(c.plan == name for c in todo)}
            futures = client.map(run_cell, todo, [sent[c.plan] for c in todo], pure=False)
            for _, row in dask_completed(futures, with_results=True, loop=client.loop):
                yield row
        finally:
            client.close()
    return rows(), workers
