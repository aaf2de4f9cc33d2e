"""Re-ordering: a robot that is ready passes late ones, where no cycle of waits follows.

The ADG keeps the plan's order of robots at every cell. When the robot due
first at a cell is late, every robot behind it waits, down the chain, though
some of those waits are not forced: the late robot has not even set off into
the cell. This strategy changes the order online, as delays happen, in the
spirit of BTPG (Su et al., AAAI-24: "whoever comes first passes" on pairs
whose order may switch), decided when a robot is ready, with a check on the
graph itself instead of a precomputed set of switchable pairs.

Theory of operation. Each cell's visits form a chain in the dependency graph:
visit o, then p, then q, ... with edges leave(o) -> enter(p) and
leave(p) -> enter(q) (`adg`; a robot's own consecutive visits are linked
too, so the chain is never broken). Robot Q is ready for its next move and
waits for robot P's move out of the cell it needs. Q looks along its next
cells (at most `reach`): it *passes* P there, and the robots ahead of it in
the cells after, when at every one of them

1. the robot ahead (P) has not set off into the cell: it was never sent its
   move in (`sent`, not `dispatched`: a robot taken out may still begin a
   move it was sent), or it was sent the move, has not begun it, and the
   caller takes it back (`RunState.take_back`: the manager, if it has not
   handed the drive over; the simulator, if the robot stands still); and it
   does not stand halfway into the cell, stopped there by a fault
   (`RunState.halfway`: the engine forgets the move sent, and a plan handed
   over from a cut knows it only as not sent);
2. P is late: behind the plan's clock (`RunState.clock`, running time in plan
   steps) by `gap` steps or more, at least one move from the cell (so Q is
   through before P comes), or out (disabled, failed). A move P has begun
   may end now, unless it overran its step by `OVERDUE` with its way clear
   (`RunState.overran`: P stands or crawls inside it). The manager counts a
   drive begun once the robot accepts it, so a robot held up inside its drive
   looks begun; without the overrun count the real chain never passed it where
   the simulator, whose delays come before a move begins, did. Judging
   lateness wrongly costs time, never safety: a P that comes sooner waits
   behind Q;
3. the robot before P in the cell has left it (Q can go now), and the cell is
   not Q's goal (Q would stay);

and the cell after the last passed one is free for Q now (its previous
visitor's move out released): Q goes through without stopping. Each pass
swaps two visits of the chain (o, p, q, s becomes o, q, p, s: three edges
rewired, `_swap`), so each action keeps one predecessor and one successor at
a cell, and the engine's O(1) rules are unchanged.

Why it is safe, whatever the delays: the engine still starts a move into a
cell only once the previous visitor's move out of it has completed (or, for
robots of their real size, has been dispatched, the follower held at the safe
distance from the leader's reported position). A pass changes who the
previous visitor is, never the rule, and touches only moves no robot is on:
P is not in the cell nor moving into it (its move in was never sent, or was
taken back before it began), so Q entering cannot meet it there; P will
enter behind Q, by the same rule. A stale or lost pose changes nothing here:
the decision reads only the engine's record of what was sent, begun and
completed, and a follower's hold point comes from the last report, which is
never ahead of the leader.

Why no deadlock: the engine cannot deadlock on an acyclic graph (each chain
of waits ends at a move whose dependencies are met), and after the swaps
every new edge (Q's move out of a cell -> P's move in) is checked
(`_closes_cycle`): a search backwards from Q's move out over the moves not
yet dispatched (a dispatched move waits only for dispatched or completed
ones, as a move with a robot following it is never taken back) for P's move
in. Because Q's way is free at the time, the only cycles possible are
through a move that is taken back in the same pass (P standing in the cell Q
goes to next, heading for Q's cell: head-on); the search finds those. A
search that exceeds `budget` moves refuses the pass, which is always safe.
Any pass refused leaves the graph as it was.
"""
from __future__ import annotations

from typing import Dict, List, NamedTuple, Optional, Sequence, Set, Tuple

from .errors import UnknownStrategyError
from .run import RunState
from .strategy import Strategy, register


#: Plan steps a begun move may overrun (`RunState.overran`) and still count as ending now.
OVERDUE = 1.0


class Pass(NamedTuple):
    """Robot `agent` goes into cell `cell` (a cell index of the action table) before robot
    `passed`; `action` is the passing robot's move into the cell, `passed_action` the other's."""

    agent: int
    passed: int
    cell: int
    action: int
    passed_action: int
    #: The passed robot had been sent its move into the cell and gave it back (it stood still).
    taken_back: bool = False


@register
class ReorderStrategy(Strategy):
    """The ADG, with a ready robot passing late ones on its way when that closes no cycle."""

    name = "reorder"
    summary = "ADG whose order at a cell may change: a ready robot passes a late one, never into a cycle"
    SETTINGS = ("gap", "reach", "budget")
    reorders = True
    tick_every = 0.5  # a robot that stands still becomes passable as time passes

    def __init__(self, gap: int = 1, reach: int = 4, budget: int = 400) -> None:
        super().__init__()
        for key, value in (("gap", gap), ("reach", reach), ("budget", budget)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise UnknownStrategyError("reorder {} must be a whole number >= 1, got {!r}".format(
                    key, value))
        self.gap = gap
        self.reach = reach
        self.budget = budget
        #: Passes refused because the cycle search ran out of budget (a figure for the bench).
        self.over_budget = 0
        self.cycles = 0

    def overtake(self, eq: int) -> bool:
        """Robot q of action `eq` is ready and `eq` waits for a move out of its cell that is not
        released: if every robot ahead of q on its next cells (up to `reach`) is late, and the cell
        after them is free, q passes them all. True when `eq`'s dependency is met now."""
        run = self._attached()
        agent, first, dep = run.agent, run.first, run.dep
        q = agent[eq]
        end = first[q + 1]
        swaps: List[Tuple[int, int, int, int]] = []  # (q's move in, p's move in, p, p's index)
        cells: Set[int] = set()
        standing = -1
        e = eq
        while True:
            d = dep[e]
            if e > eq and (d < 0 or agent[d] == q or run.released(d)):
                break  # the cell after the passed ones is free: q goes through
            if len(swaps) == self.reach or e + 1 >= end or run.dst[e] in cells:
                return False  # too far, or q would stay in the cell (its goal), or loops back
            cells.add(run.dst[e])
            ep = d - 1
            p = agent[d]
            stands = self._passable(run, q, ep)
            if stands is None or stands and standing >= 0:
                return False
            if stands:
                standing = len(swaps)
            swaps.append((e, ep, p, ep - first[p]))
            e += 1
        undo = [self._swap(run, e, ep) for e, ep, _, _ in swaps]
        for e, ep, _, _ in swaps:
            cycle = self._closes_cycle(run, e + 1, ep)
            if cycle is not False:  # never, by the argument of the module docstring; budget
                if cycle is None:
                    self.over_budget += 1
                else:
                    self.cycles += 1
                self._undo(undo)
                return False
        if standing >= 0 and not run.take_back(swaps[standing][2], swaps[standing][3]):
            self._undo(undo)
            return False
        for j, (e, ep, p, _) in enumerate(swaps):
            run.passes.append(Pass(q, p, run.dst[e], e, ep, j == standing))
        return True

    def on_completed(self, a: int) -> Sequence[int]:
        """A robot left a cell: robots behind the next visitor, if that one is late, may pass."""
        run = self.run
        e = run.succ[a]  # type: ignore[union-attr]
        if e < 0:
            return ()
        return self._behind(run, e)  # type: ignore[arg-type]

    def on_tick(self) -> Sequence[int]:
        """Robots ready and waiting for a cell whose previous visitor has not moved out: as the
        plan's clock runs, the one they wait for may now count as late."""
        run = self._attached()
        first, dep, agent, out = run.first, run.dep, run.agent, []
        for r in range(run.num_agents):
            k = run.completed[r]
            if run.out[r] is not None or run.dispatched[r] != k or first[r] + k >= first[r + 1]:
                continue
            d = dep[first[r] + k]
            if d >= 0 and agent[d] != r and not run.released(d):
                out.append(r)
        return out

    def on_out(self, agent: int) -> Sequence[int]:
        """Robots queued behind an out robot's next cell may pass it."""
        run = self._attached()
        e = run.next_undispatched(agent)
        return self._behind(run, e) if e >= 0 else ()

    # ---- the pass --------------------------------------------------------------------------
    def _behind(self, run: RunState, e: int) -> List[int]:
        """Up to two robots queued at the cell `e` enters behind `e`'s robot, if that one was not
        sent its move in yet (it may be passed)."""
        out: List[int] = []
        for _ in range(2):
            p = run.agent[e]
            if e - run.first[p] < run.sent[p] or e + 1 >= run.first[p + 1]:
                break
            e = run.succ[e + 1]
            if e < 0:
                break
            out.append(run.agent[e])
        return out

    @staticmethod
    def _undo(undo: List[List[Tuple[List[int], int, int]]]) -> None:
        for slots in reversed(undo):
            for array, index, value in reversed(slots):
                array[index] = value

    @staticmethod
    def _swap(run: RunState, eq: int, ep: int) -> List[Tuple[List[int], int, int]]:
        """Cell order o, p, q, s becomes o, q, p, s (eq, ep: q's and p's moves into the cell);
        the slots written, with their old values."""
        dep, succ = run.dep, run.succ
        lp, lq = ep + 1, eq + 1
        lo, es = dep[ep], succ[lq]
        old = [(dep, eq, dep[eq]), (dep, ep, dep[ep]), (succ, lq, succ[lq]), (succ, lp, succ[lp])]
        if lo >= 0:
            old.append((succ, lo, succ[lo]))
        if es >= 0:
            old.append((dep, es, dep[es]))
        dep[eq] = lo
        if lo >= 0:
            succ[lo] = eq
        dep[ep] = lq
        succ[lq] = ep
        succ[lp] = es
        if es >= 0:
            dep[es] = lp
        return old

    def _passable(self, run: RunState, q: int, ep: int) -> Optional[bool]:
        """May robot q go into the cell before the robot whose move into it is `ep`? None: no;
        False: yes; True: yes, if that robot gives back the move, which it was sent and has not
        begun (it stands still)."""
        p = run.agent[ep + 1]
        first = run.first[p]
        if ep < first:
            return None  # p starts the plan in the cell: it is there
        k = ep - first
        if run.halfway[p] and k == run.completed[p]:
            return None  # p failed on its way into the cell: it stands partly in it
        stands = False
        if k < run.sent[p]:
            if run.started[p] > k or k >= run.dispatched[p] or run.out[p] is not None:
                return None  # p was sent its move into the cell and may be on its way
            stands = True
        if run.out[p] is None and not self._late(run, p, k, stands):
            return None  # p is on time, or so near that it would wait for q
        lo = run.dep[ep]
        if not (lo < 0 or run.agent[lo] == q or run.released(lo)):
            return None  # whoever is before p in the cell is still there
        return stands

    def _late(self, run: RunState, p: int, k: int, standing: bool) -> bool:
        """Is robot p, whose move k enters the cell, behind the plan by `gap` steps or more, and
        at least a move from starting it (so that q is through before it comes)?"""
        clock = run.clock
        now = clock.steps(run.now)
        done = run.completed[p]
        ahead = k - done
        if run.started[p] > done and run.overran(p, run.now) < OVERDUE:
            ahead -= 1  # its current move may end now
        if standing and now - clock.steps(run.dispatched_at[p]) >= 1.0:
            ahead += 1  # it has stood still a whole move already: count on one more
        return ahead >= 1 and now + ahead - run.step[run.first[p] + k] >= self.gap

    def _closes_cycle(self, run: RunState, lq: int, ep: int) -> Optional[bool]:
        """Does `lq` wait for `ep`, through the graph (None: the search went over budget)?

        Backwards from `lq` over moves not dispatched (a dispatched move waits for nothing that
        is not dispatched, so nothing behind it can be `ep`); a robot's moves reached form a
        range, so each is looked at once."""
        agent, first, dispatched, dep = run.agent, run.first, run.dispatched, run.dep
        p = agent[ep]
        reached: Dict[int, int] = {}
        stack = [lq]
        budget = self.budget
        while stack:
            y = stack.pop()
            r = agent[y]
            if r == p and y >= ep:
                return True
            top = reached.get(r)
            low = first[r] + dispatched[r] if top is None else top + 1
            if y < low:
                continue
            reached[r] = y
            budget -= y - low + 1
            if budget < 0:
                return None
            for z in range(low, y + 1):
                d = dep[z]
                if d >= 0:
                    stack.append(d)
        return False


def replay(run: RunState, passes: Sequence[Tuple[int, int, int, int]]) -> List[Pass]:
    """Make again, in order, passes made in an earlier life of this run (a manager resumed on
    its folder): (robot, its action index, robot passed, that one's action index), each the
    moves into the cell. Raises ValueError, changing nothing, when one does not fit the graph."""
    dep, first, count = list(run.dep), run.first, len(run.dep)
    succ = list(run.succ)
    made: List[Pass] = []
    for agent, k, passed, j in passes:
        if not (0 <= agent < run.num_agents and 0 <= passed < run.num_agents):
            raise ValueError("a pass names robots not in this plan: {} and {}".format(agent, passed))
        eq, ep = first[agent] + k, first[passed] + j
        if not (first[agent] <= eq < first[agent + 1] - 1 and first[passed] <= ep < first[passed + 1] - 1
                and eq < count and dep[eq] == ep + 1):
            raise ValueError("agent {}'s action {} was not next after agent {}'s action {} at a cell".format(
                agent, k, passed, j))
        view = _Chains(dep, succ)
        ReorderStrategy._swap(view, eq, ep)  # type: ignore[arg-type]
        made.append(Pass(agent, passed, run.dst[eq], eq, ep))
    run.dep[:], run.succ[:] = dep, succ
    run.passes.extend(made)
    return made


class _Chains(NamedTuple):
    dep: List[int]
    succ: List[int]
