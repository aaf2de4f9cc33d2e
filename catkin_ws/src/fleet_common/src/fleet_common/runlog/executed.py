"""The executed run as a plan: the cell each robot held, one row per `dt` of run time.

From a run folder's `action` records (each move a robot completed, with its
time), sampled every `dt` seconds from the run's start (its first "running"
state) to its end: each robot is on the target of its last move completed by
the sample time (its start before any). The result is a `Plan` that the
player and mapf-IR's visualizer play like any solver's output, so a run can
be watched again beside its plan, and the validator checks it: so no robot
may move more than one cell from row to row. `traced_plan` picks the row time
that keeps it so. The quickest move (drive sent to completion) is not short
enough: completions are stamped when their reports arrive, and a report held
up by a busy machine arrives closer to the next one than a move takes (a CI
run traced a robot two cells in one row of that length). A robot of real size may
complete its move into a cell before the robot it follows has completed its
move out of it; in such a row the leader, already on its way out, is shown
in the cell it goes to, so that each cell holds one robot, as in any plan. (Where robots were between
cells, the `poses` records say; the run report plots them.)
"""
from __future__ import annotations

import bisect
import math
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..plan import Plan
from .reader import RunFolder

__all__ = ["executed_plan", "run_span", "traced_plan"]


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



def traced_plan(run: RunFolder, starts: Sequence[Tuple[int, int]],
                dt: Optional[float] = None) -> Tuple[Plan, float]:
    """The executed plan and its row time: `dt` as given, else the shortest time between two
    completions of one robot, halved while a robot still moves more than a cell in one row
    (a leader shown leaving once its follower is in may be a move ahead)."""
    if dt is not None:
        return executed_plan(run, dt, starts), dt
    dt = _shortest_gap(run)
    plan = executed_plan(run, dt, starts)
    for _ in range(8):  # bounded: each halving doubles the rows
        if not _jumps(plan):
            break
        dt = math.floor(dt / 2 * 1000) / 1000 or 0.001
        plan = executed_plan(run, dt, starts)
    return plan, dt


def _shortest_gap(run: RunFolder) -> float:
    """The shortest time between two completions of one robot, rounded down to the millisecond
    (1 s if no robot completed two moves): no row of this length holds two of them."""
    last: Dict[object, float] = {}
    best = math.inf
    for record in run.of("action"):
        if record.get("phase") != "completed":
            continue
        robot, t = record.get("robot"), float(record["t"])
        if robot in last:
            best = min(best, t - last[robot])
        last[robot] = t
    if math.isinf(best):
        return 1.0
    return max(math.floor(best * 1000) / 1000, 0.01)


def _jumps(plan: Plan) -> bool:
    """Whether a robot moves more than one cell from one row to the next."""
    steps = np.abs(np.diff(plan.positions, axis=0)).sum(axis=2)
    return bool((steps > 1).any())
