"""The progress of one run: what every robot was sent, has started and completed.

One `RunState` is shared by the engine (which writes it) and whichever
strategy is active (which reads it). Progress lives here and nowhere else, so
switching strategies mid-run loses nothing: the new strategy derives its own
bookkeeping from this state when it is attached.

Per robot, actions are counted in order: `completed <= started <= dispatched
<= sent`. `dispatched` is what the robot is committed to now; `sent` is the
most ever sent, so a robot that finishes a move it was sent before it was
disabled is believed. A robot is *out* while disabled (the operator's choice)
or failed (it reported a fault); out robots get no new actions.

Lists of Python ints rather than numpy arrays: the engine reads a handful of
entries per event, and a list index is several times faster than a numpy one.
"""
from __future__ import annotations

from typing import Callable, List, Optional

import numpy as np

from .actions import ActionTable
from .adg import ActionDependencyGraph

DISABLED = "disabled"
FAILED = "failed"


class PlanClock:
    """The plan's clock in a run: plan steps of running time (paused and stepped time does not
    count), for strategies that ask whether a robot is behind the plan."""

    def __init__(self, step_time: float = 1.0) -> None:
        if not step_time > 0:
            raise ValueError("a plan step must take some time, got {!r}".format(step_time))
        self.step_time = step_time
        self._ran = 0.0
        self._since: Optional[float] = None

    def run(self, now: float) -> None:
        if self._since is None:
            self._since = now

    def stop(self, now: float) -> None:
        if self._since is not None:
            self._ran += max(0.0, now - self._since)
            self._since = None

    def steps(self, now: float) -> float:
        """Plan steps of running time at `now`."""
        ran = self._ran + (max(0.0, now - self._since) if self._since is not None else 0.0)
        return ran / self.step_time


def _never(agent: int, index: int) -> bool:
    return False


class RunState:
    """Progress per robot and per action; see the module docstring."""

    def __init__(self, graph: ActionDependencyGraph) -> None:
        table = graph.table
        self.table: ActionTable = table
        self.graph = graph
        self.num_agents = table.num_agents
        self.first: List[int] = table.first.tolist()
        self.step: List[int] = table.step.tolist()
        self.agent: List[int] = table.agent.tolist()
        self.src: List[int] = table.src.tolist()
        self.dst: List[int] = table.dst.tolist()
        self.dep: List[int] = graph.dep.tolist()
        self.succ: List[int] = graph.succ.tolist()
        n = self.num_agents
        self.done = bytearray(table.num_actions)
        self.completed = [0] * n
        self.started = [0] * n
        self.dispatched = [0] * n
        self.sent = [0] * n
        #: When each robot was last dispatched an action while it had none in hand.
        self.dispatched_at = [0.0] * n
        #: When each robot began its latest move (its last ActionStarted; a restore's time).
        self.started_at = [0.0] * n
        #: None while the robot takes part; DISABLED or FAILED while it is out.
        self.out: List[Optional[str]] = [None] * n
        #: Robots that failed in the middle of a move and have not completed it since: the robot
        #: stands between two cells, and only that move (sent again on Enabled) gets it out.
        self.halfway = [False] * n
        #: Robots smaller than a cell: a move out of a cell releases the next visitor once it is
        #: dispatched (the follower is held at the safe distance), not only once it completed.
        self.follow = False
        #: Changes of a cell's order of robots made by a re-ordering strategy (`reorder.Pass`),
        #: in the order they were made; `dep` and `succ` already include them.
        self.passes: List[object] = []
        #: `take_back(r, k)`: ask the caller to take back robot r's dispatched, unstarted actions
        #: from index k on; True when it did (they will never start). Set by the engine.
        self.take_back: Callable[[int, int], bool] = _never
        #: The time of the event being handled, and the plan's clock (set by the engine).
        self.now = 0.0
        self.clock = PlanClock()
        #: Events handled so far; strategies key their caches on it.
        self.version = 0
        self._by_step: Optional[List[List[int]]] = None

    def count(self, r: int) -> int:
        return self.first[r + 1] - self.first[r]

    def active(self, r: int) -> bool:
        return self.out[r] is None

    def finished_agent(self, r: int) -> bool:
        return self.completed[r] == self.first[r + 1] - self.first[r]

    def released(self, d: int) -> bool:
        """Is dependency `d` (a move out of a cell, or -1) met for the next visitor to start?"""
        if d < 0 or self.done[d]:
            return True
        r = self.agent[d]
        return self.follow and self.dispatched[r] > d - self.first[r]

    def overran(self, r: int, now: float) -> float:
        """Plan steps robot r's begun move has taken beyond the one step a move takes, when nothing
        but the robot holds it (its leader left the cell): a robot that accepted its drive and
        stands inside it, as the manager sees a late robot. 0 when it has not begun a move, is
        on time, or follows a leader still in the cell (that wait is the leader's)."""
        if self.started[r] <= self.completed[r]:
            return 0.0
        a = self.first[r] + self.completed[r]
        d = self.dep[a]
        if d >= 0 and self.agent[d] != r and not self.done[d]:
            return 0.0
        return max(0.0, self.clock.steps(now) - self.clock.steps(self.started_at[r]) - 1.0)

    def next_undispatched(self, r: int) -> int:
        """Flat index of the next action robot r has not been sent, or -1."""
        a = self.first[r] + self.dispatched[r]
        return a if a < self.first[r + 1] else -1

    def next_incomplete(self, r: int) -> int:
        a = self.first[r] + self.completed[r]
        return a if a < self.first[r + 1] else -1

    def incomplete_active_mask(self) -> np.ndarray:
        """Per action: not completed and its robot is not out."""
        done = np.frombuffer(bytes(self.done), dtype=np.uint8).astype(bool)
        active = np.array([o is None for o in self.out], dtype=bool)
        return ~done & active[self.table.agent] if self.table.num_actions else done

    def agents_at_step(self, t: int) -> List[int]:
        """Robots that have an action in plan step t (built once, on first use)."""
        if self._by_step is None:
            steps = self.table.step
            order = np.argsort(steps, kind="stable")
            bounds = np.searchsorted(steps[order], np.arange(self.table.makespan + 2))
            agents = self.table.agent[order].tolist()
            b = bounds.tolist()
            self._by_step = [agents[b[s]:b[s + 1]] for s in range(len(b) - 1)]
        return self._by_step[t] if 0 <= t < len(self._by_step) else []

    @property
    def finished(self) -> bool:
        """Every robot that is not out has completed all its actions."""
        return all(self.out[r] is not None or self.finished_agent(r) for r in range(self.num_agents))

    @property
    def moving(self) -> bool:
        """Some robot has an action it was sent and has not completed."""
        return any(self.dispatched[r] > self.completed[r] for r in range(self.num_agents))
