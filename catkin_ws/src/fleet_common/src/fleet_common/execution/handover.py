"""Handing a running engine over to a reroute's new plan, without stopping anyone.

The new plan starts at the reroute's cut: each robot's moves in it are its
moves still to make then, the first of them the ones it had been sent
(`reroute_plan`). By the time the plan is ready the run may have gone on
(the manager plans in a worker thread): the robots that keep their paths
have made the same moves in both plans, and a rerouted robot may have begun
or completed the moves it had been sent at the cut, the first moves of its
new path, so everyone's progress carries over one to one; a rerouted robot
sent a move since or that gave one back, or a robot that went out or came
back, makes the plan stale (`Cut.moved`), and the hand-over is refused
(`HandoverError`), changing nothing.

The new engine (`Engine.adopt`) runs the same strategy with the same
settings and the same metrics, and refuses a plan in which a move already
made or sent would wait for one that is not (a robot sent, in the new plan,
into a cell another is in or driving into): the safety of the hand-over,
checked.
(One such wait is the run's own: a follower sent behind a leader that went
out since and took its move back keeps following that move, held behind the
leader's real pose, as it was in the old engine.)
"""
from __future__ import annotations

from typing import List, Sequence, Tuple

from ..errors import FleetError
from .cut import cut_of
from .engine import Engine
from .errors import EventError
from .events import Dispatch
from .reroute import Reroute


class HandoverError(FleetError):
    """A reroute's plan that no longer fits the run (robots moved since its cut)."""


def hand_over(engine: Engine, reroute: Reroute, now: float) -> Tuple[Engine, List[Dispatch]]:
    """The engine of `reroute.plan`, going on with `engine`'s run at `now`, and its decisions now."""
    cut, here = reroute.cut, cut_of(engine, now)
    moved = here.moved(cut, reroute.agents)
    if moved:
        raise HandoverError("robot{} {} moved since the reroute was planned".format(
            "s" if len(moved) > 1 else "", ", ".join(map(str, moved))))
    changed = [r for r in range(cut.num_agents) if here.out[r] != cut.out[r]]
    if changed:
        raise HandoverError("robot{} {} went out or came back since the reroute was planned".format(
            "s" if len(changed) > 1 else "", ", ".join(map(str, changed))))
    progress = [(here.completed[r] - cut.base[r], here.committed[r], here.started[r])
                for r in range(cut.num_agents)]
    strategy = engine.strategy
    new = Engine(reroute.plan, strategy.name, show=engine.show, follow=engine.follow,
                 step_time=engine.run.clock.step_time,
                 **strategy.settings())
    released_by = {w.agent: w.on[0] for w in engine.waiting() if w.on}
    try:
        dispatches = new.adopt(engine, progress, now, released_by)
    except EventError as err:
        raise HandoverError(str(err)) from None
    return new, dispatches


def renumbered(new: Engine, base: Sequence[int], d: Dispatch) -> Dispatch:
    """`d`, a move of the old plan sent (or queued) before the hand-over to `new`, numbered as in
    the new plan (which starts robot r with the old plan's move `base[r]`), with its leader there."""
    run = new.run
    k = d.index - base[d.agent]
    a = run.first[d.agent] + k
    lead = new.early.get(a)
    return d._replace(index=k, step=run.step[a], follows=None if lead is None else (
        run.agent[lead], lead - run.first[run.agent[lead]]))
