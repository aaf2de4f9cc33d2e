"""Space-time A* for one agent through a plan under repair, around everyone on the board.

Like `st_astar`, but what the agent must avoid is read from the plan itself
(`occupancy`) as the search reaches each step, instead of being copied into
sets first: a search costs the states it expands, whatever the plan's size.
A move is refused when its cell is taken at the next step, when it swaps with
the cell's occupant, or when it would close a rotation: following the chain
of moves from the cell entered (its occupant moves on to a cell whose
occupant moves on ...) leads back to the cell left.

The agent starts at `start` at step t0 and is at `goal` at step t1 (both
within the plan); it may arrive earlier and wait there, once nobody else
stands on `goal` any more up to t1. The heuristic `h(cell)` must not
overestimate the moves from the cell to the goal.
"""
from __future__ import annotations

import heapq
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from .deadline import Deadline
from .occupancy import Occupancy
from .st_astar import DeadlineReached, _path  # the space-time search's own walk back

#: Check the deadline every this many expansions.
_CHECK_EVERY = 256


def find_path(moves: Sequence[Sequence[int]], occ: Occupancy, agent: int, start: int, goal: int, t0: int,
              t1: int, h: Callable[[int], int], deadline: Deadline) -> Optional[List[int]]:
    """Cells from step t0 to the arrival at `goal` (inclusive), or None; see the module docstring."""
    col = occ.ids[t0 + 1:t1 + 1] == goal
    col[:, agent] = False
    hit = col.any(axis=1).nonzero()[0]
    done = t0 + 1 + (int(hit[-1]) + 1 if hit.size else 0)  # the first step the goal is free for good
    if t0 + max(h(start), done - t0) > t1:
        return None
    nv = len(moves)
    steps: Dict[int, Tuple[Dict[int, int], List[int]]] = {}

    def step(t: int) -> Tuple[Dict[int, int], List[int]]:
        found = steps.get(t)
        if found is None:
            found = steps[t] = (occ.at(t), occ.row(t))
        return found

    seen = {t0 * nv + start}  # a state is (cell, step): the first way there is as good as any
    parent: Dict[int, int] = {}
    # ties on f go to the deepest state: with waits allowed, diving beats flooding (cell, step) pairs
    heap = [(t0 + max(h(start), done - t0), -t0, start)]
    pops = 0
    while heap:
        _, neg_t, cell = heapq.heappop(heap)
        t = -neg_t
        key = t * nv + cell
        if cell == goal and t >= done:
            return _path(parent, key, nv)
        pops += 1
        if pops % _CHECK_EVERY == 0 and deadline.expired():
            raise DeadlineReached()
        nt = t + 1
        at_t, _ = step(t)
        at_nt, row_nt = step(nt)
        nkey_base = nt * nv
        for v in moves[cell]:
            other = at_nt.get(v)
            if other is not None and other != agent:
                continue
            if v != cell and _blocked(cell, v, agent, at_t, row_nt):
                continue
            hv = h(v)
            if done - nt > hv:
                hv = done - nt
            if nt + hv > t1:
                continue
            nkey = nkey_base + v
            if nkey in seen:
                continue
            seen.add(nkey)
            parent[nkey] = key
            heapq.heappush(heap, (nt + hv, -nt, v))
    return None


def _blocked(frm: int, to: int, agent: int, at_t: Dict[int, int], row_nt: List[int]) -> bool:
    """Would moving `frm` -> `to` swap with, or close a cycle through, the moves of others?"""
    cell = to
    for _ in range(len(row_nt)):
        other = at_t.get(cell)
        if other is None or other == agent:
            return False
        ahead = row_nt[other]
        if ahead == frm:
            return True  # a swap (one move) or a rotation (more)
        if ahead == cell or ahead < 0:
            return False
        cell = ahead
    return False
