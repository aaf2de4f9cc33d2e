"""The rest of a run predicted: the earliest plan step at which each incomplete move can start.

From one moment of a run, every incomplete move of every robot is given the
earliest step (counted from that moment) at which it can start, as soon as
possible: moves take one step, a robot's moves go in order, and each cell keeps
its current order of robots (`RunState.dep`, re-orderings included). A move
into a cell starts no earlier than the previous visitor's move out of it
starts (robots of real size follow, in the same step) or completes (robots as
large as a cell). That is a longest path through the dependency graph, like
`step.effective_steps`, taken over the incomplete moves only.

What is known of the moment enters as `ready`: the earliest start of each
robot's next move. A robot that was sent its move and has not begun it is
standing still (a delay, a stall before the move): it is expected to stand
as long again as it already has (`ready_steps`), the one guess the rule of
`reroute` makes about the future. Robots that are out (disabled, failed) move
after everybody else: their moves, and the moves waiting for them, are
pushed behind the last move of everyone else, so that every schedule is
finite and can be written as a plan.

Pure and linear in the incomplete moves: each is placed once, when the moves
it depends on are placed (a robot waits in `blocked` on the one move that
holds it).
"""
from __future__ import annotations

from typing import Dict, List, Mapping, Optional, Sequence

from .run import RunState

#: The start of moves that wait for a robot that is out, before they are placed behind the rest.
LATER = 1 << 40


def ready_steps(run: RunState, now: float) -> List[int]:
    """Per robot, the earliest step its next move can start: 0, or for a robot sent a move it has
    not begun, as many steps again as it has stood with it, or for one whose begun move overran
    (`RunState.overran`), as many steps again as it overran; LATER for robots out."""
    clock, out = run.clock, []
    steps = clock.steps(now)
    for r in range(run.num_agents):
        if run.out[r] is not None:
            out.append(LATER)
        elif run.dispatched[r] > run.completed[r] and run.started[r] <= run.completed[r]:
            out.append(max(0, int(round(steps - clock.steps(run.dispatched_at[r])))))
        elif run.started[r] > run.completed[r]:
            out.append(int(round(run.overran(r, now))))
        else:
            out.append(0)
    return out


class Schedule:
    """Predicted start step (from the moment of the cut) of each incomplete move, and arrivals."""

    __slots__ = ("start", "arrival", "later")

    def __init__(self, start: Dict[int, int], arrival: List[int], later: int) -> None:
        #: flat action -> step it starts (the moves this schedule placed)
        self.start = start
        #: per robot, the step its last move completes (0: nothing left, or not placed)
        self.arrival = arrival
        #: the step behind everybody else from which robots out move (0 if none is out)
        self.later = later

    @property
    def makespan(self) -> int:
        return max(self.arrival, default=0)


def earliest_starts(run: RunState, ready: Sequence[int], follow: bool, base: Sequence[int],
                    robots: Optional[Sequence[int]] = None, dep: Optional[Sequence[int]] = None,
                    released: Optional[Mapping[int, int]] = None) -> Schedule:
    """The as-soon-as-possible schedule of `robots`' moves from `base[r]` on (default: every
    robot's; `cut.Cut.base`: the moves not completed, and the moves a follower completed into a
    cell its leader has not completed leaving, which are made again in the leader's step).

    `ready[r]` holds robot r's first move not completed; `dep` replaces the run's dependencies
    (`reroute` takes robots out of cells' orders); `released[d]` is the step at which move d, not
    placed here, releases the move waiting for it. A dependency on a move before its robot's
    base, or on the robot's own move, holds nothing.
    """
    first, agent, completed = run.first, run.agent, run.completed
    dep = run.dep if dep is None else dep
    released = {} if released is None else released
    lag = 0 if follow else 1
    start: Dict[int, int] = {}
    robots = range(run.num_agents) if robots is None else robots
    nxt = {r: first[r] + base[r] for r in robots}
    free = {r: 0 for r in robots}  # the earliest step r's next move may start
    blocked: Dict[int, List[int]] = {}  # move not placed yet -> robots whose next move waits for it
    todo = [r for r in robots]
    while todo:
        r = todo.pop()
        a, end, t = nxt[r], first[r + 1], free[r]
        if a == first[r] + completed[r] and ready[r] > t:
            t = ready[r]
        while a < end:
            d = dep[a]
            if d >= 0 and agent[d] != r and d >= first[agent[d]] + base[agent[d]]:
                s = start.get(d)
                if s is None:
                    s = released.get(d)
                    if s is None:
                        blocked.setdefault(d, []).append(r)
                        break
                    s -= lag  # a release is when the next visitor may go
                if s + lag > t:
                    t = s + lag
            start[a] = t
            waiting = blocked.pop(a, None)
            if waiting:
                todo.extend(waiting)
            t += 1
            a += 1
            if a == first[r] + completed[r] and ready[r] > t:
                t = ready[r]
        nxt[r], free[r] = a, t
    arrival = [0] * run.num_agents
    for r in robots:
        if nxt[r] > first[r] + base[r]:
            arrival[r] = free[r]
    later = 0
    if any(s >= LATER for s in start.values()):
        later = max((s for s in start.values() if s < LATER), default=-1) + 2
        for a, s in start.items():
            if s >= LATER:
                start[a] = s - LATER + later
        for r in robots:
            if arrival[r] >= LATER:
                arrival[r] = arrival[r] - LATER + later
    return Schedule(start, arrival, later)


def unplaced(run: RunState, schedule: Schedule, base: Sequence[int], robots: Sequence[int]) -> List[int]:
    """Robots among `robots` with a move the schedule could not place (it waits for a move nobody
    placed or released: a caller's mistake)."""
    return [r for r in robots if base[r] < run.count(r) and run.first[r + 1] - 1 not in schedule.start]
