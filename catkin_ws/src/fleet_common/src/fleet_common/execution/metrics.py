"""Run metrics, computed from the engine's events and decisions alone.

Times are relative to the first `Resume` or `StepRound` (the run's start), in the caller's
unit. A robot *waits* from the moment it is ready for its next action (its
previous one completed, the run started, or it was enabled again) until that
action is dispatched; a wait is charged to the robot whose completion
released it (the leader it followed, the last robot of a step barrier, a
robot enabled again), or to "held" when the operator released it (resume,
step, strategy switch); a wait the rerouting ended (a look that kept new moves
back, `Thaw`, or the hand-over to its plan) is neither: it counts as avoidable. The executed makespan is the last completion; the
sum of costs adds each robot's arrival (its last completion, 0 if it never
moves) over the robots that reached their goals.

Waits not held by the operator are *forced* or *avoidable* (the engine says
how much of each wait was forced, `Engine._forced`): forced while the cell
the robot needs was taken by the plan's order in a way no change of order
could undo (the robot ahead of it there was in the cell or had been sent its
move into it, or the cell is the robot's goal), avoidable otherwise (the
robot ahead had not set off into the cell; a strategy's own holds).

A robot's *own time* adds, move by move, the time from when it was sent the
move (or finished the one before, if it had it already) until it completed
it: its moves with its own delays, without its waits. The *lower bound* of
a run is the largest own time: the makespan had every robot been alone.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

from .events import ActionCompleted, Disabled, Enabled, RobotFailed, Resume, StepRound


@dataclass
class RobotMetrics:
    """One robot's figures; `blocked_by[q]` is the time it waited for robot q."""

    moves: int = 0
    waits: int = 0
    wait_time: float = 0.0
    held_time: float = 0.0
    forced_time: float = 0.0
    own_time: float = 0.0
    blocked_by: Dict[int, float] = field(default_factory=dict)
    arrival: Optional[float] = None

    @property
    def avoidable_time(self) -> float:
        """Waiting that was neither held by the operator nor forced by the plan's order."""
        return max(0.0, self.wait_time - self.held_time - self.forced_time)


class Metrics:
    """Fed by the engine with every event and dispatch; read at any time."""

    def __init__(self, actions_per_agent: List[int]) -> None:
        self.counts = list(actions_per_agent)
        self.agents = [RobotMetrics(arrival=0.0 if c == 0 else None) for c in self.counts]
        self.begin: Optional[float] = None
        self.last_completion: Optional[float] = None
        self._ready: List[Optional[float]] = [None] * len(self.counts)
        self._done = [0] * len(self.counts)
        self._busy: List[Optional[float]] = [None] * len(self.counts)  # since when on its move
        self._ahead = [0] * len(self.counts)  # actions dispatched (sent ahead included)
        #: per robot, seconds it turned in place towards a move it had been sent (robots on the
        #: wire face their next cell first; a simulated robot never turns): part of its own time,
        #: but no delay (`reroute.delayed`)
        self.turn_time = [0.0] * len(self.counts)
        #: per robot, the wait its latest waiting dispatch ended (a caller logging each dispatch
        #: clears it before an event and takes what the event's dispatches left)
        self.last_wait: Dict[int, float] = {}
        #: the same for the forced part of those waits
        self.last_forced: Dict[int, float] = {}
        #: per robot, its moves in the run before the first move of the plan the engine runs now
        #: (a run handed over to a new plan: `rebase`); action indices count from there
        self.offset = [0] * len(self.counts)
        self._last: List[Optional[float]] = [None] * len(self.counts)

    def record(self, event: object) -> None:
        if isinstance(event, ActionCompleted):
            self._completed(event.agent, event.time)
        elif isinstance(event, (Resume, StepRound)) and self.begin is None:
            self.begin = event.time
            self._ready = [event.time] * len(self.counts)
        elif isinstance(event, Enabled):
            self._ready[event.agent] = event.time
        elif isinstance(event, (Disabled, RobotFailed)):
            self._ready[event.agent] = None
            self._ahead[event.agent] = self._done[event.agent]
            self._busy[event.agent] = None  # what it may still finish counts from its completion

    def rebase(self, offsets: List[int], counts: List[int]) -> None:
        """The run goes on with a new plan: robot r made `offsets[r]` moves before its first one,
        and has `counts[r]` moves in it (one Metrics object for the whole run)."""
        self.offset = list(offsets)
        self.counts = [o + c for o, c in zip(offsets, counts)]
        for r, m in enumerate(self.agents):
            if self._done[r] == self.counts[r]:
                if m.arrival is None:  # arrived with its last move of the old plan
                    m.arrival = (self._last[r] or 0.0) - (self.begin or 0.0)
            else:
                m.arrival = None

    def restored(self, completed: List[int], time: float) -> None:
        """The run goes on from progress known from elsewhere (`Engine.restore`): robots are
        ready for their next action from `time`."""
        self._done = list(completed)
        self._ahead = list(completed)
        self._busy = [None] * len(self.counts)
        self._ready = [time] * len(self.counts)
        for r, done in enumerate(completed):
            if done and done == self.counts[r]:
                self.agents[r].arrival = time - (self.begin or 0.0)

    def own_delay(self, agent: int, now: float, nominal: float) -> float:
        """How much longer than `nominal` a move the robot's moves have taken it so far (its own
        time less its moves' nominal time), the move it is on counted up to `now`: its own delays,
        none of its waits."""
        m = self.agents[agent]
        since = self._busy[agent]
        if since is None:
            return m.own_time - nominal * m.moves
        return m.own_time + max(0.0, now - since) - nominal * (m.moves + 1)

    def turned(self, agent: int, since: float, now: float) -> None:
        """Robot `agent` turned in place from `since` to `now`: the part of it on a move it had been
        sent counts in `turn_time`."""
        busy = self._busy[agent]
        if busy is not None:
            self.turn_time[agent] += max(0.0, now - max(since, busy))

    def ready_at(self, agent: int) -> Optional[float]:
        """Since when the robot has been ready for an action it was not sent (None: it has one)."""
        return self._ready[agent]

    def record_dispatch(self, agent: int, index: int, time: float, released_by: Optional[int],
                        forced: float = 0.0, operator: bool = True) -> None:
        """Robot `agent` was sent its action `index` at `time`; `forced`: how much of the wait
        that ends here was forced (see the module docstring); `operator`: False when what ended it
        without a robot (`released_by` None) was not the operator but the rerouting."""
        index += self.offset[agent]
        self._ahead[agent] = max(self._ahead[agent], index + 1)
        if index == self._done[agent] and self._busy[agent] is None:
            self._busy[agent] = time
        ready = self._ready[agent]
        if index != self._done[agent] or ready is None:
            return  # sent ahead (lookahead) or not ready: no wait
        self._ready[agent] = None
        waited = time - ready
        if waited <= 0:
            return
        self.last_wait[agent] = waited
        m = self.agents[agent]
        if released_by is not None and released_by != agent:
            self.last_forced[agent] = min(max(forced, 0.0), waited)
        m.waits += 1
        m.wait_time += waited
        if released_by is None or released_by == agent:
            if operator:
                m.held_time += waited
        else:
            m.forced_time += min(max(forced, 0.0), waited)
            m.blocked_by[released_by] = m.blocked_by.get(released_by, 0.0) + waited

    def taken_back(self, agent: int, index: int, time: float) -> None:
        """The robot's actions from `index` on were taken back (another robot passes it): from
        now on it waits to be sent its action again."""
        index += self.offset[agent]
        self._ahead[agent] = min(self._ahead[agent], index)
        if index == self._done[agent]:
            m = self.agents[agent]
            if self._busy[agent] is not None:
                m.own_time += max(0.0, time - self._busy[agent])  # it stood still meanwhile
            self._busy[agent] = None
            self._ready[agent] = time

    def _completed(self, agent: int, time: float) -> None:
        self._done[agent] += 1
        m = self.agents[agent]
        m.moves += 1
        since = self._busy[agent]
        if since is not None:
            m.own_time += max(0.0, time - since)
        self._busy[agent] = time if self._ahead[agent] > self._done[agent] else None
        self._ready[agent] = time
        self._last[agent] = time
        self.last_completion = time
        if self._done[agent] == self.counts[agent]:
            m.arrival = time - (self.begin or 0.0)

    @property
    def makespan(self) -> float:
        if self.last_completion is None:
            return 0.0
        return self.last_completion - (self.begin or 0.0)

    @property
    def reached(self) -> List[int]:
        """Robots that completed all their actions (or had none)."""
        return [r for r, m in enumerate(self.agents) if m.arrival is not None]

    @property
    def soc(self) -> float:
        return sum(m.arrival for m in self.agents if m.arrival is not None)

    @property
    def lower_bound(self) -> float:
        """The makespan had every robot run alone, with its own delays: the largest own time."""
        return max((m.own_time for m in self.agents), default=0.0)

    @property
    def total_forced_time(self) -> float:
        return sum(m.forced_time for m in self.agents)

    @property
    def total_avoidable_time(self) -> float:
        return sum(m.avoidable_time for m in self.agents)

    @property
    def total_held_time(self) -> float:
        return sum(m.held_time for m in self.agents)

    @property
    def total_waits(self) -> int:
        return sum(m.waits for m in self.agents)

    @property
    def total_wait_time(self) -> float:
        return sum(m.wait_time for m in self.agents)

    def blocking_pairs(self) -> List[tuple]:
        """(time, waiting robot, blocking robot), longest first."""
        pairs = [(t, r, q) for r, m in enumerate(self.agents) for q, t in m.blocked_by.items()]
        pairs.sort(key=lambda p: (-p[0], p[1], p[2]))
        return pairs
