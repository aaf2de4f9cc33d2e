"""The cut of a running engine: where every robot is, and what it is committed to, at one moment.

A new plan for a run that goes on (`reroute`) starts from a cut. Per robot:
the moves of the run's plan it has completed, the moves it was sent and has
not completed (`committed`: they cannot be taken back, it may be driving one
already), whether it began the first of them, and whether it is out. Its
cell is where its last completed move took it; while it makes a move (or was
stopped in one by a fault) it holds that move's target cell too.

A plan has one robot in a cell at a step, a run of robots of real size not
always: a follower may complete its move into a cell before the robot it
follows has completed its move out. Such a follower counts as still making
that move (`base`: the move a new plan starts a robot with; the robot that
followed it into the cell it left, likewise): in a new plan it is that
robot's first move, done already, made in the step its leader leaves.

A caller that planned from one cut can tell, at hand-over time, whether the
robots it planned for have moved away from it since (`moved`): been sent a
move, given one back (a fault, a re-ordering's take-back), gone out or come
back. Beginning and completing the moves a robot had been sent at the cut is
not moving away: a plan from the cut starts the robot with those very moves,
so that progress carries over one to one (`moved_on`). A look that takes
some 200 ms at 300 robots spans some robot's completion nearly always;
counting that as moving away dropped every such look.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

from .engine import Engine


@dataclass(frozen=True)
class Cut:
    """Per robot: the move a new plan starts it with, moves completed, moves sent and not completed,
    the first of them begun, out."""

    time: float
    base: Tuple[int, ...]
    completed: Tuple[int, ...]
    committed: Tuple[int, ...]
    started: Tuple[bool, ...]
    out: Tuple[Optional[str], ...]

    @property
    def num_agents(self) -> int:
        return len(self.completed)

    def moved(self, other: "Cut", robots: Sequence[int]) -> List[int]:
        """Robots among `robots` that moved away from `other` (an earlier cut of the same run) by
        this one (`moved_on`), or went out or came back."""
        return [r for r in robots if self.out[r] != other.out[r]
                or moved_on(other, r, self.completed[r], self.committed[r], self.started[r])]


def moved_on(cut: Cut, r: int, completed: int, committed: int, started: bool) -> bool:
    """Whether robot r, with this progress now (moves completed, sent and not completed, the first
    of those begun), moved away from where a plan made from `cut` starts it: it was sent a move
    since, or gave one back. Beginning or completing the moves it had been sent then is not."""
    was_done, was_sent = cut.completed[r], cut.committed[r]
    if completed < was_done or completed + committed != was_done + was_sent:
        return True
    return completed == was_done and cut.started[r] and not started


def cut_of(engine: Engine, time: float) -> Cut:
    """The cut of `engine`'s run now."""
    run = engine.run
    n = run.num_agents
    return Cut(time, tuple(_bases(engine)), tuple(run.completed),
               tuple(run.dispatched[r] - run.completed[r] for r in range(n)),
               tuple(run.started[r] > run.completed[r] for r in range(n)), tuple(run.out))


def _bases(engine: Engine) -> List[int]:
    """Per robot, the first of its moves a new plan starts it with: its first move not completed,
    or an earlier one when that move went into a cell before the robot leaving it had completed
    leaving (following it), or behind such a robot; bases only go down, to a fixed point."""
    run = engine.run
    first, agent, succ = run.first, run.agent, run.succ
    base = list(run.completed)
    # (robot, from, to): its moves not done in the new plan whose cells' next visitors to check;
    # first the moves sent, and the next move of each robot (a fault takes back a move begun)
    todo = [(q, run.completed[q], min(max(run.dispatched[q], run.completed[q] + 1), run.count(q)))
            for q in range(run.num_agents)]
    while todo:
        q, lo, hi = todo.pop()
        for x in range(first[q] + lo, first[q] + hi):
            s = succ[x]  # the next visitor of the cell x leaves: did it come in before x was done?
            if s < 0:
                continue
            g = agent[s]
            k = s - first[g]
            if g != q and k < base[g]:
                todo.append((g, k, base[g]))
                base[g] = k
    return base


def behind_taken_back(engine: Engine, cut: Cut, sent: bool = False) -> List[int]:
    """Robots that completed a move (with `sent`: or were sent one) into a cell whose leaving
    robot then took its move out back (it went out; it may be back, not yet sent that move
    again): a move made again from the cut (`_bases`; or sent) that waits for a move not sent.

    No plan from the cut fits a robot that completed such a move (`Engine.adopt` refuses a move
    done that waits for a move not sent), so a reroute waits until that move is sent again.
    (Letting the plan keep the follower behind that move is not enough: a way on from there may
    pass where the other robot stands, halfway into the next cell; tests/test_execution_reroute.py
    has the run.) A robot sent such a move keeps its path: its move's time in a plan from the cut
    hangs on when the robot out moves again, which the plan cannot know (a reroute that gave it
    a new path put it into the cell while the robot out was still in it)."""
    run = engine.run
    out = []
    for r in range(run.num_agents):
        upto = run.dispatched[r] if sent else cut.completed[r]
        for a in range(run.first[r] + cut.base[r], run.first[r] + upto):
            d = run.dep[a]
            q = run.agent[d] if d >= 0 else r
            if q != r and d - run.first[q] >= run.dispatched[q]:
                out.append(r)
                break
    return out
