"""A whole run in one process: the engine against simulated robots, in simulated time.

Each simulated robot keeps a queue of the actions it was sent and drives them
one after the other (`motion`: a wait in its cell, then a straight drive at
its drawn speed, stalled or slowed anywhere inside the move as the delay
model says). The simulator turns their progress into engine events in time
order and records what really happened: every robot's path (the centre's
knots, judged in metres by `approach`) and the cells it occupied (`trace`,
judged by the cell rule for robots as large as a cell). Control events
(`Pause`, `SwitchStrategy`, `Disabled`, `Enabled`, `RobotFailed`, ...) may be
scheduled at given times. The run starts with `Resume` at time 0 and ends
when nothing is left to happen: finished, or stuck because robots wait for
an out robot.

Robots of a real size (`size`, smaller than a cell) follow one another: a
follower dispatched before its leader's move completed drives only to its
hold point (`following.hold_fraction`), computed as the manager computes it:
from where the leader was at the last pose report that has reached the
manager (reports every `feedback.period`, arriving `feedback.latency`
later). A follower that reaches its hold point stops there and looks again
at each new report; the leader's completion is known the same way.

`disable={robot: step}` models a battery dying: the robot stops where the
plan has it at that step (before its first action of that step or later) and
is disabled there; its in-flight moves are never cut short.

With `reroute` (and the map, `grid`) the run may change plans as it goes
(`reroute`: new paths for robots a late one holds up, when that pays): the
engine is handed over to the new plan (`handover`) between two events (with
`Rerouter.lag`, that many steps after the look, new moves frozen meanwhile
for `reroute.FREEZE` steps at most, as a live manager does), robots drive on
with the moves they were sent, and a robot's k-th move of the run keeps its
fate whatever plan it belongs to (moves beyond the plan's draw their own,
from the same model and seed). A robot that
`RobotFailed` stops mid-move where it is: when it is enabled again it is sent
the same action and drives on from there. With `journal=True` the run also
keeps what a run log records (`SimResult.journal`: dispatches, starts,
completions, robots out, and who waits for whom whenever that changes), for
`runlog.simulated` to write.
"""
from __future__ import annotations

import heapq
import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Deque, Dict, List, Mapping, Optional, Sequence, Set, Tuple, Union

import numpy as np

from ..delays import DelayModel, MoveFates, robot_profile, simulator_fates
from ..delays.draw import COLUMNS, draw_fates
from ..grid import Coord, Grid
from ..plan import Plan
from ..planning.trim import Trimmed, trim_moves
from ..robot_size import RobotSize
from .actions import ActionTable
from .approach import Approach, Safety, judge
from .engine import Engine
from .events import (ActionCompleted, ActionStarted, Disabled, Dispatch, Enabled, Freeze, Resume, RobotFailed, Thaw,
                     Tick)
from .following import hold_fraction
from .handover import HandoverError, hand_over, renumbered
from .metrics import Metrics
from .motion import Feedback, Motion
from .reroute import FREEZE, Reroute, RerouteRule, Rerouter
from .trace import Collision, Trace, find_collisions

_WAKE, _CONTROL, _RECHECK, _TICK, _LOOKED, _THAW = 0, 1, 2, 3, 4, 5
_EPS = 1e-9


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
    paths: Optional[List[List[Tuple[float, float, float]]]] = None
    safety: Optional[Safety] = None
    size: Optional[RobotSize] = None
    #: (time, reroute) for each change of plan, in order; the engine runs the last plan
    reroutes: Tuple[Tuple[float, Reroute], ...] = ()
    rerouter: Optional[Rerouter] = None
    #: reroutes found whose hand-over was refused (the plan did not fit the run): never, by design
    refused: int = 0
    #: wall-clock seconds the hand-overs took (the only clock the simulator reads: a figure, never a time)
    handover_seconds: float = 0.0
    #: Per robot, the time its moves take with its own delays and no waiting (from the fates).
    alone: Optional[np.ndarray] = None
    #: the trim of the plan given, with `simulate(trim=True)`: the plan that ran is its `plan`
    trimmed: Optional[Trimmed] = None

    @property
    def lower_bound(self) -> float:
        """The makespan had every robot been alone: its moves with its own delays, no waits."""
        if self.alone is None or not len(self.alone):
            return self.metrics.lower_bound
        return float(self.alone.max())

    @property
    def metrics(self) -> Metrics:
        return self.engine.metrics

    @property
    def finished(self) -> bool:
        return self.engine.finished

    @property
    def closest(self) -> Optional[Approach]:
        return None if self.safety is None else self.safety.closest

    def unfinished(self) -> List[int]:
        """Robots taking part that did not reach their goal."""
        run = self.engine.run
        return [r for r in range(run.num_agents) if run.out[r] is None and not run.finished_agent(r)]


def simulate(plan: Plan, strategy: object = "adg", delays: Optional[DelayModel] = None, seed: int = 0,
             durations: Optional[np.ndarray] = None, disable: Optional[Mapping[int, int]] = None,
             controls: Sequence[object] = (), nominal: float = 1.0, waits: Optional[np.ndarray] = None,
             journal: bool = False, size: Optional[RobotSize] = None,
             feedback: Optional[Feedback] = None, fates: Optional[MoveFates] = None,
             reroute: Union[None, str, RerouteRule, Rerouter] = None, grid: Optional[Grid] = None,
             trim: bool = False, **settings: object) -> SimResult:
    """Run `plan` under `strategy` with robots of `size` (None: as large as a cell); each move's
    fate drawn from `delays` with `seed`, or given as `fates`, or as plain `durations` (and
    `waits`); no delays by default. `reroute` ("auto", a rule or a `Rerouter`; None, "none" or
    "off": never) replans robots held up by late ones on `grid` (see `reroute`). `trim`: the
    plan's robots first trimmed of moves that do not bring them in sooner (`planning.trim`, on
    `grid`); a robot's k-th move keeps the fate drawn for its k-th move of `plan`, so a run is
    paired with the same seed's run untrimmed."""
    follow = size is not None and not size.cell_sized
    drawn: Optional[ActionTable] = None  # the moves the fates are drawn for: the plan given's
    trimmed: Optional[Trimmed] = None
    if trim:
        if grid is None:
            raise ValueError("trimming needs the map (grid=)")
        drawn = ActionTable.from_plan(plan)
        trimmed = trim_moves(plan, grid)
        plan = trimmed.plan
    engine = Engine(plan, strategy, follow=follow, **settings)  # type: ignore[arg-type]
    more = None
    if fates is None and durations is None:
        model = delays or DelayModel()
        fates = simulator_fates(model, (drawn or engine.table).agent, engine.run.num_agents, seed, nominal)
        more = _more_fates(model, seed, engine.run.num_agents, nominal)
        if drawn is not None:
            fates, more = _kept_fates(drawn, engine.table, fates, more, nominal)
    result = simulate_engine(engine, durations, disable, controls, waits, journal, size=size,
                             feedback=feedback, fates=fates, nominal=nominal,
                             rerouter=_rerouter(reroute, grid), more=more)
    result.trimmed = trimmed
    return result


def _rerouter(reroute: Union[None, str, RerouteRule, Rerouter], grid: Optional[Grid]) -> Optional[Rerouter]:
    if reroute is None or reroute in ("none", "off"):
        return None
    if isinstance(reroute, Rerouter):
        return reroute
    if reroute != "auto" and not isinstance(reroute, RerouteRule):
        raise ValueError("reroute: expected none, auto or a RerouteRule, got {!r}".format(reroute))
    if grid is None:
        raise ValueError("rerouting needs the map (grid=)")
    return Rerouter(grid, reroute if isinstance(reroute, RerouteRule) else None, timed=False)


Fate = Tuple[float, float, float, float, float, float]  # wait, drive, stall, stall at, dropout, dropout at


def _more_fates(model: DelayModel, seed: int, n: int, nominal: float) -> Callable[[int, int], Fate]:
    """Fates of moves beyond a robot's moves in the plan (a longer path after a reroute): drawn
    from the same model, by (seed, robot, move), with the robot's own profile."""
    factor, prone = robot_profile(model, seed, n)

    def more(r: int, k: int) -> Fate:
        u = np.random.default_rng([seed, 1 + r, k]).random((1, COLUMNS))
        f = draw_fates(model, u, factor[[r]], prone[[r]])
        return (nominal * float(f.wait[0]), nominal * float(f.slowdown[0]), nominal * float(f.stall[0]),
                float(f.stall_at[0]), nominal * float(f.dropout[0]), float(f.dropout_at[0]))
    return more


def _kept_fates(drawn: ActionTable, table: ActionTable, fates: MoveFates, more: Callable[[int, int], Fate],
                nominal: float) -> Tuple[MoveFates, Callable[[int, int], Fate]]:
    """Fates for `table`'s moves (a trimmed plan, fewer moves a robot) from those drawn for
    `drawn`'s: each robot's k-th move keeps its k-th fate, its moves beyond `table`'s count the
    fates that follow, then `more`'s."""
    n = table.num_agents
    pick = np.concatenate([np.arange(drawn.first[r], drawn.first[r] + table.count(r)) for r in range(n)]
                          + [np.zeros(0, dtype=np.int64)]).astype(np.int64)
    kept = MoveFates(*(np.asarray(column)[pick] for column in fates))

    def beyond(r: int, k: int) -> Fate:
        if k < drawn.count(r):
            a = int(drawn.first[r]) + k
            return (float(fates.wait[a]), nominal * float(fates.slowdown[a]), float(fates.stall[a]),
                    float(fates.stall_at[a]), float(fates.dropout[a]), float(fates.dropout_at[a]))
        return more(r, k)
    return kept, beyond


def simulate_engine(engine: Engine, durations: Optional[np.ndarray] = None,
                    disable: Optional[Mapping[int, int]] = None, controls: Sequence[object] = (),
                    waits: Optional[np.ndarray] = None, journal: bool = False,
                    size: Optional[RobotSize] = None, feedback: Optional[Feedback] = None,
                    fates: Optional[MoveFates] = None, nominal: float = 1.0,
                    rerouter: Optional[Rerouter] = None,
                    more: Optional[Callable[[int, int], Fate]] = None) -> SimResult:
    """Run a fresh `engine` (not yet resumed): each move as `fates` say, or taking `durations`
    after `waits` (a constant speed); `more(robot, k)`: the fate of a robot's k-th move beyond
    its moves in the plan (default: its own fates again, in turn)."""
    if fates is None:
        if durations is None:
            raise ValueError("simulate_engine needs fates or durations")
        n = durations.shape[0]
        zero = np.zeros(n)
        fates = MoveFates(np.zeros(n) if waits is None else waits, durations / nominal, zero, zero, zero, zero)
    sim = _Simulation(engine, fates, nominal, disable or {}, journal, size, feedback or Feedback(), more)
    engine.allow_take_back(sim.take_back)
    sim.rerouter = rerouter
    sim.run(controls)
    table = engine.table  # the run's first plan: the fates are its moves'
    engine = sim.engine  # the engine of the plan the run ended with
    total = nominal * fates.slowdown + fates.stall + fates.dropout
    paths = [m.knots for m in sim.paths]
    if size is None or size.cell_sized:
        collisions = find_collisions(sim.trace)
        safety = judge(paths, 1.0 if size is None else size.safe_cells, sim.now)
    else:
        safety = judge(paths, size.safe_cells, sim.now)
        collisions = [Collision("too-close", a.agents, (a.place,), a.time, (True, True))  # type: ignore[arg-type]
                      for a in safety.violations]
    alone = np.bincount(table.agent, weights=fates.wait + total, minlength=engine.run.num_agents)
    return SimResult(engine, sim.trace, total, collisions, sim.now, sim.disabled_at, fates.wait,
                     sim.journal, paths, safety, size, reroutes=tuple(sim.reroutes), rerouter=rerouter, refused=sim.refused,
                     handover_seconds=sim.handover_seconds,
                     alone=alone)


class _Simulation:
    def __init__(self, engine: Engine, fates: MoveFates, nominal: float, disable: Mapping[int, int],
                 journal: bool, size: Optional[RobotSize], feedback: Feedback,
                 more: Optional[Callable[[int, int], Fate]] = None) -> None:
        n = engine.run.num_agents
        self.engine = engine
        # a robot's moves are counted over the whole run (its k-th move: ordinal k); plan actions
        # are ordinal - offset[r] of the plan the engine runs; fates and completions go by ordinal
        self.offset = [0] * n
        self.first0: List[int] = list(engine.run.first)
        self.nominal = nominal
        self.more = more
        self._extra: Dict[Tuple[int, int], int] = {}
        self.rerouter: Optional[Rerouter] = None
        self.reroutes: List[Tuple[float, Reroute]] = []
        self.refused = 0  # reroutes whose hand-over was refused
        self._looking = False  # a look's hand-over is on the heap (`Rerouter.lag`)
        self.handover_seconds = 0.0  # wall-clock seconds the hand-overs took (bench/reroute.py)
        self.wait: List[float] = fates.wait.tolist()
        self.drive: List[float] = (nominal * fates.slowdown).tolist()
        self.stall: List[float] = fates.stall.tolist()
        self.stall_at: List[float] = fates.stall_at.tolist()
        self.drop: List[float] = fates.dropout.tolist()
        self.drop_at: List[float] = fates.dropout_at.tolist()
        self.safe = None if size is None or size.cell_sized else size.safe_cells
        self.feedback = feedback
        self.journal: Optional[List[Tuple[float, str, dict]]] = [] if journal else None
        self._waits_seen: object = ()
        self._passes_seen = 0
        self._ticking = False  # a Tick is on the heap
        self._charged: Dict[int, Tuple[float, float, Dict[int, float], float]] = {}
        # the ordinal of the move before which each robot to disable stops (its first of that step)
        self.disable = {r: k for r, k in ((r, self._first_at(engine, r, step)) for r, step in disable.items())
                        if k is not None}
        table = engine.table
        self.trace = Trace([table.start(r) for r in range(n)])
        self.paths = [Motion.at_rest(table.start(r)) for r in range(n)]
        self.queue: List[Deque[Dispatch]] = [deque() for _ in range(n)]
        self.busy: List[Optional[Tuple[Dispatch, float, int]]] = [None] * n  # action, start, token
        self.completed_at: Dict[int, float] = {}  # fate id (a robot's ordinal) -> when it completed
        self.stand_until: Dict[int, float] = {}  # fate id (a robot's ordinal) taken back -> its wait's end
        self.held_by: Dict[int, Set[int]] = {}  # leader -> followers held until it moves
        self.heap: List[tuple] = []
        self.seq = 0
        self.now = 0.0
        self.disabled_at: Dict[int, float] = {}

    def run(self, controls: Sequence[object]) -> None:
        for event in controls:
            self._push(event.time, _CONTROL, event)  # type: ignore[attr-defined]
        self._deliver(self.engine.handle(Resume(0.0)))
        self._tick_later()
        while self.heap:
            time, _, kind, payload = heapq.heappop(self.heap)
            self.now = time
            if kind == _TICK:
                self._ticking = False
                self._deliver(self.engine.handle(Tick(time)))
            elif kind == _LOOKED:
                self._looking = False
                if payload is None:
                    self._deliver(self.engine.handle(Thaw(time)))
                else:
                    self._hand_over(payload)
            elif kind == _THAW:
                self._deliver(self.engine.handle(Thaw(time)))
            elif kind == _CONTROL:
                self._control(payload)
            else:
                r, token = payload
                busy = self.busy[r]
                if busy is None or busy[2] != token:
                    continue  # superseded (a failure, a new plan of motion)
                if kind == _WAKE:
                    self._wake(r)
                else:
                    self._drive_on(r)
            if self.rerouter is not None:
                self._reroute()
            if not self._ticking:
                self._tick_later()
            if self.journal is not None:
                self._note_waits()

    def _tick_later(self) -> None:
        """The strategy's next `Tick`, while something else is still to happen."""
        every = self.engine.tick_every
        if every > 0 and self.heap:
            self._ticking = True
            self._push(self.now + every, _TICK, None)

    @staticmethod
    def _first_at(engine: Engine, r: int, step: int) -> Optional[int]:
        run = engine.run
        for a in range(run.first[r], run.first[r + 1]):
            if run.step[a] >= step:
                return a - run.first[r]
        return None

    def _fid(self, r: int, k: int) -> int:
        """The fate id of robot r's move k of the run (ordinal)."""
        if k < self.first0[r + 1] - self.first0[r]:
            return self.first0[r] + k
        fid = self._extra.get((r, k))
        if fid is None:
            fid = self._extra[(r, k)] = len(self.wait)
            fate = self.more(r, k) if self.more is not None else self._again(r, k)
            for column, value in zip((self.wait, self.drive, self.stall, self.stall_at, self.drop, self.drop_at),
                                     fate):
                column.append(value)
        return fid

    def _again(self, r: int, k: int) -> Fate:
        """A robot's own fates again, in turn (fates given without a model to draw more from)."""
        count = self.first0[r + 1] - self.first0[r]
        if count == 0:
            return (0.0, self.nominal, 0.0, 0.0, 0.0, 0.0)
        a = self.first0[r] + k % count
        return (self.wait[a], self.drive[a], self.stall[a], self.stall_at[a], self.drop[a], self.drop_at[a])

    def _dst(self, r: int, k: int) -> Coord:
        """The target of robot r's move k of the run (ordinal)."""
        if k < self.offset[r]:
            return self.trace.moves[r][k].dst
        run = self.engine.run
        return self.engine.table.coord(run.dst[run.first[r] + k - self.offset[r]])

    # ---- a new plan ----------------------------------------------------------------------

    def _reroute(self) -> None:
        assert self.rerouter is not None
        if self._looking:
            return
        looks = self.rerouter.looks
        found = self.rerouter.consider(self.engine, self.now)
        lag = self.rerouter.lag
        # the looks a manager asks for take `lag`; none while nothing else is to happen (the run
        # is stuck: a robot out for good), where waiting would change nothing and never end
        if (lag <= 0 or self.rerouter.looks == looks or not self.heap
                or (found is None and not self.rerouter.wanted(self.engine, self.now))):
            if found is not None:
                self._hand_over(found)
            return
        # the manager's worker thread: every look's answer (a reroute or none) comes `lag` steps later
        self._looking = True
        self._deliver(self.engine.handle(Freeze(self.now)))
        self._push(self.now + lag, _LOOKED, found)
        if lag > FREEZE:
            self._push(self.now + FREEZE, _THAW, None)

    def _hand_over(self, found: Reroute) -> None:
        old = self.engine
        began = time.perf_counter()
        try:
            new, dispatches = hand_over(old, found, self.now)
        except HandoverError:  # never at the cut's own moment; a run goes on with its plan all the same
            self.refused += 1
            self._deliver(old.handle(Thaw(self.now)))
            return
        shift = found.cut.base  # the hand-over is at the cut: a robot's moves from its base on
        for r in range(old.run.num_agents):
            self.offset[r] += shift[r]
        self.engine = new
        self.handover_seconds += time.perf_counter() - began
        self.rerouter.restart()
        self.reroutes.append((self.now, found))
        self._passes_seen = 0
        run = new.run

        def moved(d: Dispatch) -> Dispatch:
            return renumbered(new, shift, d)
        for r in range(run.num_agents):
            busy = self.busy[r]
            if busy is not None:
                self.busy[r] = (moved(busy[0]), busy[1], busy[2])
            self.queue[r] = deque(moved(d) for d in self.queue[r])
        self._note("reroute", robots=list(found.agents), around=found.around, late=found.late, gain=found.gain,
                   text=found.describe())
        self._deliver(dispatches)

    # ---- robots --------------------------------------------------------------------------

    def _try_start(self, r: int) -> None:
        if self.busy[r] is not None or not self.queue[r] or self.engine.run.out[r] is not None:
            return
        d = self.queue[r][0]
        stop = self.disable.get(r)
        if stop is not None and self.offset[r] + d.index >= stop:
            del self.disable[r]
            self.queue[r].clear()
            self.disabled_at[r] = self.now
            self._note("out", robot=r, why="disabled", reason="disable")
            self._deliver(self.engine.handle(Disabled(r, self.now)))
            return
        self.queue[r].popleft()
        a = self._fid(r, self.offset[r] + d.index)
        path = self.paths[r]
        if path.action == a:  # the move it stopped in (a fault): it drives on from where it is
            path.resume(self.now)
            self._begin(r, d, path.began)
            return
        wait = self.wait[a] if a not in self.stand_until else max(0.0, self.stand_until.pop(a) - self.now)
        path.start(a, d.src, d.dst, self.now, wait, self.drive[a],
                   (self.stall_at[a], self.stall[a]), (self.drop_at[a], self.drop[a]))
        if wait > 0:  # it stays in its cell for the wait, then starts moving
            self._set_busy(r, d, self.now)
            self._schedule(r, _WAKE, self.now + wait)
            return
        self._begin(r, d, self.now)

    def take_back(self, r: int, k: int) -> bool:
        """The engine takes back robot r's actions from index k on: only if it has not begun
        moving in any of them (it then keeps standing still for what is left of its wait)."""
        busy = self.busy[r]
        if busy is not None and busy[0].index >= k:
            path = self.paths[r]
            if path.moving:
                return False
            a = self._fid(r, self.offset[r] + busy[0].index)
            self.stand_until[a] = path.began  # it stands still till then, sent the move or not
            self.busy[r] = None
            path.forget()
        queue = self.queue[r]
        while queue and queue[-1].index >= k:
            queue.pop()
        return True

    def _begin(self, r: int, d: Dispatch, began: float) -> None:
        """Robot r starts its move d (it occupies both cells from `began`)."""
        self.engine.handle(ActionStarted(r, d.index, self.now))
        self._note("action", robot=r, index=d.index, phase="started", src=d.src, dst=d.dst)
        self._set_busy(r, d, began)
        self.paths[r].moving = True
        self._drive_on(r)

    def _wake(self, r: int) -> None:
        """Robot r reached what it was heading for: the end of its wait, a stall, its hold point
        or the end of its move."""
        busy = self.busy[r]
        path = self.paths[r]
        assert busy is not None
        if not path.moving:  # its wait is over
            self._begin(r, busy[0], self.now)
            return
        path.advance(self.now)
        if path.progress >= 1.0 - _EPS:
            self._complete(r)
        else:
            self._drive_on(r)

    def _drive_on(self, r: int) -> None:
        """Robot r goes on (or stays) as its stall and its hold point allow; its next wake."""
        path = self.paths[r]
        busy = self.busy[r]
        assert busy is not None
        path.advance(self.now)
        if path.stalled_until > self.now + _EPS:
            self._schedule(r, _WAKE, path.stalled_until)
            return
        d = busy[0]
        hold = 1.0 if d.follows is None or self.safe is None else self._hold(r, d, path.progress)
        if hold <= path.progress + _EPS:
            path.halt(self.now)  # it waits at its hold point for the next report
            lpath = self.paths[d.follows[0]]  # type: ignore[index]
            if lpath.driving or lpath.knots[-1][0] > self.feedback.seen_at(self.now):
                self._schedule(r, _RECHECK, self.feedback.next_report(self.now))
            else:  # reports would say the same until the leader moves: wait for that
                self.held_by.setdefault(d.follows[0], set()).add(r)  # type: ignore[index]
            return
        starting = not path.driving
        self._schedule(r, _WAKE, path.go(self.now, hold))
        if starting:
            self._moved(r)

    def _moved(self, r: int) -> None:
        """Robot r began to move or arrived: robots held behind it look at the next report."""
        for follower in self.held_by.pop(r, ()):
            if self.busy[follower] is not None:
                self._schedule(follower, _RECHECK, self.feedback.next_report(self.now))

    def _hold(self, r: int, d: Dispatch, progress: float) -> float:
        """How far robot r may go in its move d, following d.follows, by the newest report."""
        leader, index = d.follows  # type: ignore[misc]
        lead = self.offset[leader] + index  # the leader's move out of the cell (ordinal)
        seen = self.feedback.seen_at(self.now)
        done = self.completed_at.get(self._fid(leader, lead))
        if done is not None and done <= seen:
            return 1.0
        lpath = self.paths[leader]
        x, y = lpath.position(seen)
        first = lead
        while first > 0 and self.completed_at.get(self._fid(leader, first - 1), math.inf) > seen:
            first -= 1
        points = [(x, y)] + [self._dst(leader, b) for b in range(first, lead + 1)]
        return hold_fraction(d.src, d.dst, points, self.safe, progress)  # type: ignore[arg-type]

    def _complete(self, r: int) -> None:
        busy = self.busy[r]
        assert busy is not None
        d, began, _ = busy
        self.busy[r] = None
        a = self._fid(r, self.offset[r] + d.index)
        self.paths[r].arrive(self.now)
        self.completed_at[a] = self.now
        self.trace.add(r, began, self.now, d.src, d.dst)
        self._note("action", robot=r, index=d.index, phase="completed", src=d.src, dst=d.dst)
        self._moved(r)
        self._deliver(self.engine.handle(ActionCompleted(r, d.index, self.now)))
        self._try_start(r)

    def _set_busy(self, r: int, d: Dispatch, began: float) -> None:
        self.seq += 1
        self.busy[r] = (d, began, self.seq)

    def _schedule(self, r: int, kind: int, time: float) -> None:
        busy = self.busy[r]
        assert busy is not None
        self.seq += 1
        self.busy[r] = (busy[0], busy[1], self.seq)
        heapq.heappush(self.heap, (time, self.seq, kind, (r, self.seq)))

    # ---- control -------------------------------------------------------------------------

    def _control(self, event: object) -> None:
        agent = getattr(event, "agent", None)
        if isinstance(event, (Disabled, RobotFailed)):
            self.queue[agent].clear()  # type: ignore[index]
            busy = self.busy[agent]  # type: ignore[index]
            path = self.paths[agent]  # type: ignore[index]
            if busy is not None and not path.moving:
                self.busy[agent] = None  # type: ignore[index]  # it had not started: nothing to finish
                path.forget()
            elif busy is not None and isinstance(event, RobotFailed):
                path.advance(self.now)
                path.halt(self.now)  # stops where it is, in both cells, until enabled
                self.busy[agent] = None  # type: ignore[index]
        if isinstance(event, (Disabled, RobotFailed, Enabled)):
            why = "disabled" if isinstance(event, Disabled) else "failed" if isinstance(event, RobotFailed) else None
            self._note("out", robot=agent, why=why, reason=type(event).__name__)
        self._deliver(self.engine.handle(event))
        if isinstance(event, Enabled):
            self._try_start(agent)  # type: ignore[arg-type]

    def _deliver(self, dispatches: List[Dispatch]) -> None:
        passes = self.engine.run.passes
        if self.journal is not None and len(passes) > self._passes_seen:
            table = self.engine.table
            for p in passes[self._passes_seen:]:
                self._note("pass", robot=p.agent, passed=p.passed, cell=table.coord(p.cell),  # type: ignore[attr-defined]
                           taken_back=p.taken_back)  # type: ignore[attr-defined]
            self._passes_seen = len(passes)
        for d in dispatches:
            self.queue[d.agent].append(d)
            if self.journal is not None:
                waited, forced, by, held = self._waited(d.agent)
                cause = {} if by is not None or held >= waited else {"cause": "reroute"}  # not the operator
                self._note("dispatch", robot=d.agent, index=d.index, step=d.step, src=d.src, dst=d.dst,
                           waited=waited, forced=forced, released_by=by, **cause)
        for d in dispatches:
            self._try_start(d.agent)

    # ---- the journal ---------------------------------------------------------------------

    def _note(self, kind: str, **fields: object) -> None:
        if self.journal is not None:
            self.journal.append((self.now, kind, fields))

    def _waited(self, r: int) -> Tuple[float, float, Optional[int], float]:
        """What the metrics charged robot r since its last dispatch: time waited, of it forced,
        to whom, and of it held by the operator."""
        m = self.engine.metrics.agents[r]
        seen = self._charged.get(r, (0.0, 0.0, {}, 0.0))
        waited = m.wait_time - seen[0]
        forced = m.forced_time - seen[1]
        held = m.held_time - seen[3]
        by = next((q for q, t in m.blocked_by.items() if t > seen[2].get(q, 0.0)), None)
        self._charged[r] = (m.wait_time, m.forced_time, dict(m.blocked_by), m.held_time)
        return round(waited, 6), round(forced, 6), by, round(held, 6)

    def _note_waits(self) -> None:
        waits = tuple((w.agent, w.on, w.cell, w.reason) for w in self.engine.waiting())
        if waits != self._waits_seen:
            self._waits_seen = waits
            self._note("waits", w=[list(w) for w in waits])

    def _push(self, time: float, kind: int, payload: object) -> None:
        self.seq += 1
        heapq.heappush(self.heap, (time, self.seq, kind, payload))
