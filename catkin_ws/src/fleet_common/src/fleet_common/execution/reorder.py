"""Re-ordering: a robot that is ready passes one that is late, where no cycle of waits follows.

The ADG keeps the plan's order of robots at every cell. When the robot that
should pass a cell first is late, every robot behind it waits, down the
chain, though most of those waits are not forced: the late robot has not even
set off towards the cell. This strategy changes the order online, as delays
happen, in the spirit of BTPG (Su et al., AAAI-24: "whoever comes first
passes" on pairs whose order may switch), decided per pair when a robot is
ready, with a cycle check instead of a precomputed set of switchable pairs.

Theory of operation. Each cell's visits form a chain in the dependency graph:
visit o, then p, then q, ... with edges leave(o) -> enter(p) and
leave(p) -> enter(q) (`adg`). Robot Q is ready to enter cell c and waits for
robot P, the visit before it, which has not been sent its move into c. Q
*passes* P when

1. P is late: it has at least `gap` moves still to make before its move into
   c (or it is out: disabled or failed), and has never been sent that move
   (`sent`, not `dispatched`: a robot taken out may still begin a move it was
   sent, so a move once sent is never overtaken);
2. Q will not stay in c: Q's visit is not its last (it has a move out of c),
   and that move's own dependency is already met, so Q passes through;
3. passing closes no cycle: after the swap P's move into c waits for Q's
   move out of it, so there is a cycle exactly when Q's move out depends,
   through the new graph, on P's move into c. `_closes_cycle` searches
   backwards from Q's move out over incomplete actions (a robot's reached
   actions are a range, so each is looked at once); when the search exceeds
   `budget` actions the pass is refused, which is always safe.

The swap rewires three edges, leaving the chain o, q, p, ... Each action keeps
at most one predecessor and one successor at a cell (`RunState.dep`/`succ`),
so the engine's O(1) rules are unchanged, and every strategy after this one
sees a graph that is acyclic.

Why it stays safe, whatever the delays: the engine still starts a move into a
cell only once the previous visitor's move out of it has completed (or, for
robots of their real size, has been dispatched, with the follower held at the
safe distance from the leader's reported position). The swap changes who the
previous visitor is, never the rule, and it only ever touches moves nobody
has been sent: P is not in c nor moving into it (its move in was never sent),
so Q entering c cannot meet it there; P will enter only behind Q, by the same
rule. A stale or lost pose changes nothing here: the decision reads only the
engine's record of what was sent and completed, and a follower's hold point
is computed from the last report, which is never ahead of the leader.
Why no deadlock: every run of the engine is deadlock-free on an acyclic graph
(each chain of waits ends at an action whose dependencies are met), and a
swap is made only when the search shows it closes no cycle; a budget
exceeded refuses the swap, keeping the graph as it was.
"""
from __future__ import annotations

from typing import Dict, List, NamedTuple, Optional, Sequence, Set, Tuple

from .errors import UnknownStrategyError
from .run import RunState
from .strategy import Strategy, register


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
            if ep < first[p]:
                return False  # p starts the plan in the cell: it is there
            k = ep - first[p]
            stands = False
            if k < run.sent[p]:
                if run.started[p] > k or k >= run.dispatched[p] or run.out[p] is not None or standing >= 0:
                    return False  # p was sent its move into the cell and may be on its way
                stands = True  # p stands still with it: passed only if it gives it back
            if run.out[p] is None and not self._late(run, p, k, stands):
                return False  # p is on time, or so near that it would wait for q
            lo = dep[ep]
            if not (lo < 0 or agent[lo] == q or run.released(lo)):
                return False  # whoever is before p in the cell is still there
            if stands:
                standing = len(swaps)
            swaps.append((e, ep, p, k))
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

    def _late(self, run: RunState, p: int, k: int, standing: bool) -> bool:
        """Is robot p, whose move k enters the cell, behind the plan by `gap` steps or more, and
        at least a move from starting it (so that q is through before it comes)?"""
        clock = run.clock
        now = clock.steps(run.now)
        done = run.completed[p]
        ahead = k - done - (1 if run.started[p] > done else 0)  # its current move may end now
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
