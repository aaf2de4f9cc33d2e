"""Who is late in a running engine, and whom a late robot holds up (`reroute`, `reroute_all`).

A robot is *late* when it is behind the plan's clock by some steps, measured
against the step a run without delays would start its next move
(`expected_steps`), and delayed itself (`delayed`): so a run without delays
never has a late robot. Pure: values in (an engine, the time), values out.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence, Tuple

from .engine import Engine
from .events import CELL
from .forecast import earliest_starts


def expected_steps(engine: Engine) -> List[int]:
    """Per action, the step of the plan's clock at which a run without delays starts it: as soon
    as the dependency graph allows (`forecast`), which for robots as large as a cell is later
    than the plan's own step wherever a robot follows another (it waits for the move out to
    complete). Lateness is measured against it, so that a run without delays has no late robot
    and never reroutes. Computed once per plan (re-orderings later do not change it)."""
    run = engine.run
    n = run.num_agents
    schedule = earliest_starts(run, [0] * n, engine.follow, [0] * n)
    return [schedule.start.get(a, run.step[a]) for a in range(len(run.step))]


def behind(engine: Engine, r: int, now: float, expected: Optional[Sequence[int]] = None) -> Optional[int]:
    """Whole steps robot r is behind the plan's clock (its next move should have started that long
    ago by `expected`, default `expected_steps`; 0 when it is not), or None when it is out (late
    for good)."""
    run = engine.run
    if run.out[r] is not None:
        return None
    a = run.next_incomplete(r)
    if a < 0:
        return 0
    due = (expected_steps(engine) if expected is None else expected)[a]
    return max(0, int(run.clock.steps(now) - due))


def delayed(engine: Engine, r: int, now: float) -> bool:
    """Robot r's own moves have taken it half a step or more longer than planned (it is not only
    behind because it waited for others, nor because the run is slower than the plan without any
    delay: robots as large as a cell, the step barrier, a robot turning at a corner before it
    drives, which takes a TurtleBot half a nominal move)."""
    step = engine.run.clock.step_time
    metrics = engine.metrics
    return metrics.own_delay(r, now, step) - metrics.turn_time[r] >= 0.5 * step


def held_up(engine: Engine, now: float, gap: int,
            expected: Optional[Sequence[int]] = None) -> Dict[int, List[int]]:
    """Late robot -> the robots it holds up (waiting for a cell, directly or down a chain), those
    waiting for it directly first; `expected`: see `behind`."""
    if expected is None:
        expected = expected_steps(engine)
    on: Dict[int, int] = {}
    waiters: List[int] = []
    for w in engine.waiting():
        if w.reason == CELL and w.on:
            on[w.agent] = w.on[0]
            waiters.append(w.agent)
    for w in engine.following():
        on.setdefault(w.agent, w.on[0])
    late: Dict[int, bool] = {}
    out: Dict[int, List[Tuple[int, int]]] = {}
    for h in waiters:
        q, depth, seen = on[h], 0, {h}
        while q not in seen:
            if q not in late:
                lag = behind(engine, q, now, expected)
                late[q] = lag is None or (lag >= gap and delayed(engine, q, now))
            if late[q]:
                out.setdefault(q, []).append((depth, h))
                break
            seen.add(q)
            depth += 1
            if q not in on:
                break
            q = on[q]
    return {q: [h for _, h in sorted(hs)] for q, hs in out.items()}


def late_robots(engine: Engine, now: float, gap: int, expected: Sequence[int]) -> List[int]:
    """Robots behind the plan's clock by `gap` steps or more and delayed themselves."""
    out = []
    for r in range(engine.run.num_agents):
        lag = behind(engine, r, now, expected)
        if lag is not None and lag >= gap and delayed(engine, r, now):
            out.append(r)
    return out
