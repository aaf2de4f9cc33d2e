"""Space-time A*: one agent's shortest path around reservations.

States are (cell, step); moves go to a neighbour or wait, one step each. The
heuristic is the true distance to the goal on the empty map (consistent), so
the first time the goal is popped the path is shortest. The agent may only
finish at its goal at a step after the last reservation of that cell, since
it stays there for good. After the reservations' horizon nothing changes any
more but parked agents, so all later steps of a cell are one state: the
search is finite and reports "no path" when the goal cannot be reached.
A move that would close a rotation with reserved moves (see `reservations`)
is forbidden like a reserved cell, unless the reservations allow rotations.
"""
from __future__ import annotations

import heapq
from typing import Dict, List, Optional, Sequence, Set

from .deadline import Deadline
from .reservations import NEVER, Reservations

#: Check the deadline every this many expansions (a clock read costs ~50 ns; a pop ~1 us).
_CHECK_EVERY = 256


#: Packs (step, soft conflicts) into one int: step * _SCALE + conflicts.
_SCALE = 1 << 16
_EMPTY: Set[int] = set()


class DeadlineReached(Exception):
    """The deadline expired during a search (solvers turn it into a "timeout")."""


def space_time_astar(moves: Sequence[Sequence[int]], start: int, goal: int, h: Sequence[int],
                     res: Reservations, deadline: Deadline, start_time: int = 0,
                     avoid: Optional[Reservations] = None) -> Optional[List[int]]:
    """Cells from `start` (at step `start_time`) to `goal`, one per step, or None if impossible.

    `avoid` holds soft reservations (other agents' current paths, in CBS):
    among shortest paths, one that meets them least often is preferred.
    """
    nv = res.num_cells
    vertex, edge, parked = res.vertex, res.edge, res.parked
    follow = res.follow  # empty when rotations are allowed or no path is reserved
    if parked[goal] != NEVER:
        return None
    soft, soft_parked = (avoid.vertex, avoid.parked) if avoid is not None else (_EMPTY, None)
    # the agent cannot finish before `done`: a sharper, still admissible heuristic
    done = res.last.get(goal, -1) + 1
    cap = res.horizon + 1  # steps >= cap are all alike
    start_key = (start_time if start_time < cap else cap) * nv + start
    # per state, the best (step, soft conflicts) reached, packed in one int
    best: Dict[int, int] = {start_key: start_time * _SCALE}
    parent: Dict[int, int] = {}
    h0 = max(h[start], done - start_time)
    # ties on f go to fewer soft conflicts, then to the deepest state: with waits
    # allowed, diving beats flooding every (cell, step) of equal f
    heap = [(start_time + h0, 0, -start_time, start)]
    pops = 0
    while heap:
        _, hits, neg_t, cell = heapq.heappop(heap)
        t = -neg_t
        key = (t if t < cap else cap) * nv + cell
        if best[key] < t * _SCALE + hits:
            continue  # a better way here was found after this entry was queued
        if cell == goal and t >= done:
            return _path(parent, key, nv)
        pops += 1
        if pops % _CHECK_EVERY == 0 and deadline.expired():
            raise DeadlineReached()
        nt = t + 1
        t_base = t * nv
        nt_base = nt * nv
        move_base = (nt_base + cell) * nv
        nkey_base = (nt if nt < cap else cap) * nv
        for v in moves[cell]:
            if nt_base + v in vertex or parked[v] <= nt:
                continue
            if v != cell and (move_base + v in edge or (
                    follow and t_base + v in follow and res.closes_cycle(cell, v, t))):
                continue
            nhits = hits
            if nt_base + v in soft or (soft_parked is not None and soft_parked[v] <= nt):
                nhits += 1
            score = nt * _SCALE + min(nhits, _SCALE - 1)
            nkey = nkey_base + v
            old = best.get(nkey)
            if old is not None and old <= score:
                continue
            best[nkey] = score
            parent[nkey] = key
            hv = h[v]
            if done - nt > hv:
                hv = done - nt
            heapq.heappush(heap, (nt + hv, nhits, -nt, v))
    return None


def _path(parent: Dict[int, int], key: int, nv: int) -> List[int]:
    cells = [key % nv]
    for _ in range(len(parent)):
        if key not in parent:
            break
        key = parent[key]
        cells.append(key % nv)
    cells.reverse()
    return cells
