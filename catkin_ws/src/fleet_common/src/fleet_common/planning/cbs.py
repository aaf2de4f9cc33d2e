"""Conflict-Based Search (Sharon et al., AIJ 2015) with ICBS's improvements: optimal sum of costs.

Theory of operation. The high level is a best-first search over constraint
sets. Each node holds one shortest path per agent that respects that agent's
constraints (space-time A*; among shortest paths, one that meets the other
agents' paths least). A conflict between two paths splits the node in two:
each child forbids one of the agents that cell (or move) at that step. The
first node without conflicts is optimal. Costs are counted as mapf-IR counts
them: an agent's cost is the step from which it stays at its goal for good.

What makes it fast enough for dozens of agents (all keep it optimal):
- conflicts are prioritised by MDDs (`mdd`): a *cardinal* conflict, where
  every shortest path of both agents collides, is split first, then
  semi-cardinal ones, then the rest (ICBS, Boyarski et al. 2015);
- the node's lower bound adds the CG heuristic: agents joined by cardinal
  conflicts form a graph, and at least one agent of each edge must pay a
  step, so the size of a minimum vertex cover is admissible (Felner et al.
  2018); the open list is ordered by cost + that bound;
- bypassing: a child that keeps the cost and has fewer conflicts gives its
  path to the node instead of being added (Boyarski et al., SoCS 2015).

`ecbs(..., w=1.1)` is the bounded-suboptimal variant by focal search: among
open nodes whose lower bound is within `w` times the smallest, the one with
the fewest conflicts is expanded; its plan costs at most `w` times the optimum.

Unless `rotations` is set, a rotation (k >= 3 agents each entering the cell
the next one leaves in one step; robots cannot perform one) is a conflict too
(`cbs_conflicts`): k children each forbid one agent its move. Every
rotation-free plan leaves out one of those moves, so CBS stays optimal among
rotation-free plans.
"""
from __future__ import annotations

import heapq
from typing import Dict, List, Optional, Sequence, Set, Tuple

from ..grid import Coord, Grid
from .cbs_conflicts import ROTATION, SWAP, Conflict, Constraint, all_conflicts, vertex_cover_size
from .cells import moves, plan_from_paths, to_ids
from .deadline import Deadline
from .dist_table import dist_codes, dist_lists
from .mdd import MDD
from .reservations import Reservations
from .result import NO_SOLUTION, TIMEOUT, SolveResult, failed, solved
from .st_astar import DeadlineReached, space_time_astar

NAME = "cbs"
#: Default suboptimality bound of `ecbs`.
DEFAULT_W = 1.1


class _Node:
    __slots__ = ("constraints", "paths", "cost", "h", "conflicts")

    def __init__(self, constraints: List[Tuple[Constraint, ...]], paths: List[List[int]]) -> None:
        self.constraints = constraints
        self.paths = paths
        self.cost = sum(len(p) - 1 for p in paths)
        self.h = 0
        self.conflicts: List[Conflict] = []


class _Search:
    """The low level, the MDDs and the conflict analysis of one CBS run."""

    def __init__(self, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
                 rotations: bool) -> None:
        self.num_cells = grid.num_cells
        self.starts, self.goals = to_ids(grid, starts), to_ids(grid, goals)
        self.h = dist_lists(grid, goals, unreachable=grid.num_cells + 1)
        self.free = grid.free
        self.dist_goal = [codes.reshape(grid.free.shape) for codes in dist_codes(grid, goals)]
        self.moves = moves(grid)
        self.deadline = deadline
        self.rotations = rotations
        self.mdds: Dict[Tuple[int, Tuple[Constraint, ...]], MDD] = {}

    def constraints_of(self, cons: Tuple[Constraint, ...]) -> Reservations:
        res = Reservations(self.num_cells)
        for t, a, b in cons:
            if b < 0:
                res.block_cell(a, t)
            else:
                res.block_move(a, b, t)
        return res

    def path(self, i: int, cons: Tuple[Constraint, ...], others: Sequence[List[int]]) -> Optional[List[int]]:
        # the other agents' paths are soft: among optimal paths, prefer one that meets them less
        soft = Reservations(self.num_cells, rotations=True)  # cells only: no move chains needed
        for j, p in enumerate(others):
            if j != i and p:
                soft.add_path(p)
        return space_time_astar(self.moves, self.starts[i], self.goals[i], self.h[i], self.constraints_of(cons),
                                self.deadline, avoid=soft)

    def mdd(self, node: _Node, i: int) -> MDD:
        key = (i, node.constraints[i])
        found = self.mdds.get(key)
        if found is None:
            found = self.mdds[key] = MDD(self.free, self.starts[i], self.goals[i], len(node.paths[i]) - 1,
                                         self.dist_goal[i], node.constraints[i])
        return found

    def analyse(self, node: _Node) -> None:
        """Find the node's conflicts, how cardinal each is, and its CG lower bound."""
        node.conflicts = all_conflicts(node.paths, self.rotations)
        edges: Set[Tuple[int, int]] = set()
        for c in node.conflicts:
            if c.kind == ROTATION:
                continue
            (i, ci), (j, _) = c.branches
            c.cardinality = self._cardinal(node, i, c, ci) + self._cardinal(node, j, c, c.branches[1][1])
            if c.cardinality == 2:
                edges.add((min(i, j), max(i, j)))
        node.h = vertex_cover_size(edges)

    def _cardinal(self, node: _Node, i: int, c: Conflict, con: Constraint) -> int:
        mdd = self.mdd(node, i)
        t, a, b = con
        if c.kind == SWAP:
            return int(mdd.single(t - 1) == a and mdd.single(t) == b)
        return int(mdd.single(t) == a)


def cbs(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
        seed: int = 0, rotations: bool = False) -> SolveResult:
    """Optimal (sum of costs) plan, or "timeout" at the deadline. `seed` is unused: CBS is deterministic."""
    return _run(grid, starts, goals, deadline, rotations, 1.0, NAME)


def ecbs(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
         seed: int = 0, rotations: bool = False, w: float = DEFAULT_W) -> SolveResult:
    """A plan whose sum of costs is at most `w` times the optimum, by focal search on conflicts."""
    if w < 1.0:
        raise ValueError("ecbs needs w >= 1 (a factor on the optimal sum of costs), got {}".format(w))
    return _run(grid, starts, goals, deadline, rotations, w, "ecbs")


def _run(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline, rotations: bool,
         w: float, name: str) -> SolveResult:
    search = _Search(grid, starts, goals, deadline, rotations)
    n = len(starts)
    expanded = 0
    try:
        root_paths: List[List[int]] = []
        for i in range(n):
            path = search.path(i, (), root_paths)
            if path is None:
                return failed(name, NO_SOLUTION, "agent {} cannot reach its goal".format(i))
            root_paths.append(path)
        root = _Node([() for _ in range(n)], root_paths)
        search.analyse(root)
        open_ = _Open(w)
        open_.push(root)
        while open_:
            if deadline.expired():
                raise DeadlineReached()
            node = open_.pop()
            if not node.conflicts:
                return solved(plan_from_paths(grid, node.paths), name, expanded=expanded, lower_bound=open_.bound)
            expanded += 1
            children = _expand(search, node)
            if children is None:
                open_.push(node)  # bypassed: the node took a child's path; look at it again
                continue
            for child in children:
                open_.push(child)
    except DeadlineReached:
        return failed(name, TIMEOUT, "time limit reached after {} constraint-tree nodes".format(expanded),
                      expanded=expanded)
    return failed(name, NO_SOLUTION, "every constraint set was tried: no plan exists", expanded=expanded)


def _expand(search: _Search, node: _Node) -> Optional[List[_Node]]:
    """The children of the node's most cardinal (then earliest) conflict; None if one was bypassed."""
    conflict = max(node.conflicts, key=lambda c: (c.cardinality, -c.t))
    children = []
    for agent, con in conflict.branches:
        cons = list(node.constraints)
        cons[agent] = cons[agent] + (con,)
        path = search.path(agent, cons[agent], node.paths)
        if path is None:
            continue
        paths = list(node.paths)
        paths[agent] = path
        child = _Node(cons, paths)
        search.analyse(child)
        if conflict.cardinality == 0 and child.cost == node.cost and len(child.conflicts) < len(node.conflicts):
            # bypass: the path fits the node's own constraints too, at the same cost
            node.paths = paths
            node.conflicts, node.h = child.conflicts, child.h
            return None
        children.append(child)
    return children


class _Open:
    """Open nodes by lower bound; with w > 1, the focal choice: fewest conflicts within w x the bound."""

    def __init__(self, w: float) -> None:
        self.w = w
        self.heap: List[Tuple[int, int, int, _Node]] = []
        self.count = 0
        self.bound = 0

    def __bool__(self) -> bool:
        return bool(self.heap)

    def push(self, node: _Node) -> None:
        self.count += 1
        heapq.heappush(self.heap, (node.cost + node.h, len(node.conflicts), self.count, node))

    def pop(self) -> _Node:
        self.bound = self.heap[0][0]
        if self.w <= 1.0:
            return heapq.heappop(self.heap)[3]
        limit = self.w * self.bound
        pick = min((k for k, e in enumerate(self.heap) if e[0] <= limit), key=lambda k: self.heap[k][1:3])
        entry = self.heap[pick]
        self.heap[pick] = self.heap[-1]
        self.heap.pop()
        heapq.heapify(self.heap)
        return entry[3]
