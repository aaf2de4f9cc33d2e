"""The executed run as a plan: the cell each robot held, one row per `dt` of run time.

From a run folder's `action` records (each move a robot completed, with its
time), sampled every `dt` seconds from the run's start (its first "running"
state) to its end: each robot is on the target of its last move completed by
the sample time (its start before any). The result is a `Plan` that the
player and mapf-IR's visualizer play like any solver's output, so a run can
be watched again beside its plan. With `dt` no longer than the quickest move,
no robot moves more than one cell from row to row. A robot of real size may
complete its move into a cell before the robot it follows has completed its
move out of it; in such a row the leader, already on its way out, is shown
in the cell it goes to, so that each cell holds one robot, as in any plan. (Where robots were between
cells, the `poses` records say; the run report plots them.)
"""
from __future__ import annotations

import bisect
from typing import Dict, List, Optional, Sequence, Tuple

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
    starts_at: List[List[float]] = [[] for _ in robots]
    cells: List[List[Tuple[int, int]]] = [[] for _ in robots]
    for record in run.of("action"):
        i = index.get(record.get("robot"))  # type: ignore[arg-type]
        dst = record.get("dst")
        if i is None or not isinstance(dst, list):
            continue
        if record.get("phase") == "started":
            starts_at[i].append(float(record["t"]))
        elif record.get("phase") == "completed":
            times[i].append(float(record["t"]))
            cells[i].append((int(dst[0]), int(dst[1])))
    begin, end = run_span(run)
    # rows at begin, begin + dt, ... and a last one at the end (moves finish between rows)
    steps = int(np.ceil(max(0.0, end - begin) / dt - 1e-9)) + 1
    positions = np.empty((steps, len(robots), 2), dtype=np.int32)
    for k in range(steps):
        now = min(begin + k * dt, end)
        done = [bisect.bisect_right(times[i], now) for i in range(len(robots))]  # moves completed
        begun = [bisect.bisect_right(starts_at[i], now) for i in range(len(robots))]  # and started
        for _ in range(len(robots) + 1):  # a leader moved on may meet the robot it follows
            held: Dict[Tuple[int, int], int] = {}
            ahead = []
            for i, j in enumerate(done):
                cell = cells[i][j - 1] if j > 0 else tuple(starts[i])
                other = held.setdefault(cell, i)
                if other != i:  # two in one cell: the one that came first is on its way out
                    first_in = times[other][done[other] - 1] if done[other] > 0 else -np.inf
                    arrived = times[i][j - 1] if j > 0 else -np.inf
                    ahead.append(other if arrived >= first_in else i)
            ahead = [i for i in ahead if begun[i] > done[i] and done[i] < len(cells[i])]
            if not ahead:
                break
            for i in ahead:
                done[i] += 1
        for i, j in enumerate(done):
            positions[k, i] = cells[i][j - 1] if j > 0 else tuple(starts[i])
    return Plan(positions)

