"""The executed run as a plan: the cell each robot held, one row per `dt` of run time.

From a run folder's `action` records (each move a robot completed, with its
time), sampled every `dt` seconds from the run's start (its first "running"
state) to its end: each robot is on the target of its last move completed by
the sample time (its start before any). The result is a `Plan` that the
player and mapf-IR's visualizer play like any solver's output, so a run can
be watched again beside its plan. With `dt` no longer than the quickest move,
no robot moves more than one cell from row to row. (Where robots were between
cells, the `poses` records say; the run report plots them.)
"""
from __future__ import annotations

import bisect
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..plan import Plan
from .reader import RunFolder

__all__ = ["executed_plan", "run_span"]


def run_span(run: RunFolder) -> Tuple[float, float]:
    """(begin, end) of the run in log seconds: first "running" state to the last record."""
    begin: Optional[float] = None
    for r in run.of("state"):
        if r.get("run") == "running":
            begin = float(r["t"])
            break
    end = float(run.records[-1]["t"]) if run.records else 0.0
    done = [float(r["t"]) for r in run.of("state") if r.get("run") == "done"]
    if done:
        end = done[-1]
    return (begin if begin is not None else 0.0), end


def executed_plan(run: RunFolder, dt: float, starts: Sequence[Tuple[int, int]]) -> Plan:
    """One row per `dt` seconds of the run; `starts` by agent (where robots began)."""
    if dt <= 0:
        raise ValueError("dt must be positive, got {}".format(dt))
    robots = run.robots
    index = {rid: i for i, rid in enumerate(robots)}
    times: List[List[float]] = [[] for _ in robots]
    cells: List[List[Tuple[int, int]]] = [[] for _ in robots]
    for record in run.of("action"):
        i = index.get(record.get("robot"))  # type: ignore[arg-type]
        dst = record.get("dst")
        if i is None or record.get("phase") != "completed" or not isinstance(dst, list):
            continue
        times[i].append(float(record["t"]))
        cells[i].append((int(dst[0]), int(dst[1])))
    begin, end = run_span(run)
    # rows at begin, begin + dt, ... and a last one at the end (moves finish between rows)
    steps = int(np.ceil(max(0.0, end - begin) / dt - 1e-9)) + 1
    positions = np.empty((steps, len(robots), 2), dtype=np.int32)
    for i in range(len(robots)):
        first = tuple(starts[i])
        for k in range(steps):
            j = bisect.bisect_right(times[i], min(begin + k * dt, end)) - 1
            positions[k, i] = cells[i][j] if j >= 0 else first
    return Plan(positions)

