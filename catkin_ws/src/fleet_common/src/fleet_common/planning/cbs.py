"""Conflict-Based Search (Sharon et al., AIJ 2015): optimal sum of costs.

Theory of operation. The high level is a best-first search over constraint
sets, cheapest total first. Each node holds one shortest path per agent that
respects that agent's constraints (space-time A*). The earliest conflict
between two paths (two agents in one cell at one step, or swapping cells)
splits the node in two: one child forbids the first agent that cell (or move)
at that step, the other forbids the second agent. The first node without
conflicts is optimal. Costs are counted as mapf-IR counts them: an agent's
cost is the step from which it stays at its goal for good, so a vertex
constraint on a goal after an agent arrived forces it to arrive later (the
low level only finishes after the last constraint on the goal). Exponential
in the number of conflicts: for small instances, within a deadline.

Unless `rotations` is set, a rotation (k >= 3 agents each entering the cell
the next one leaves in one step; robots cannot perform one) is a conflict
too. It splits the node in k children, each forbidding one of the agents its
move of that step (an edge constraint). Every rotation-free plan leaves out at
least one of those k moves, so it satisfies some child's constraints: CBS
stays optimal among rotation-free plans.
"""
from __future__ import annotations

import heapq
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..grid import Coord, Grid
from ..rotations import step_cycles
from .cells import moves, plan_from_paths, to_ids
from .deadline import Deadline
from .dist_table import dist_lists
from .reservations import Reservations
from .result import NO_SOLUTION, TIMEOUT, SolveResult, failed, solved
from .st_astar import DeadlineReached, space_time_astar

NAME = "cbs"
#: A constraint: (t, cell, -1) forbids being at `cell` at step t; (t, a, b) forbids moving a->b into step t.
Constraint = Tuple[int, int, int]


class _Node:
    __slots__ = ("constraints", "paths", "cost")

    def __init__(self, constraints: List[Tuple[Constraint, ...]], paths: List[List[int]]) -> None:
        self.constraints = constraints
        self.paths = paths
        self.cost = sum(len(p) - 1 for p in paths)


def cbs(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
        seed: int = 0, rotations: bool = False) -> SolveResult:
    """Optimal (sum of costs) plan, or "timeout" at the deadline. `seed` is unused: CBS is deterministic."""
    n = len(starts)
    start_ids, goal_ids = to_ids(grid, starts), to_ids(grid, goals)
    h = dist_lists(grid, goals, unreachable=grid.num_cells + 1)
    mv = moves(grid)

    def low_level(i: int, cons: Tuple[Constraint, ...], others: Sequence[List[int]]) -> Optional[List[int]]:
        res = Reservations(grid.num_cells)
        for t, a, b in cons:
            if b < 0:
                res.block_cell(a, t)
            else:
                res.block_move(a, b, t)
        # the other agents' paths are soft: among optimal paths, prefer one that meets them less
        soft = Reservations(grid.num_cells, rotations=True)  # cells only: no move chains needed
        for j, p in enumerate(others):
            if j != i and p:
                soft.add_path(p)
        return space_time_astar(mv, start_ids[i], goal_ids[i], h[i], res, deadline, avoid=soft)

    expanded = 0
    try:
        root_paths: List[List[int]] = []
        for i in range(n):
            path = low_level(i, (), root_paths)
            if path is None:
                return failed(NAME, NO_SOLUTION, "agent {} cannot reach its goal".format(i))
            root_paths.append(path)
        root = _Node([() for _ in range(n)], root_paths)
        counter = 0
        heap = [(root.cost, 0, counter, root)]
        while heap:
            if deadline.expired():
                return failed(NAME, TIMEOUT, "time limit reached after {} constraint-tree nodes".format(
                    expanded), expanded=expanded)
            _, _, _, node = heapq.heappop(heap)
            conflict, count = _first_conflict(node.paths, rotations)
            if conflict is None:
                return solved(plan_from_paths(grid, node.paths), NAME, expanded=expanded)
            expanded += 1
            for agent, con in conflict:
                cons = list(node.constraints)
                cons[agent] = cons[agent] + (con,)
                path = low_level(agent, cons[agent], node.paths)
                if path is None:
                    continue
                paths = list(node.paths)
                paths[agent] = path
                child = _Node(cons, paths)
                counter += 1
                heapq.heappush(heap, (child.cost, _first_conflict(paths, rotations)[1], counter, child))
    except DeadlineReached:
        return failed(NAME, TIMEOUT, "time limit reached after {} constraint-tree nodes".format(expanded),
                      expanded=expanded)
    return failed(NAME, NO_SOLUTION, "every constraint set was tried: no plan exists", expanded=expanded)


def _first_conflict(paths: List[List[int]], rotations: bool) -> Tuple[Optional[List[Tuple[int, Constraint]]], int]:
    """The earliest conflict as (agent, constraint) per branch, and how many conflicts there are."""
    first, when, count = _first_vertex_or_swap(paths)
    if rotations or len(paths) < 3:
        return first, count
    steps = max(len(p) for p in paths)
    ids = np.array([p + [p[-1]] * (steps - len(p)) for p in paths], dtype=np.int64).T
    found = step_cycles(ids, min_length=3)
    if found and found[0][0] + 1 < when:
        t, agents = found[0]
        first = [(i, (t + 1, int(ids[t, i]), int(ids[t + 1, i]))) for i in agents]
    return first, count + len(found)


def _first_vertex_or_swap(paths: List[List[int]]) -> Tuple[Optional[List[Tuple[int, Constraint]]], int, int]:
    """The earliest vertex or swap conflict (None if none), its step, and how many there are."""
    steps = max((len(p) for p in paths), default=0)
    first: Optional[List[Tuple[int, Constraint]]] = None
    when = steps
    count = 0
    prev: List[int] = []
    for t in range(steps):
        now = [p[t] if t < len(p) else p[-1] for p in paths]
        seen: Dict[int, int] = {}
        for i, c in enumerate(now):
            j = seen.get(c)
            if j is None:
                seen[c] = i
                continue
            count += 1
            if first is None:
                first, when = [(j, (t, c, -1)), (i, (t, c, -1))], t
        if t > 0:
            came: Dict[Tuple[int, int], int] = {}
            for i, (a, b) in enumerate(zip(prev, now)):
                if a != b:
                    came[(a, b)] = i
            for (a, b), i in came.items():
                j = came.get((b, a))
                if j is not None and i < j:
                    count += 1
                    if first is None:
                        first, when = [(i, (t, a, b)), (j, (t, b, a))], t
        prev = now
    return first, when, count
