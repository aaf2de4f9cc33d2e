"""Breadth-first searches from many goals at once over free cells, in numpy, resumable.

Theory of operation. Row r of `table` (uint16, F+1 columns: the free cells
and the "no cell" sentinel F of `free_cells`, which holds 0 so that it never
looks unreached) holds distances to one goal, `UNREACHED` where the search
has not been yet. A `Search` remembers how far its row is final (`level`: every
cell at distance <= level has its value) and its frontier (the cells at
distance exactly `level`), so it can be resumed later: solvers grow a goal's
row only as far as agents need it. `grow` advances up to `BATCH` searches
together, one level per round, as flat (search, cell) arrays: the four
neighbours of every frontier cell, those still unreached, duplicates dropped
by scattering positions into a scratch array, then their distance written.
Every (goal, cell) pair enters a frontier once, so the work is goals x cells
reached, in a few dozen numpy passes per level and batch.
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import numpy as np

#: Distance of a cell not reached (yet); larger than any distance the tables hold.
UNREACHED = 65535
#: Searches advanced together: bounds the scratch array to BATCH x (F+1) int32.
BATCH = 128


class Search:
    """One goal's search: its row is final up to `level`; `frontier` holds the cells at that level."""

    __slots__ = ("frontier", "level")

    def __init__(self, frontier: np.ndarray, level: int = 0) -> None:
        self.frontier = frontier
        self.level = level

    @property
    def done(self) -> bool:
        """Every cell reachable from the goal has its distance."""
        return self.frontier.size == 0


def grow(table: np.ndarray, neighbours: np.ndarray, searches: Sequence[Search], rows: Sequence[int],
         stops: Sequence[int], targets: Optional[Sequence[int]] = None, margin: int = 0) -> None:
    """Advance search k (filling row `rows[k]`) until its level reaches `stops[k]` or it is done.

    With `targets`, search k also stops `margin` levels after it reached cell
    `targets[k]` (use -1 for none), whichever comes first.
    """
    todo = sorted((k for k, s in enumerate(searches) if not s.done and s.level < stops[k]),
                  key=lambda k: searches[k].level)
    for b in range(0, len(todo), BATCH):
        chunk = todo[b:b + BATCH]
        _grow_batch(table, neighbours, [searches[k] for k in chunk], [rows[k] for k in chunk],
                    [stops[k] for k in chunk], None if targets is None else [targets[k] for k in chunk], margin)


def _grow_batch(table: np.ndarray, neighbours: np.ndarray, searches: List[Search], rows: List[int],
                stops: List[int], targets: Optional[List[int]], margin: int) -> None:
    width = table.shape[1]
    local = table[rows]  # a copy: the batch's rows side by side, written back at the end
    flat = local.reshape(-1)
    n = len(searches)
    base = np.arange(n, dtype=np.int64) * width
    # the batch advances one level a round; a search joins when the round reaches its level
    level = searches[0].level
    joins = [s.level for s in searches]
    joined = 0
    stop = np.asarray(stops, dtype=np.int64).copy()
    saved = np.zeros(n, dtype=bool)
    target = None if targets is None else np.asarray(targets, dtype=np.int64)
    nb = neighbours
    col = np.zeros(0, dtype=np.int32)
    pos = np.zeros(0, dtype=np.int32)
    scratch = np.empty(n * width, dtype=np.int32)
    while True:
        if joined < n and joins[joined] == level:
            end = joined
            while end < n and joins[end] == level:
                end += 1
            fresh_cols = [searches[k].frontier.astype(np.int32) for k in range(joined, end)]
            col = np.concatenate([col] + fresh_cols)
            pos = np.concatenate([pos] + [c + np.int32(k * width) for k, c in zip(range(joined, end), fresh_cols)])
            joined = end
        if target is not None:  # a reached target sets its search's stop
            at = flat[base + np.maximum(target, 0)].astype(np.int64)
            np.minimum(stop, np.where((target >= 0) & (at != UNREACHED), at + margin, stop), out=stop)
        finished = ~saved & (level >= stop)
        finished[joined:] = False
        if finished.any():
            who = pos // width
            out = finished[who]
            _save(searches, finished, col[out], who[out], level)
            saved |= finished
            col, pos = col[~out], pos[~out]
        if not col.size:
            if joined == n:
                break
            level = joins[joined]  # nothing to expand until the next search joins
            continue
        nbr = nb[col].ravel()
        pos4 = nbr + np.repeat(pos - col, 4)
        fresh = np.flatnonzero(flat[pos4] == UNREACHED)
        pos, col = pos4[fresh], nbr[fresh]
        order = np.arange(pos.size, dtype=np.int32)
        scratch[pos] = order
        first = np.flatnonzero(scratch[pos] == order)  # one copy of each (search, cell) reached twice
        pos, col = pos[first], col[first]
        level += 1
        if level >= UNREACHED - 1:
            raise ValueError("a shortest path on this map is {} moves or longer; distance tables "
                             "hold at most {}".format(UNREACHED - 1, UNREACHED - 2))
        flat[pos] = level
    for k in np.flatnonzero(~saved):  # ran out of cells: the row is complete
        searches[k].frontier, searches[k].level = np.zeros(0, dtype=np.int32), level
    table[rows] = local


def _save(searches: List[Search], finished: np.ndarray, col: np.ndarray, who: np.ndarray, level: int) -> None:
    """Give each finished search its frontier (its cells among `col`) and level."""
    order = np.argsort(who, kind="stable")
    col = col[order]
    ends = np.cumsum(np.bincount(who, minlength=finished.size)).tolist()
    for k in np.flatnonzero(finished).tolist():
        searches[k].frontier, searches[k].level = col[ends[k - 1] if k else 0:ends[k]], level
