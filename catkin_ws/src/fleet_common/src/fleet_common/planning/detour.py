"""New paths for a few agents over a window of a plan, around everyone else: the first try of rotation repair.

A window is the steps t0..t1 of a plan under repair (`occupancy`). The
chosen agents keep their cells at t0 and at t1 and get new paths in between,
one agent after the other, by space-time A* (`window_search`) around the
other agents' moves and the paths placed before, where a move that would
close a rotation is as forbidden as a taken cell. Everything outside the
window stays as it was, so the plan stays valid there.

The plan is changed in place, and only if every agent found a path. Its
lookups are the plan's own and the distances are searched only as far as
the window reaches, so a window costs what its searches expand, whatever the
size of the plan and of the map.
"""
from __future__ import annotations

import random
from typing import Callable, Dict, List, Sequence

from .deadline import Deadline
from .occupancy import AWAY, Occupancy
from .window_search import find_path


def replan_window(moves: List[List[int]], occ: Occupancy, t0: int, t1: int, agents: Sequence[int],
                  deadline: Deadline, orders: int = 8) -> bool:
    """Re-plan `agents` over steps t0..t1 of `occ` in place; False (and `occ` as it was) if no order works.

    `moves` is `cells.moves(grid)`. Agents are planned one by one, in up to
    `orders` orders (the failed agent first next time, every other time a
    shuffle). Raises `st_astar.DeadlineReached` when `deadline` expires.
    """
    agents = [int(a) for a in agents]
    before = occ.ids[t0:t1 + 1, agents].copy()
    starts, goals = before[0].tolist(), before[-1].tolist()
    h = [_near_distances(moves, g, t1 - t0) for g in goals]
    off = [AWAY] * (t1 - t0 - 1)
    order = sorted(range(len(agents)), key=lambda k: (-h[k](starts[k]), agents[k]))
    rng = random.Random(t0 * 7919 + len(agents))
    for attempt in range(orders):
        for a in agents:  # off the board, between the window's ends
            occ.put(a, t0 + 1, off)
        failed = None
        for k in order:
            path = find_path(moves, occ, agents[k], starts[k], goals[k], t0, t1, h[k], deadline)
            if path is None:
                failed = k
                break
            occ.put(agents[k], t0, path + [path[-1]] * (t1 - t0 + 1 - len(path)))  # waits at its t1 cell
        if failed is None:
            return True
        if failed == order[0]:
            break  # no path even before the others were placed: no order helps
        if attempt % 2:
            rng.shuffle(order)  # taking the failed agent first can go round in circles
        order.remove(failed)  # the agent that found no path goes first next time
        order.insert(0, failed)
    for k, a in enumerate(agents):
        occ.put(a, t0, before[:, k].tolist())
    return False


def _near_distances(moves: List[List[int]], goal: int, radius: int) -> Callable[[int], int]:
    """Moves from each cell to `goal`, searched `radius` moves out; farther cells read radius + 1."""
    dist: Dict[int, int] = {goal: 0}
    frontier = [goal]
    for level in range(1, radius + 1):
        nxt = []
        for c in frontier:
            for v in moves[c]:
                if v not in dist:
                    dist[v] = level
                    nxt.append(v)
        frontier = nxt
    far = radius + 1
    return lambda c: dist.get(c, far)
