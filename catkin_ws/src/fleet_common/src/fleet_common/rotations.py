"""Rotations: closed chains of following moves, found without a loop over agents.

In one step, mover i *follows* mover j when i enters the cell j leaves. Each
mover enters one cell, so "follows" is a functional graph (every node has at
most one out-edge); its cycles are swaps (2 movers) and rotations (3 or more
movers each entering the cell the next one leaves). mapf-IR allows rotations,
but a robot occupies both cells while it moves, so robots cannot perform one.
This module is the one place that finds them: for the validator, the
execution engine and the solvers.

Cycles come from pointer jumping over numpy arrays: after squaring the
successor map k times (2^k longer than any chain), every node has walked off
its chain's end (into the sink) or into a cycle, so the nodes still reached
are exactly the cycle nodes. A second doubling pass labels each cycle with its
smallest node, so cycles are counted without a loop; Python loops only over
the members of the cycles a caller asks to see.
"""
from __future__ import annotations

from typing import List, Optional, Tuple

import numpy as np


def follow_links(step: np.ndarray, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Per move k (from `src[k]` to `dst[k]` in step `step[k]`): the move it follows, or -1.

    The move followed is one that leaves `dst[k]` in the same step (cells are
    non-negative ints); with several such moves (a plan with a vertex
    conflict) one of them is taken.
    """
    m = int(step.shape[0])
    if m == 0:
        return np.zeros(0, dtype=np.int64)
    span = np.int64(max(int(src.max()), int(dst.max())) + 1)
    leaving = step.astype(np.int64) * span + src
    order = np.argsort(leaving, kind="stable")
    keys = leaving[order]
    probe = step.astype(np.int64) * span + dst
    at = np.minimum(np.searchsorted(keys, probe), m - 1)
    return np.where(keys[at] == probe, order[at], -1)


def cycle_leaders(links: np.ndarray, max_length: int) -> np.ndarray:
    """The smallest node of each cycle of the functional graph `links` (node -> node, -1: none).

    `max_length` bounds every chain (e.g. the number of agents, for links
    within one step). Ascending; as many as there are cycles.
    """
    m = int(links.shape[0])
    if m == 0:
        return np.zeros(0, dtype=np.int64)
    rounds = max(int(max_length), 1).bit_length()
    jump = np.append(np.where(links >= 0, links, m), m)  # node m is the sink
    for _ in range(rounds):
        jump = jump[jump]
    on = np.zeros(m + 1, dtype=bool)
    on[jump[:m]] = True
    nodes = np.nonzero(on[:m])[0]
    if nodes.size == 0:
        return nodes
    # smallest node of each cycle: min-label doubling over the cycle nodes only
    where = np.full(m, -1, dtype=np.int64)
    where[nodes] = np.arange(nodes.size)
    nxt = where[links[nodes]]
    label = nodes.copy()
    for _ in range(rounds):
        label = np.minimum(label, label[nxt])
        nxt = nxt[nxt]
    return nodes[label == nodes]


def walk_cycle(links: np.ndarray, first: int) -> np.ndarray:
    """The cycle through node `first`, in link order from it."""
    cycle = [int(first)]
    k = int(links[first])
    while k != cycle[0]:
        cycle.append(k)
        k = int(links[k])
    return np.asarray(cycle, dtype=np.int64)


def cycles(links: np.ndarray, max_length: int, limit: Optional[int] = None) -> List[np.ndarray]:
    """The cycles of `links` (see `cycle_leaders`), each from its smallest node, in that order.

    With `limit`, only the first `limit` are walked (a broken plan may have
    hundreds of thousands; Python loops only over those returned).
    """
    return [walk_cycle(links, first) for first in cycle_leaders(links, max_length)[:limit].tolist()]


def step_cycles(ids: np.ndarray, min_length: int = 3) -> List[Tuple[int, Tuple[int, ...]]]:
    """Cycles of following moves in a (steps, agents) array of non-negative cell ids.

    Returns (t, agents) for each cycle of at least `min_length` agents moving
    from step t to t + 1, the agents in cycle order (each enters the cell the
    next one leaves, the last the first one's), starting at the smallest;
    ordered by t, then by that agent.
    """
    if ids.shape[0] < 2 or ids.shape[1] < max(min_length, 2):
        return []
    moving = ids[1:] != ids[:-1]
    t, agent = np.nonzero(moving)
    links = follow_links(t, ids[t, agent], ids[t + 1, agent])
    out = []
    for cycle in cycles(links, ids.shape[1]):
        if cycle.size >= min_length:
            out.append((int(t[cycle[0]]), tuple(int(a) for a in agent[cycle])))
    return out
