"""The Action Dependency Graph (Hönig, Kiesel, Tinka, Durham, Ayanian, RA-L 2019).

A MAPF plan is collision-free only while every robot keeps its time steps.
The ADG keeps what matters of the timing and drops the rest: the *order* in
which robots pass through each cell. Its nodes are the actions (moves) of
`actions.ActionTable`; its edges say "finish this before starting that":

- type 1: a robot's actions in order (action k before action k + 1);
- type 2: where robot i leaves cell c and robot j enters c later in the plan,
  j's entering move waits until i's leaving move has *completed*.

A robot occupies both cells of the move it is making, so a type-2 edge means
that j starts moving into c only after i is wholly out of it: each cell has
at most one robot in it or moving in or out of it at any time, whatever the
delays (no vertex collision, and no swap, which needs two robots in two cells
at once). The same rule settles *following moves* (j enters c in the very
step i leaves it): j starts once i's move is complete.

Worked example (base frame, y up):

    y=1   .  .  E  .        robot 0: A B C D D     (t = 0..4)
    y=0   A  B  C  D        robot 1: E E E C B

    actions   robot 0: a0 = A->B (step 0), a1 = B->C (step 1), a2 = C->D (step 2)
              robot 1: b0 = E->C (step 2), b1 = C->B (step 3)
    visits    B: robot 0 [t 1..1] then robot 1 [t 4..]  => type 2: a1 -> b1
              C: robot 0 [t 2..2] then robot 1 [t 3..3]  => type 2: a2 -> b0
    type 1    a0 -> a1 -> a2,  b0 -> b1

b0 is a following move (robot 1 enters C in the step robot 0 leaves it): it
may start only once a2 has completed. If robot 0 is delayed, robot 1 waits at
E instead of bumping into it; if robot 0 is early, robot 1 can start early too,
without waiting for a global clock. a1 -> b1 is implied by a1 -> a2 -> b0 -> b1
and costs nothing to keep.

Built without comparing pairs of robots: every visit of a robot to a cell is
one record (its start cell, and the cell each action enters), the records are
sorted by (cell, arrival step), and each consecutive pair at a cell gives one
type-2 edge, from the earlier visit's leaving action to the later one's
entering action (between two visits of one robot the edge repeats what type 1
says; it is kept so that each cell's visits form one chain, which `reorder`
edits, and the engine ignores it). Edges to non-consecutive visits follow by
transitivity, so each action has at most one type-2 predecessor (`dep`) and one
successor (`succ`): O(A log A) for A actions, a few numpy calls.

Plan errors are found on the way. Two visits that overlap in time are a vertex
conflict. Type-1 edges go strictly forward in plan steps and type-2 edges never
backwards, so a cycle can only join actions of one step through type-2 edges:
a swap (2 robots) or a rotation (3 or more robots each entering the cell the
next one leaves). mapf-IR allows rotations, but robots that occupy both cells
while moving cannot perform one, so either is a `PlanError`. As each action has
at most one type-2 predecessor, those cycles are found by pointer doubling,
by the validator's own cycle finder (`fleet_common.rotations`).
"""
from __future__ import annotations

from typing import Callable, List

import numpy as np

from ..grid import Coord
from ..rotations import cycles
from .actions import ActionTable
from .errors import ROTATION, SWAP, VERTEX, PlanError


def _identity(c: Coord) -> Coord:
    return c


class ActionDependencyGraph:
    """Type-2 edges as arrays over the flat action index; type-1 edges are implicit."""

    __slots__ = ("table", "dep", "succ")

    def __init__(self, table: ActionTable, dep: np.ndarray, succ: np.ndarray) -> None:
        self.table = table
        #: dep[a]: the other robot's action that must complete before a starts, or -1.
        self.dep = dep
        #: succ[a]: the action that waits for a (dep[succ[a]] == a), or -1.
        self.succ = succ

    def type1_edges(self) -> np.ndarray:
        """(E, 2) array of (before, after) pairs along each robot's actions."""
        a = np.arange(1, self.table.num_actions)
        same = self.table.agent[a] == self.table.agent[a - 1]
        return np.stack([a[same] - 1, a[same]], axis=1)

    def type2_edges(self) -> np.ndarray:
        """(E, 2) array of (leaving action, entering action) pairs between robots."""
        agent = self.table.agent
        after = np.nonzero((self.dep >= 0) & (agent[np.maximum(self.dep, 0)] != agent))[0]
        return np.stack([self.dep[after], after], axis=1)

    def predecessors(self, a: int) -> List[int]:
        """Every action that must complete before action `a` may start."""
        out = []
        if a > 0 and self.table.agent[a - 1] == self.table.agent[a]:
            out.append(a - 1)
        if self.dep[a] >= 0:
            out.append(int(self.dep[a]))
        return out

    @property
    def num_following(self) -> int:
        """Type-2 edges within one plan step: following moves."""
        has = self.dep >= 0  # a robot's own visits are never in one step
        return int(np.count_nonzero(self.table.step[self.dep[has]] == self.table.step[has]))


def build_adg(table: ActionTable, show: Callable[[Coord], Coord] = _identity) -> ActionDependencyGraph:
    """The ADG of `table`; a vertex conflict, swap or rotation raises `PlanError`.

    `show` turns base cells into the coordinates messages should use.
    """
    n, count = table.num_agents, table.num_actions
    first, agent, step = table.first, table.agent, table.step
    dep = np.full(count, -1, dtype=np.int64)
    succ = np.full(count, -1, dtype=np.int64)
    if n < 2:
        return ActionDependencyGraph(table, dep, succ)
    acts = np.arange(count, dtype=np.int64)
    has_moves = first[1:] > first[:-1]
    last_of_agent = first[agent + 1] - 1
    # one visit per start cell and per action (the cell it enters)
    v_agent = np.concatenate([np.arange(n, dtype=np.int64), agent])
    v_cell = np.concatenate([table.start_cell, table.dst])
    v_begin = np.concatenate([np.zeros(n, dtype=np.int64), step + 1])
    v_enter = np.concatenate([np.full(n, -1, dtype=np.int64), acts])
    v_leave = np.concatenate([np.where(has_moves, first[:-1], -1), np.where(acts < last_of_agent, acts + 1, -1)])
    order = np.argsort(v_cell * (table.makespan + 2) + v_begin, kind="stable")
    cell_o = v_cell[order]
    # consecutive visits by one robot are linked too (a type-1 path already orders them): each
    # cell's visits then form one chain through dep/succ, which a re-ordering strategy edits
    pair = np.nonzero(cell_o[1:] == cell_o[:-1])[0]
    p, q = order[pair], order[pair + 1]  # p's visit, then q's visit to the same cell
    leave, enter = v_leave[p], v_enter[q]
    # q arrives (at v_begin[q]) while p is still there: p never leaves, or leaves later
    padded = np.append(step, 0)  # index -1 (no such action) reads the pad
    clash = (leave < 0) | (enter < 0) | (padded[leave] > padded[enter])
    if clash.any():
        _raise_vertex(table, p[clash], q[clash], v_agent, v_cell, v_begin, show)
    dep[enter] = leave
    succ[leave] = enter
    _check_cycles(table, dep, show)
    return ActionDependencyGraph(table, dep, succ)


def _raise_vertex(table: ActionTable, p: np.ndarray, q: np.ndarray, v_agent: np.ndarray,
                  v_cell: np.ndarray, v_begin: np.ndarray, show: Callable[[Coord], Coord]) -> None:
    k = int(np.argmin(v_begin[q]))  # the earliest clash
    i, j, t = int(v_agent[p[k]]), int(v_agent[q[k]]), int(v_begin[q[k]])
    cell = table.coord(v_cell[q[k]])
    raise PlanError("vertex conflict at t={}: agents {} and {} both at {}".format(
        t, min(i, j), max(i, j), show(cell)), VERTEX, t, (min(i, j), max(i, j)), (cell,))


def _check_cycles(table: ActionTable, dep: np.ndarray, show: Callable[[Coord], Coord]) -> None:
    step = table.step
    # same-step type-2 edges are following moves: a follows dep[a]; their cycles are swaps and
    # rotations, found as the validator finds them (fleet_common.rotations)
    links = np.where((dep >= 0) & (step[np.maximum(dep, 0)] == step), dep, -1)
    found = cycles(links, table.num_agents, limit=1)
    if not found:
        return
    cycle = found[0].tolist()  # the one with the smallest action: the lowest robot's first
    t = int(step[cycle[0]])
    agents = [int(table.agent[a]) for a in cycle]
    cells = [table.coord(table.dst[a]) for a in cycle]
    if len(cycle) == 2:
        i, j = sorted(agents)
        raise PlanError("swap at t={}->{}: agents {} and {} exchange {} and {}".format(
            t, t + 1, i, j, show(cells[0]), show(cells[1])), SWAP, t, (i, j), cells)
    raise PlanError(
        "rotation at t={}->{}: agents {} each enter the cell the next one leaves ({}); real "
        "robots cannot do that, a robot occupies both cells until its move completes".format(
            t, t + 1, ", ".join(map(str, agents)), ", ".join(str(show(c)) for c in cells)),
        ROTATION, t, agents, cells)
