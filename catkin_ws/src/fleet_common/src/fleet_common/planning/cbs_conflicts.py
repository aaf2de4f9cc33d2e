"""The conflicts between CBS's paths, and how each may be resolved.

A conflict lists its branches: (agent, constraint) pairs, one per child node.
A constraint (t, cell, -1) forbids being at `cell` at step t; (t, a, b)
forbids moving a->b into step t. Kinds: two agents in one cell (vertex), two
swapping cells (swap), and, unless rotations are allowed, k >= 3 agents each
entering the cell the next one leaves (rotation: k branches, each forbidding
one agent its move; every rotation-free plan leaves out one of those moves).
Paths wait at their last cell after their end (mapf-IR's cost semantics).

`vertex_cover_size` is CBS's CG bound: agents joined by cardinal conflicts
form a graph, and each edge costs one of its two agents at least a step.
"""
from __future__ import annotations

from typing import Dict, List, Set, Tuple

import numpy as np

from ..rotations import step_cycles

Constraint = Tuple[int, int, int]
VERTEX, SWAP, ROTATION = "vertex", "swap", "rotation"


class Conflict:
    """One conflict: its kind, step, and per branch the agent and the constraint it gets."""

    __slots__ = ("kind", "t", "branches", "cardinality")

    def __init__(self, kind: str, t: int, branches: List[Tuple[int, Constraint]]) -> None:
        self.kind = kind
        self.t = t
        self.branches = branches
        #: agents for which resolving it costs at least a step (0, 1 or 2 of a pair), set by CBS
        self.cardinality = 0

    @property
    def pair(self) -> Tuple[int, int]:
        return self.branches[0][0], self.branches[1][0]


def all_conflicts(paths: List[List[int]], rotations: bool) -> List[Conflict]:
    """Every vertex and swap conflict (and rotation, unless allowed), earliest first."""
    steps = max((len(p) for p in paths), default=0)
    out: List[Conflict] = []
    prev: List[int] = []
    for t in range(steps):
        now = [p[t] if t < len(p) else p[-1] for p in paths]
        seen: Dict[int, int] = {}
        for i, c in enumerate(now):
            j = seen.get(c)
            if j is None:
                seen[c] = i
            else:
                out.append(Conflict(VERTEX, t, [(j, (t, c, -1)), (i, (t, c, -1))]))
        if t > 0:
            came: Dict[Tuple[int, int], int] = {}
            for i, (a, b) in enumerate(zip(prev, now)):
                if a != b:
                    came[(a, b)] = i
            for (a, b), i in came.items():
                j = came.get((b, a))
                if j is not None and i < j:
                    out.append(Conflict(SWAP, t, [(i, (t, a, b)), (j, (t, b, a))]))
        prev = now
    if not rotations and len(paths) >= 3 and steps > 1:
        ids = np.array([p + [p[-1]] * (steps - len(p)) for p in paths], dtype=np.int64).T
        for t, agents in step_cycles(ids, min_length=3):
            out.append(Conflict(ROTATION, t + 1, [(i, (t + 1, int(ids[t, i]), int(ids[t + 1, i])))
                                                  for i in agents]))
        out.sort(key=lambda c: c.t)
    return out


#: Conflict graphs with more agents than this get a matching's size as their bound (still admissible).
EXACT_COVER_AGENTS = 16


def vertex_cover_size(edges: Set[Tuple[int, int]]) -> int:
    """Size of a minimum vertex cover of the graph, or a lower bound of it for large graphs."""
    adj: Dict[int, Set[int]] = {}
    for u, v in edges:
        adj.setdefault(u, set()).add(v)
        adj.setdefault(v, set()).add(u)
    if len(adj) > EXACT_COVER_AGENTS:
        matched: Set[int] = set()
        for u, v in sorted(edges):  # a maximal matching: each edge needs its own cover vertex
            if u not in matched and v not in matched:
                matched |= {u, v}
        return len(matched) // 2
    return _cover(adj)


def _cover(adj: Dict[int, Set[int]]) -> int:
    """Exact minimum vertex cover by branching on a vertex of largest degree: it, or all its neighbours."""
    adj = {u: set(vs) for u, vs in adj.items() if vs}
    if not adj:
        return 0
    u = max(adj, key=lambda k: len(adj[k]))
    without_u = _remove(adj, [u])
    take_u = 1 + _cover(without_u)
    nbrs = list(adj[u])
    if len(nbrs) >= take_u:
        return take_u
    return min(take_u, len(nbrs) + _cover(_remove(adj, nbrs + [u])))


def _remove(adj: Dict[int, Set[int]], gone: List[int]) -> Dict[int, Set[int]]:
    drop = set(gone)
    return {k: vs - drop for k, vs in adj.items() if k not in drop}
