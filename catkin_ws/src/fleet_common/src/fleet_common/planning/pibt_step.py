"""One PIBT step: every agent's next cell, by priority inheritance with backtracking.

Theory of operation (Okumura et al., AIJ 2022). Agents pick their next cell in
priority order: the free candidate (a neighbour, or staying) closest to their
goal. An agent that wants the cell of a not-yet-planned agent lends it its
priority: that agent plans next and must move out. If it cannot, it
backtracks: it stays, and the asking agent tries its next candidate. No
search, so a step for hundreds of agents takes about a millisecond.

Plain PIBT deadlocks where two agents must pass each other in a corridor or a
dead end (each wants the other's cell, and swapping is a conflict). The swap
rule of LaCAM* (Okumura, IJCAI 2023) handles it: when the cell an agent wants
holds an agent going the other way and no side exit lets one step aside, the
first agent walks away from its goal and pulls the other one along, until a
branching cell lets them pass.

Rotations (3 or more agents each entering the cell the next one leaves) are
legal in mapf-IR but not for robots, which occupy both cells while moving;
unless `rotations` is set, a step makes none. An agent that takes the cell of
an unplanned agent makes it inherit at once, so the chain of agents moving
into each other's cells ending at the agent being planned is exactly the
inheritance stack, and a move closes a cycle exactly when it enters the cell
of an agent on the stack. Every such cell but the bottom agent's is already
claimed by the agent below it, so the one new check is "not the bottom
agent's cell": skipped like a swap, the agent tries its next candidate (O(1);
the highest-priority agent still gets the best move that is left). Cells
fixed in advance (LaCAM's constraints) can close a cycle outside the stack:
after such a step, any cycle is found (`fleet_common.rotations`) and its
agents stay. Each cell of a cycle is entered only by a cycle member, so
reverting the whole cycle is vertex-safe, and it leaves no new cycle.

Inheritance is an explicit stack, not recursion, so chains of thousands of
agents do not reach Python's recursion limit. `step` also accepts next cells
fixed in advance: LaCAM uses it as its configuration generator.

Cells are free-cell ids (`free_cells`); distances come from
`agent_distances` (complete lists, or rows searched lazily that each step
first makes exact around every agent's cell). An agent resting on its goal whose cell nobody claimed stays without a search
(staying is its unique best move), which is most agents late in a plan.
"""
from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..grid import Coord, Grid
from ..plan import Plan
from ..rotations import step_cycles
from .agent_distances import AgentDistances
from .cells import NIL
from .free_cells import FreeCells

try:  # the same step in C (setup builds it); robots and machines without a compiler use the Python below
    from ._native import PIBTCore as _Core
except ImportError:
    _Core = None

#: Is the C step built (and so used by default)?
NATIVE = _Core is not None


class PIBTStep:
    """Next configurations by PIBT, for one grid and one set of goals."""

    def __init__(self, grid: Grid, goals: Sequence[Coord], swap: bool = True, rotations: bool = False,
                 native: Optional[bool] = None) -> None:
        """`native`: steps by `_native.PIBTCore` (the same moves as the Python methods here, about 15x
        faster); by default whenever it is built (`NATIVE`)."""
        if native is None:
            native = NATIVE
        if native and _Core is None:
            raise RuntimeError("the C step (fleet_common.planning._native) is not built here")
        self.free = FreeCells.of(grid)
        self.moves = self.free.moves()
        #: per cell, its moves in each rotation (the tie orders of `_open`; the C step makes its own)
        self.turns = [] if native else [[m[r:] + m[:r] for r in range(len(m))] for m in self.moves]
        self.adj = self.free.adjacency()
        self.goals = self.free.to_free(goals)
        self.swap = swap
        self.rotations = rotations
        self.distances = AgentDistances(grid, self.goals, lists=not native)
        self.dist = self.distances.dist
        self.limit = self.distances.limit
        self.core = None
        if native:
            d = self.distances
            self.core = _Core(self.moves, self.goals, d.rows.row_of, d.rows.table, d.limit,
                              d.far if d.lazy is not None else None, swap, rotations)
        #: cycles undone after steps with cells fixed in advance (only those can close one)
        self.reverted = 0
        self.occ_now = [NIL] * self.free.count
        self.occ_nxt = [NIL] * self.free.count

    def to_ids(self, cells: Sequence[Coord]) -> List[int]:
        """Free-cell ids of coordinates: the cells `step` works on."""
        return self.free.to_free(cells)

    def plan(self, configs: Sequence[Sequence[int]]) -> Plan:
        """The plan of a list of configurations (free-cell ids per agent)."""
        return self.free.plan(configs, len(self.goals))

    def cover(self, q: Sequence[int], agents: Optional[Sequence[int]] = None) -> None:
        """Make the agents' distances (default: all) exact around their cells in `q`."""
        self.distances.cover(q, agents)

    def step(self, q_from: Sequence[int], q_to: List[int], order: Sequence[int], salt: int,
             moving: Optional[Sequence[int]] = None) -> bool:
        """Fill the NIL entries of `q_to` (next cells); the others are fixed in advance.

        `moving`, if given, lists every agent not resting on its goal (the
        others' distance rows need no check). Agents missing from `order`
        must rest on their goals: they stay unless another agent needs their
        cell. Returns False when the fixed entries conflict (two in one cell, or a
        swap) or leave some agent nowhere to go; `q_to` is then meaningless.
        Unless `rotations` is set, the step has no rotation: one closed through
        fixed entries is undone by making its agents stay (fixed or not).
        """
        self.distances.cover(q_from, moving)
        if self.core is not None:
            ok, fixed = self.core.step(q_from, q_to, order, salt)
        else:
            ok, fixed = self._step(q_from, q_to, order, salt)
        if ok and fixed and not self.rotations:
            self._revert_cycles(q_from, q_to)
        return ok

    def _step(self, q_from: Sequence[int], q_to: List[int], order: Sequence[int], salt: int) -> Tuple[bool, int]:
        """`step` after `cover`, before undoing rotations: (ok, how many entries were fixed)."""
        occ_now, occ_nxt = self.occ_now, self.occ_nxt
        claimed: List[int] = []
        for i, v in enumerate(q_from):
            occ_now[v] = i
        ok = True
        for i, v in enumerate(q_to if q_to.count(NIL) < len(q_to) else ()):
            if v == NIL:
                continue
            j = occ_now[v]
            if occ_nxt[v] != NIL or (j != NIL and j != i and q_to[j] == q_from[i]):
                ok = False
                break
            occ_nxt[v] = i
            claimed.append(v)
        fixed = len(claimed)
        if ok:
            goals = self.goals
            for i in order:
                if q_to[i] != NIL:
                    continue
                v = q_from[i]
                if v == goals[i] and occ_nxt[v] == NIL:
                    q_to[i] = v  # resting on its goal, unclaimed: staying is its best move
                    occ_nxt[v] = i
                    claimed.append(v)
                elif not self._plan_agent(i, q_from, q_to, salt, claimed):
                    ok = False
                    break
            if ok and NIL in q_to:
                # agents left out of `order` rest on their goals and nobody asked for their cell
                # (asking makes an agent plan at once): they stay
                q_to[:] = [f if v == NIL else v for v, f in zip(q_to, q_from)]
        for v in q_from:
            occ_now[v] = NIL
        for v in claimed:
            occ_nxt[v] = NIL
        return ok, fixed

    def _revert_cycles(self, q_from: Sequence[int], q_to: List[int]) -> None:
        for _, agents in step_cycles(np.array([q_from, q_to], dtype=np.int64), min_length=2):
            self.reverted += 1
            for i in agents:
                q_to[i] = q_from[i]

    def _plan_agent(self, agent: int, q_from: Sequence[int], q_to: List[int], salt: int,
                    claimed: List[int]) -> bool:
        occ_now, occ_nxt = self.occ_now, self.occ_nxt
        stack = []  # frames of agents waiting on an inheritor: (agent, candidates, next, partner)
        bottom = NIL if self.rotations else agent  # entering its cell would close a rotation
        cands, partner = self._open(agent, q_from, q_to, salt)
        k = 0
        while True:
            here = q_from[agent]
            pushed = False
            while k < len(cands):
                v = cands[k]
                k += 1
                if occ_nxt[v] != NIL:
                    continue
                j = occ_now[v]
                if j != NIL and q_to[j] == here:
                    continue  # j is moving into our cell: taking its cell would be a swap
                if j == bottom and j != NIL and stack:
                    continue  # the stack moves into each other's cells up to ours: a rotation
                q_to[agent] = v
                occ_nxt[v] = agent
                claimed.append(v)
                if j == NIL or j == agent or q_to[j] != NIL:
                    # a success anywhere in the chain is a success of every agent above it
                    self._pull(agent, k, partner, q_from, q_to, claimed)
                    while stack:
                        a, _, ka, pa = stack.pop()
                        self._pull(a, ka, pa, q_from, q_to, claimed)
                    return True
                stack.append((agent, cands, k, partner))
                agent = j
                cands, partner = self._open(j, q_from, q_to, salt)
                k = 0
                pushed = True
                break
            if pushed:
                continue
            # every candidate failed: stay; the asking agent (if any) tries its next one
            holder = occ_nxt[here]
            q_to[agent] = here
            occ_nxt[here] = agent
            claimed.append(here)
            if not stack:
                return holder == NIL
            agent, cands, k, partner = stack.pop()

    def _open(self, i: int, q_from: Sequence[int], q_to: List[int], salt: int) -> Tuple[List[int], int]:
        """Candidates of agent i, best first (reversed when it must lead a swap), and its partner."""
        turns = self.turns[q_from[i]]
        # rotating the tie order stands in for a shuffle, cheaply
        cands = sorted(turns[(salt + i) % len(turns)], key=self.dist[i].__getitem__)
        partner = self._swap_partner(i, cands[0], q_from, q_to) if self.swap else NIL
        if partner != NIL:
            cands.reverse()
        return cands, partner

    def _pull(self, i: int, k: int, partner: int, q_from: Sequence[int], q_to: List[int],
              claimed: List[int]) -> None:
        """After i took its first (reversed) candidate, draw the swap partner into i's cell."""
        here = q_from[i]
        if partner != NIL and k == 1 and q_to[partner] == NIL and self.occ_nxt[here] == NIL:
            self.occ_nxt[here] = partner
            q_to[partner] = here
            claimed.append(here)

    # -- the swap rule ------------------------------------------------------

    def _swap_partner(self, i: int, best: int, q_from: Sequence[int], q_to: List[int]) -> int:
        occ_now = self.occ_now
        here = q_from[i]
        if best == here:
            return NIL  # i wants to stay: nobody needs to get past it
        j = occ_now[best]
        if (j != NIL and q_to[j] == NIL and self._swap_required(i, j, here, best)
                and self._swap_possible(best, here)):
            return j  # i wants j's cell and j wants through i: i leads, pulling j
        dist = self.dist
        for u in self.adj[here]:
            k = occ_now[u]
            if k == NIL or u == best or q_to[k] != NIL:
                continue
            # k, were it where i is, would have to pass i: i backs off and pulls k along
            # (never unless `best` brings k nearer its goal: then _swap_required is False at once)
            dk = dist[k]
            if dk[best] < dk[here] and self._swap_required(k, i, here, best) and self._swap_possible(best, here):
                return k
        return NIL

    def _exits(self, cell: int, came_from: int) -> List[int]:
        """Neighbours of `cell` other than `came_from`, ignoring dead ends whose agent is home."""
        out = []
        for u in self.adj[cell]:
            if u == came_from:
                continue
            a = self.occ_now[u]
            if a != NIL and len(self.adj[u]) == 1 and self.goals[a] == u:
                continue
            out.append(u)
        return out

    def _swap_required(self, pusher: int, puller: int, at_pusher: int, at_puller: int) -> bool:
        """Must `pusher` (wanting through `puller`'s cell) and `puller` trade places?"""
        d_push, d_pull = self.dist[pusher], self.dist[puller]
        # follow the corridor ahead of the pusher while it leads towards the pusher's goal
        while d_push[at_puller] < d_push[at_pusher]:
            exits = self._exits(at_puller, at_pusher)
            if len(exits) >= 2:
                return False  # the puller can step aside
            if not exits:
                break
            at_pusher, at_puller = at_puller, exits[0]
        if d_pull[at_puller] > self.limit[puller]:  # the corridor may lead past the known part
            far = self.distances.far
            return far(puller, at_pusher) < far(puller, at_puller) and (
                d_push[at_pusher] == 0 or d_push[at_puller] < d_push[at_pusher])
        return d_pull[at_pusher] < d_pull[at_puller] and (
            d_push[at_pusher] == 0 or d_push[at_puller] < d_push[at_pusher])

    def _swap_possible(self, at_follower: int, at_leader: int) -> bool:
        """Can the leader back away from `at_follower` until a branch lets the two pass?"""
        origin = at_follower
        behind, ahead = at_follower, at_leader
        for _ in range(len(self.adj)):
            if ahead == origin:
                return False  # went round a loop
            exits = self._exits(ahead, behind)
            if len(exits) >= 2:
                return True
            if not exits:
                return False
            behind, ahead = ahead, exits[0]
        return False
