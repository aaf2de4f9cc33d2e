"""A whole run in one process: the engine against simulated robots, in simulated time.

Each simulated robot keeps a queue of the actions it was sent and drives them
one after the other, each taking its drawn duration (`delays`); the
simulator turns their progress into engine events in time order and records
the executed trace, which `trace.find_collisions` then judges. Control
events (`Pause`, `SwitchStrategy`, `Disabled`, `Enabled`, `RobotFailed`, ...) may be
scheduled at given times. The run starts with `Resume` at time 0 and ends
when nothing is left to happen: finished, or stuck because robots wait for
an out robot.

`disable={robot: step}` models a battery dying: the robot stops where the
plan has it at that step (before its first action of that step or later) and
is disabled there; its in-flight moves are never cut short.
A robot that `RobotFailed` stops mid-move: it keeps both cells of that move, and when
it is enabled again it is sent the same action and completes it.

A move may have a wait before it (`waits`, from delay events): the robot stays in
its cell that long after the action reaches it, then starts moving. With
`journal=True` the run also keeps what a run log records (`SimResult.journal`:
dispatches, starts, completions, robots out, and who waits for whom whenever
that changes), for `runlog_sim` to write.
"""
from __future__ import annotations

import heapq
from collections import deque
from dataclasses import dataclass
from typing import Deque, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..plan import Plan
from ..delays import DelayModel, simulator_durations
from .engine import Engine
from .events import ActionCompleted, ActionStarted, Disabled, Dispatch, Enabled, Resume, RobotFailed
from .metrics import Metrics
from .trace import Collision, Trace, find_collisions

_COMPLETE, _CONTROL, _BEGIN = 0, 1, 2


@dataclass
class SimResult:
    engine: Engine
    trace: Trace
    durations: np.ndarray
    collisions: List[Collision]
    end_time: float
    disabled_at: Dict[int, float]
    waits: Optional[np.ndarray] = None
    journal: Optional[List[Tuple[float, str, dict]]] = None

    @property
    def metrics(self) -> Metrics:
        return self.engine.metrics

    @property
    def finished(self) -> bool:
        return self.engine.finished

    def unfinished(self) -> List[int]:
        """Robots taking part that did not reach their goal."""
        run = self.engine.run
        return [r for r in range(run.num_agents) if run.out[r] is None and not run.finished_agent(r)]


def simulate(plan: Plan, strategy: object = "adg", delays: Optional[DelayModel] = None, seed: int = 0,
             durations: Optional[np.ndarray] = None, disable: Optional[Mapping[int, int]] = None,
             controls: Sequence[object] = (), nominal: float = 1.0, waits: Optional[np.ndarray] = None,
             journal: bool = False, **settings: object) -> SimResult:
    """Run `plan` under `strategy`; waits and durations drawn from `delays`, or given
    (none: no delays)."""
    engine = Engine(plan, strategy, **settings)  # type: ignore[arg-type]
    if durations is None:
        waits, durations = simulator_durations(delays or DelayModel(), engine.table.agent,
                                                engine.run.num_agents, seed, nominal)
    return simulate_engine(engine, durations, disable, controls, waits, journal)


def simulate_engine(engine: Engine, durations: np.ndarray, disable: Optional[Mapping[int, int]] = None,
                    controls: Sequence[object] = (), waits: Optional[np.ndarray] = None,
                    journal: bool = False) -> SimResult:
    """Run a fresh `engine` (not yet resumed) with one duration (and wait) per action."""
    sim = _Simulation(engine, durations, disable or {}, waits, journal)
    sim.run(controls)
    return SimResult(engine, sim.trace, sim.durations, find_collisions(sim.trace), sim.now, sim.disabled_at,
                     waits, sim.journal)


class _Simulation:
    def __init__(self, engine: Engine, durations: np.ndarray, disable: Mapping[int, int],
                 waits: Optional[np.ndarray], journal: bool) -> None:
        n = engine.run.num_agents
        self.engine = engine
        self.durations = durations
        self.dur: List[float] = durations.tolist()
        self.wait: Optional[List[float]] = None if waits is None or not waits.any() else waits.tolist()
        self.journal: Optional[List[Tuple[float, str, dict]]] = [] if journal else None
        self._waits_seen: object = ()
        self._charged: Dict[int, Tuple[float, Dict[int, float]]] = {}
        self.disable = dict(disable)
        self.trace = Trace([engine.table.start(r) for r in range(n)])
        self.queue: List[Deque[Dispatch]] = [deque() for _ in range(n)]
        self.busy: List[Optional[Tuple[Dispatch, float, int]]] = [None] * n  # action, start, seq
        self.moving: List[bool] = [False] * n  # False while the busy action waits to start
        self.stuck: List[Optional[Tuple[Dispatch, float]]] = [None] * n  # failed mid-move
        self.heap: List[tuple] = []
        self.seq = 0
        self.now = 0.0
        self.disabled_at: Dict[int, float] = {}

    def run(self, controls: Sequence[object]) -> None:
        for event in controls:
            self._push(event.time, _CONTROL, event)  # type: ignore[attr-defined]
        self._deliver(self.engine.handle(Resume(0.0)))
        while self.heap:
            time, seq, kind, payload = heapq.heappop(self.heap)
            self.now = time
            if kind == _COMPLETE:
                r = payload
                current = self.busy[r]
                if current is None or current[2] != seq:
                    continue  # cancelled by a failure
                d, start, _ = current
                self.busy[r] = None
                self.moving[r] = False
                self.trace.add(r, start, time, d.src, d.dst)
                self._note("action", robot=r, index=d.index, phase="completed", src=d.src, dst=d.dst)
                self._deliver(self.engine.handle(ActionCompleted(r, d.index, time)))
                self._try_start(r)
            elif kind == _BEGIN:
                r, token = payload
                current = self.busy[r]
                if current is not None and current[2] == token:
                    self._begin(r, current[0], time, time)
            else:
                self._control(payload)
            if self.journal is not None:
                self._note_waits()

    def _control(self, event: object) -> None:
        agent = getattr(event, "agent", None)
        if isinstance(event, (Disabled, RobotFailed)):
            self.queue[agent].clear()  # type: ignore[index]
        busy = self.busy[agent] if isinstance(event, (Disabled, RobotFailed)) else None  # type: ignore[index]
        if busy is not None and not self.moving[agent]:  # type: ignore[index]
            self.busy[agent] = None  # type: ignore[index]  # it had not started: nothing to finish
        elif busy is not None and isinstance(event, RobotFailed):
            self.stuck[agent] = (busy[0], busy[1])  # type: ignore[index]
            self.busy[agent] = None  # type: ignore[index]
            self.moving[agent] = False  # type: ignore[index]
        if isinstance(event, (Disabled, RobotFailed, Enabled)):
            why = "disabled" if isinstance(event, Disabled) else "failed" if isinstance(event, RobotFailed) else None
            self._note("out", robot=agent, why=why, reason=type(event).__name__)
        self._deliver(self.engine.handle(event))
        if isinstance(event, Enabled):
            self._try_start(agent)  # type: ignore[arg-type]

    def _deliver(self, dispatches: List[Dispatch]) -> None:
        for d in dispatches:
            self.queue[d.agent].append(d)
            if self.journal is not None:
                waited, by = self._waited(d.agent)
                self._note("dispatch", robot=d.agent, index=d.index, step=d.step, src=d.src, dst=d.dst,
                           waited=waited, released_by=by)
        for d in dispatches:
            self._try_start(d.agent)

    def _try_start(self, r: int) -> None:
        if self.busy[r] is not None or not self.queue[r] or self.engine.run.out[r] is not None:
            return
        d = self.queue[r][0]
        stop = self.disable.get(r)
        if stop is not None and d.step >= stop:
            del self.disable[r]
            self.queue[r].clear()
            self.disabled_at[r] = self.now
            self._note("out", robot=r, why="disabled", reason="disable")
            self._deliver(self.engine.handle(Disabled(r, self.now)))
            return
        self.queue[r].popleft()
        start = self.now
        stuck = self.stuck[r]
        self.stuck[r] = None
        if stuck is not None and stuck[0].index == d.index:
            start = stuck[1]  # resuming the move it stopped in: it held both cells since then
        elif self.wait is not None and self.wait[self.engine.run.first[r] + d.index] > 0:
            self.seq += 1  # it stays in its cell for the wait, then starts moving
            self.busy[r] = (d, start, self.seq)
            self._push(self.now + self.wait[self.engine.run.first[r] + d.index], _BEGIN, (r, self.seq))
            return
        self._begin(r, d, start, self.now)

    def _begin(self, r: int, d: Dispatch, start: float, now: float) -> None:
        """Robot r starts moving (occupying both cells from `start`) with action d."""
        self.engine.handle(ActionStarted(r, d.index, now))
        self._note("action", robot=r, index=d.index, phase="started", src=d.src, dst=d.dst)
        self.seq += 1
        self.busy[r] = (d, start, self.seq)
        self.moving[r] = True
        heapq.heappush(self.heap, (now + self.dur[self.engine.run.first[r] + d.index], self.seq,
                                   _COMPLETE, r))

    def _note(self, kind: str, **fields: object) -> None:
        if self.journal is not None:
            self.journal.append((self.now, kind, fields))

    def _waited(self, r: int) -> Tuple[float, Optional[int]]:
        """What the metrics charged robot r since its last dispatch: time waited, and to whom."""
        m = self.engine.metrics.agents[r]
        seen = self._charged.get(r, (0.0, {}))
        waited = m.wait_time - seen[0]
        by = next((q for q, t in m.blocked_by.items() if t > seen[1].get(q, 0.0)), None)
        self._charged[r] = (m.wait_time, dict(m.blocked_by))
        return round(waited, 6), by

    def _note_waits(self) -> None:
        waits = tuple((w.agent, w.on, w.cell, w.reason) for w in self.engine.waiting())
        if waits != self._waits_seen:
            self._waits_seen = waits
            self._note("waits", w=[list(w) for w in waits])

    def _push(self, time: float, kind: int, payload: object) -> None:
        self.seq += 1
        heapq.heappush(self.heap, (time, self.seq, kind, payload))
