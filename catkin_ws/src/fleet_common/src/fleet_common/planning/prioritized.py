"""Prioritized planning: agents one by one, each around the paths planned before it.

Theory of operation. Agents are taken in priority order (longest
start-to-goal distance first, ties at random from the seed); each gets a
space-time A* path that avoids the cells and moves already reserved, and
then parks at its goal for good. It is fast and its plans are short, but it
is incomplete: an agent planned early can wall in a later one (classically,
by parking on a cell the later one must cross). When an agent finds no path
it is moved to the front of the order and planning starts over, up to
`max_restarts` times. Unless `rotations` is set, no agent's path closes a
rotation with the paths reserved before it (`reservations`); a rotation's
last-planned agent would close it, so plans have none.

`plan_with_reservations` plans a subset of agents around the fixed paths of
the others: the engine of replanning (robots that are out stay where they
are; robots that keep their plans keep their paths).
"""
from __future__ import annotations

import random
from typing import List, Optional, Sequence, Union

import numpy as np

from ..grid import Coord, Grid
from ..plan import Plan
from .cells import moves, plan_from_paths, to_ids
from .deadline import Deadline
from .dist_table import dist_lists
from .reservations import Reservations
from .result import NO_SOLUTION, TIMEOUT, SolveResult, failed, solved
from .st_astar import DeadlineReached, space_time_astar

NAME = "pp"
MAX_RESTARTS = 20


def pp(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
       seed: int = 0, max_restarts: int = MAX_RESTARTS, rotations: bool = False) -> SolveResult:
    """Prioritized planning for all agents (no fixed paths)."""
    return plan_with_reservations(grid, starts, goals, (), deadline, seed, max_restarts, rotations)


def plan_with_reservations(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
                           fixed_paths: Sequence[Sequence[Coord]], deadline: Deadline,
                           seed: int = 0, max_restarts: int = MAX_RESTARTS,
                           rotations: bool = False) -> SolveResult:
    """Paths for the agents of `starts`/`goals` that avoid `fixed_paths` (which stay as given).

    Each fixed path holds its last cell forever after its end. The plan covers
    the agents of `starts` only, and is at least as long as the longest fixed
    path, so that the two together form one conflict-free plan.
    """
    rng = random.Random(seed)
    n = len(starts)
    fixed = [to_ids(grid, p) for p in fixed_paths]
    min_len = max((len(p) for p in fixed), default=1)
    if n == 0:
        return solved(Plan(np.zeros((min_len, 0, 2), dtype=np.int32)), NAME)
    start_ids, goal_ids = to_ids(grid, starts), to_ids(grid, goals)
    h = dist_lists(grid, goals, unreachable=grid.num_cells + 1)
    mv = moves(grid)
    tie = [rng.random() for _ in range(n)]
    order = sorted(range(n), key=lambda i: (-h[i][start_ids[i]], tie[i]))
    failed_agent = -1
    try:
        for attempt in range(max_restarts + 1):
            paths = _plan_in_order(grid, mv, h, start_ids, goal_ids, fixed, order, deadline, rotations)
            if isinstance(paths, int):
                failed_agent = paths
                order.remove(failed_agent)
                order.insert(0, failed_agent)
                continue
            paths = [p + [p[-1]] * (min_len - len(p)) for p in paths]
            return solved(plan_from_paths(grid, paths), NAME, restarts=attempt)
    except DeadlineReached:
        return failed(NAME, TIMEOUT, "time limit reached while planning agent paths one by one")
    return failed(NAME, NO_SOLUTION, (
        "prioritized planning found no path for agent {} in {} priority orders; it is incomplete, "
        "a complete solver (lacam) may still find a plan").format(failed_agent, max_restarts + 1),
        restarts=max_restarts)


def _plan_in_order(grid: Grid, mv: List[List[int]], h: List[List[int]], starts: List[int],
                   goals: List[int], fixed: List[List[int]], order: List[int],
                   deadline: Deadline, rotations: bool) -> Union[List[List[int]], int]:
    """Paths per agent, or the index of the first agent that found none."""
    res = Reservations(grid.num_cells, rotations)
    for p in fixed:
        res.add_path(p)
    # agents not planned yet sit on their starts at step 0: nobody may enter those at step 1
    # (they are added to and removed from the step-1 cells around each search)
    waiting = set(starts)
    res.horizon = max(res.horizon, 1)
    paths: List[Optional[List[int]]] = [None] * len(starts)
    for i in order:
        waiting.discard(starts[i])
        for s in waiting:
            res.vertex.add(grid.num_cells + s)
        path = space_time_astar(mv, starts[i], goals[i], h[i], res, deadline)
        for s in waiting:
            res.vertex.discard(grid.num_cells + s)
        if path is None:
            return i
        res.add_path(path)
        paths[i] = path
    return [p for p in paths if p is not None]
