"""A whole run in one process: the engine against simulated robots, in simulated time.

Each simulated robot keeps a queue of the actions it was sent and drives them
one after the other, each taking its drawn duration (`delays`); the
simulator turns their progress into engine events in time order and records
the executed trace, which `trace.find_collisions` then judges. Control
events (`Pause`, `SwitchStrategy`, `Disabled`, `Enabled`, `RobotFailed`, ...) may be
scheduled at given times. The run starts with `Resume` at time 0 and ends
when nothing is left to happen: finished, or stalled because robots wait for
an out robot.

`disable={robot: step}` models a battery dying: the robot stops where the
plan has it at that step (before its first action of that step or later) and
is disabled there; its in-flight moves are never cut short.
A robot that `RobotFailed` stops mid-move: it keeps both cells of that move, and when
it is enabled again it is sent the same action and completes it.
"""
from __future__ import annotations

import heapq
from collections import deque
from dataclasses import dataclass
from typing import Deque, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..plan import Plan
from .delays import DelayModel
from .engine import Engine
from .events import ActionCompleted, ActionStarted, Disabled, Dispatch, Enabled, Resume, RobotFailed
from .metrics import Metrics
from .trace import Collision, Trace, find_collisions

_COMPLETE, _CONTROL = 0, 1


@dataclass
class SimResult:
    engine: Engine
    trace: Trace
    durations: np.ndarray
    collisions: List[Collision]
    end_time: float
    disabled_at: Dict[int, float]

    @property
    def metrics(self) -> Metrics:
        return self.engine.metrics

    @property
    def finished(self) -> bool:
        return self.engine.finished

    def unfinished(self) -> List[int]:
        """Robots taking part that did not reach their goal."""
        run = self.engine.run
        return [r for r in range(run.num_robots) if run.out[r] is None and not run.finished_robot(r)]


def simulate(plan: Plan, strategy: object = "adg", delays: Optional[DelayModel] = None, seed: int = 0,
             durations: Optional[np.ndarray] = None, disable: Optional[Mapping[int, int]] = None,
             controls: Sequence[object] = (), nominal: float = 1.0, **settings: object) -> SimResult:
    """Run `plan` under `strategy`; durations drawn from `delays`, or given (none: no delays)."""
    engine = Engine(plan, strategy, **settings)  # type: ignore[arg-type]
    if durations is None:
        durations = (delays or DelayModel()).durations(engine.table, seed, nominal)
    return simulate_engine(engine, durations, disable, controls)


def simulate_engine(engine: Engine, durations: np.ndarray, disable: Optional[Mapping[int, int]] = None,
                    controls: Sequence[object] = ()) -> SimResult:
    """Run a fresh `engine` (not yet resumed) with one duration per action."""
    sim = _Simulation(engine, durations, disable or {})
    sim.run(controls)
    return SimResult(engine, sim.trace, sim.durations, find_collisions(sim.trace), sim.now, sim.disabled_at)


class _Simulation:
    def __init__(self, engine: Engine, durations: np.ndarray, disable: Mapping[int, int]) -> None:
        n = engine.run.num_robots
        self.engine = engine
        self.durations = durations
        self.dur: List[float] = durations.tolist()
        self.disable = dict(disable)
        self.trace = Trace([engine.table.start(r) for r in range(n)])
        self.queue: List[Deque[Dispatch]] = [deque() for _ in range(n)]
        self.busy: List[Optional[Tuple[Dispatch, float, int]]] = [None] * n  # action, start, seq
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
                self.trace.add(r, start, time, d.src, d.dst)
                self._deliver(self.engine.handle(ActionCompleted(r, d.index, time)))
                self._try_start(r)
            else:
                self._control(payload)

    def _control(self, event: object) -> None:
        robot = getattr(event, "robot", None)
        if isinstance(event, (Disabled, RobotFailed)):
            self.queue[robot].clear()  # type: ignore[index]
        if isinstance(event, RobotFailed) and self.busy[robot] is not None:  # type: ignore[index]
            d, start, _ = self.busy[robot]  # type: ignore[index, misc]
            self.stuck[robot] = (d, start)  # type: ignore[index]
            self.busy[robot] = None  # type: ignore[index]
        self._deliver(self.engine.handle(event))
        if isinstance(event, Enabled):
            self._try_start(robot)  # type: ignore[arg-type]

    def _deliver(self, dispatches: List[Dispatch]) -> None:
        for d in dispatches:
            self.queue[d.robot].append(d)
        for d in dispatches:
            self._try_start(d.robot)

    def _try_start(self, r: int) -> None:
        if self.busy[r] is not None or not self.queue[r] or self.engine.run.out[r] is not None:
            return
        d = self.queue[r][0]
        stop = self.disable.get(r)
        if stop is not None and d.step >= stop:
            del self.disable[r]
            self.queue[r].clear()
            self.disabled_at[r] = self.now
            self._deliver(self.engine.handle(Disabled(r, self.now)))
            return
        self.queue[r].popleft()
        start = self.now
        stuck = self.stuck[r]
        if stuck is not None and stuck[0].index == d.index:
            start = stuck[1]  # resuming the move it stopped in: it held both cells since then
        self.stuck[r] = None
        self.engine.handle(ActionStarted(r, d.index, self.now))
        self.seq += 1
        self.busy[r] = (d, start, self.seq)
        heapq.heappush(self.heap, (self.now + self.dur[self.engine.run.first[r] + d.index], self.seq,
                                   _COMPLETE, r))

    def _push(self, time: float, kind: int, payload: object) -> None:
        self.seq += 1
        heapq.heappush(self.heap, (time, self.seq, kind, payload))
