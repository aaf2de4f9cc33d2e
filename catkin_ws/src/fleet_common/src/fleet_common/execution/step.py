"""The discrete time step: the original system's implicit barrier, as a strategy.

No robot starts an action of plan step t + 1 before every robot that takes
part has completed its actions of step t, so the run keeps the plan's timing
and a student sees their plan as the solver wrote it (thesis 5.6.1). Steps in
which nobody moves are skipped. Following moves (a robot entering a cell that
another leaves in the same step) are not started together: the engine's
dependency rule starts the follower once the leader's move is complete, so a
chain of k followers takes k move times within the step.

The barrier is the lowest step with an incomplete action of a robot that is
not out; `remaining[t]` counts those actions per step, so a completion costs
O(1) and only the completion that empties the barrier step looks at the
robots of the next one.

After a re-ordering strategy (`reorder`) changed a cell's order of robots, a
robot's move of an early plan step may wait for another's move of a later
one; the barrier then counts *effective* steps, each action's plan step raised
to that of the moves it waits for (`effective_steps`), so that it never waits
for a move it holds back itself. A disabled robot leaves the count (the others go on
without it) and rejoins it when enabled: the others then wait for it to catch
up, as the plan's timing says.
"""
from __future__ import annotations

from bisect import bisect_right
from typing import List, Optional, Sequence, Tuple

import numpy as np

from .run import RunState
from .strategy import BARRIER, Strategy, register


@register
class DiscreteTimeStep(Strategy):
    """Everyone finishes step t before anyone starts step t + 1."""

    name = "step"
    summary = "discrete time step: every robot waits for the slowest at each plan step"

    def __init__(self) -> None:
        super().__init__()
        self.step: List[int] = []
        self._by_step: Optional[List[List[int]]] = None
        self.barrier = 0
        self.remaining: List[int] = []
        self._reason_key = (-1, -1)
        self._reason: Tuple[int, ...] = ()

    def attach(self, run: RunState) -> None:
        super().attach(run)
        self.step = run.step if not run.passes else effective_steps(run)
        self._by_step: Optional[List[List[int]]] = None
        mask = run.incomplete_active_mask()
        steps = np.asarray(self.step, dtype=np.int64)[mask] if run.table.num_actions else np.zeros(0, dtype=np.int64)
        last = max(self.step) if self.step else 0
        self.remaining = np.bincount(steps, minlength=max(last, run.table.makespan) + 1).tolist()
        self.barrier = 0
        self._advance()

    def holds(self, a: int) -> bool:
        return self.step[a] > self.barrier

    def hold_reason(self, a: int) -> Tuple[str, Tuple[int, ...]]:
        run = self._attached()
        key = (self.barrier, run.version)
        if key != self._reason_key:  # one tuple per state, shared by every waiting robot
            self._reason_key = key
            t = self.barrier
            self._reason = tuple(sorted({
                r for r in self._agents_at(t)
                if run.active(r) and not run.done[self._action_at(r, t)]}))
        return (BARRIER, self._reason)

    def on_completed(self, a: int) -> Sequence[int]:
        run = self.run
        if run.out[run.agent[a]] is not None:  # type: ignore[union-attr]
            return ()  # not counted while out
        t = self.step[a]
        self.remaining[t] -= 1
        if t == self.barrier and self.remaining[t] == 0:
            return self._advance()
        return ()

    def on_out(self, agent: int) -> Sequence[int]:
        run = self._attached()
        for a in range(run.first[agent] + run.completed[agent], run.first[agent + 1]):
            self.remaining[self.step[a]] -= 1
        if self.barrier < len(self.remaining) and self.remaining[self.barrier] == 0:
            return self._advance()
        return ()

    def on_back(self, agent: int) -> Sequence[int]:
        run = self._attached()
        a = run.next_incomplete(agent)
        for b in range(run.first[agent] + run.completed[agent], run.first[agent + 1]):
            self.remaining[self.step[b]] += 1
        if a >= 0:
            self.barrier = min(self.barrier, self.step[a])
        return ()

    def round(self) -> List[int]:
        """One plan step: the lowest step some robot has not been sent yet."""
        run = self._attached()
        nxt = [run.next_undispatched(r) for r in range(run.num_agents)]
        pending = [self.step[a] for r, a in enumerate(nxt) if a >= 0 and run.active(r)]
        if not pending:
            return list(run.dispatched)
        t = min(pending)
        return [bisect_right(self.step, t, run.first[r] + run.dispatched[r], run.first[r + 1]) - run.first[r]
                for r in range(run.num_agents)]

    def _advance(self) -> List[int]:
        """Move the barrier past empty steps; the robots of the new barrier step."""
        end = len(self.remaining)
        t = self.barrier
        while t < end and self.remaining[t] == 0:
            t += 1
        self.barrier = t
        return self._agents_at(t) if t < end else []

    def _agents_at(self, t: int) -> List[int]:
        run = self._attached()
        if self.step is run.step:
            return run.agents_at_step(t)
        if self._by_step is None:
            self._by_step = [[] for _ in range(len(self.remaining))]
            for r in range(run.num_agents):
                for a in range(run.first[r], run.first[r + 1]):
                    if not self._by_step[self.step[a]] or self._by_step[self.step[a]][-1] != r:
                        self._by_step[self.step[a]].append(r)
        return self._by_step[t] if 0 <= t < len(self._by_step) else []

    def _action_at(self, agent: int, t: int) -> int:
        run = self._attached()
        lo, hi = run.first[agent], run.first[agent + 1]
        return bisect_right(self.step, t, lo, hi) - 1


def effective_steps(run: RunState) -> List[int]:
    """Per action, its plan step raised to the effective step of every incomplete move it waits
    for (its robot's previous move, the move out of the cell it enters), in a topological order
    of the incomplete moves; completed moves keep their plan step."""
    step = list(run.step)
    first, agent, dep, done = run.first, run.agent, run.dep, run.done
    waiting_on = [0] * len(step)
    after: List[List[int]] = [[] for _ in step]
    for a in range(len(step)):
        if done[a]:
            continue
        if a > first[agent[a]] and not done[a - 1]:
            waiting_on[a] += 1
            after[a - 1].append(a)
        d = dep[a]
        if d >= 0 and not done[d] and agent[d] != agent[a]:
            waiting_on[a] += 1
            after[d].append(a)
    ready = [a for a in range(len(step)) if not done[a] and waiting_on[a] == 0]
    while ready:
        a = ready.pop()
        for b in after[a]:
            if step[b] < step[a]:
                step[b] = step[a]
            waiting_on[b] -= 1
            if waiting_on[b] == 0:
                ready.append(b)
    return step
