"""A simulated run written as a run folder, like the manager's (`fleetctl simulate --log`).

The simulator keeps a journal when asked (`simulate(..., journal=True)`):
dispatches, action starts and completions, robots out and back, and who waits
for whom whenever that changes. This module writes it with the run's plan, in
plan steps (`time_unit` "step"), plus `poses` sampled `POSE_RATE` times a
step from the executed trace (source "robot": a simulated robot reports
where it is exactly), and the `end` record with the summary. Robots are
named by their agent index (a simulated run has no robot_definitions.txt).
"""
from __future__ import annotations

import heapq
import math
from pathlib import Path
from typing import Any, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..execution.simulate import SimResult
from ..execution.trace import Trace
from ..plan import Plan
from .records import approach_fields, plan_file, size_fields
from .writer import RunLog, new_run_folder

POSE_RATE = 10  # pose samples per plan step

Entry = Tuple[float, str, dict]


def pose_samples(trace: Trace, end: float, rate: int = POSE_RATE,
                 paths: Optional[Sequence[Sequence[Tuple[float, float, float]]]] = None) -> Iterator[Entry]:
    """`poses` entries from `trace.begin` to `end`: each robot's centre where its path (knots
    (t, x, y)) has it, or, without paths, moving in a straight line during each move of
    `trace`; heading along its last move."""
    n = len(trace.starts)
    times = np.arange(trace.begin, end + 1e-9, 1.0 / rate)
    if n == 0 or times.size == 0:
        return
    xs, ys, thetas = np.empty((n, times.size)), np.empty((n, times.size)), np.zeros((n, times.size))
    for r, start in enumerate(trace.starts):
        t, x, y = [trace.begin], [float(start[0])], [float(start[1])]
        heading_t, heading = [trace.begin], [0.0]
        for m in trace.moves[r]:
            t += [m.start, m.end]
            x += [float(m.src[0]), float(m.dst[0])]
            y += [float(m.src[1]), float(m.dst[1])]
            heading_t.append(m.start)
            heading.append(math.atan2(m.dst[1] - m.src[1], m.dst[0] - m.src[0]))
        if paths is not None:
            t, x, y = (list(v) for v in zip(*paths[r]))
        xs[r], ys[r] = np.interp(times, t, x), np.interp(times, t, y)
        thetas[r] = np.asarray(heading)[np.searchsorted(heading_t, times, side="right") - 1]
    for k, when in enumerate(times.tolist()):
        yield when, "poses", {"p": [[r, round(float(xs[r, k]), 3), round(float(ys[r, k]), 3),
                                     round(float(thetas[r, k]), 3), "robot", 0.0] for r in range(n)]}


def write_simulation(parent: Union[str, Path], plan: Plan, result: SimResult, solution: Union[str, Path],
                     delays: str, seed: int, summary: Sequence[str]) -> Path:
    """A new run folder in `parent` for a run simulated with `journal=True`; its path."""
    if result.journal is None:
        raise ValueError("the run was simulated without journal=True")
    folder = new_run_folder(parent)
    engine, m = result.engine, result.metrics
    n = plan.num_agents
    with RunLog(folder, clock=lambda: 0.0) as log:
        log.copy_in(solution, plan_file(1))
        size = result.size
        log.run_started(source="simulate", time_unit="step", plan=plan_file(1), robots=list(range(n)),
                        strategy=engine.strategy.name, settings={}, definitions=None,
                        strategy_text=engine.strategy.describe(), delays=delays, seed=seed,
                        size=None if size is None else size_fields(size))
        log.record("state", t=0.0, run="running", reason="start")
        end = result.end_time
        entries: Iterator[Entry] = heapq.merge(result.journal, pose_samples(result.trace, end, paths=result.paths),
                                               key=lambda e: e[0])
        for t, kind, fields in entries:
            log.record(kind, t=t, **fields)
        missing = result.unfinished()
        reason = "done" if not missing else "stuck"
        log.record("state", t=end, run="done" if not missing else "stopped", reason=reason)
        summary_fields: dict = {
            "lines": list(summary), "makespan": m.makespan, "soc": m.soc,
            "plan_makespan": plan.makespan, "plan_soc": plan.soc,
            "wait_time": m.total_wait_time, "collisions": len(result.collisions),
            "blocked_by": _blocked_by(result),
            "closest": None if result.closest is None or size is None else approach_fields(result.closest, size),
        }
        log.record("end", t=end, reason=reason, arrived=len(m.reached),
                   robots=n, summary=summary_fields)
    return folder


def _blocked_by(result: SimResult) -> List[List[Any]]:
    """[waiting robot, blocking robot, time] pairs, longest first."""
    return [[r, q, t] for t, r, q in result.metrics.blocking_pairs()]
