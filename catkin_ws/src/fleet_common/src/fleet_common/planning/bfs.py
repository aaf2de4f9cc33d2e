"""Breadth-first searches from many goals at once, resumable: in C where `_native` is built,
else in numpy (`grow_in_numpy`, the reference, whose theory follows).

Theory of operation. Row r of `table` (uint16, one column per free cell of
`free_cells` plus its "no cell" column) holds distances to one goal,
`UNREACHED` where the search has not been yet. A `Search` remembers how far
its row is final (`level`: every cell at distance <= level has its value) and
its frontier (the free cells at distance exactly `level`), so it can be
resumed later: solvers grow a goal's row only as far as agents need it.

`grow` advances up to a batch of searches together, one level per round.
The batch's rows are laid out on the grid with a blocked border (walls and
border hold 0, so only free cells can look unreached), one grid per search
side by side, so the neighbours of a cell are at fixed offsets (+-1, +-row
width) and a round is, per direction: shift the frontier, keep the cells
still unreached, write their distance at once (so a cell reached from two
sides is taken once). Every (goal, cell) pair enters a frontier once: the
work is goals x cells reached, in a few numpy passes per level and batch.
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import numpy as np

from .free_cells import FreeCells

try:  # the same searches in C (setup builds it)
    from ._native import grow_row
except ImportError:
    grow_row = None

#: Distance of a cell not reached (yet); larger than any distance the tables hold.
UNREACHED = 65535
#: Bytes of grid rows a batch lays out at most (it always takes at least 8 searches).
BATCH_BYTES = 32_000_000


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


class _Layout:
    """Free cells on the grid with a one-cell blocked border, row width `stride`."""

    def __init__(self, free: FreeCells) -> None:
        w, h = free.grid.width, free.grid.height
        self.stride = w + 2
        self.size = (w + 2) * (h + 2)
        x, y = free.ids % w, free.ids // w
        self.of_free = ((y + 1) * self.stride + x + 1).astype(np.int64)
        self.free_of = np.full(self.size, -1, dtype=np.int64)
        self.free_of[self.of_free] = np.arange(free.count)
        self.offsets = (-1, 1, -self.stride, self.stride)  # the order of Grid.adjacency

    @staticmethod
    def of(free: FreeCells) -> "_Layout":
        found = free.grid.derived.get("bfs_layout")
        if found is None:
            found = free.grid.derived["bfs_layout"] = _Layout(free)
        return found  # type: ignore[return-value]


def grow(table: np.ndarray, free: FreeCells, searches: Sequence[Search], rows: Sequence[int],
         stops: Sequence[int], targets: Optional[Sequence[int]] = None, margin: int = 0) -> None:
    """Advance search k (filling row `rows[k]`) until its level reaches `stops[k]` or it is done.

    With `targets`, search k also stops `margin` levels after it reached free
    cell `targets[k]` (-1: none), whichever comes first. In C (`_native.grow_row`,
    one search at a time, a queue per level) where it is built; `grow_in_numpy`
    is the reference and gives the same rows, levels and frontiers.
    """
    if grow_row is None:
        grow_in_numpy(table, free, searches, rows, stops, targets, margin)
        return
    for k, s in enumerate(searches):
        if s.done or s.level >= stops[k]:
            continue
        target = -1 if targets is None else targets[k]
        frontier = np.ascontiguousarray(s.frontier, dtype=np.int64)
        cells, s.level = grow_row(table, free.neighbours, rows[k], frontier, s.level, stops[k], target, margin)
        s.frontier = np.frombuffer(cells, dtype=np.int64)


def grow_in_numpy(table: np.ndarray, free: FreeCells, searches: Sequence[Search], rows: Sequence[int],
                  stops: Sequence[int], targets: Optional[Sequence[int]] = None, margin: int = 0) -> None:
    """`grow` in numpy: a batch of searches side by side, one level a round (see the module's theory)."""
    layout = _Layout.of(free)
    batch = max(8, BATCH_BYTES // (2 * layout.size))
    todo = sorted((k for k, s in enumerate(searches) if not s.done and s.level < stops[k]),
                  key=lambda k: searches[k].level)  # a batch starts at its lowest level
    for b in range(0, len(todo), batch):
        chunk = todo[b:b + batch]
        _grow_batch(table, layout, [searches[k] for k in chunk], [rows[k] for k in chunk],
                    [stops[k] for k in chunk], None if targets is None else [targets[k] for k in chunk], margin)


def _grow_batch(table: np.ndarray, layout: _Layout, searches: List[Search], rows: List[int],
                stops: List[int], targets: Optional[List[int]], margin: int) -> None:
    n, size = len(searches), layout.size
    grids = np.zeros((n, size), dtype=np.uint16)  # walls and border: 0, never "unreached"
    grids[:, layout.of_free] = table[rows, :layout.of_free.size]
    flat = grids.reshape(-1)
    base = np.arange(n, dtype=np.int64) * size
    stop = np.asarray(stops, dtype=np.int64).copy()
    target = None
    if targets is not None:
        target = np.where(np.asarray(targets) >= 0, layout.of_free[np.maximum(targets, 0)], -1)
    saved = np.zeros(n, dtype=bool)
    # the batch advances one level a round; a search joins when the round reaches its level
    joins = [s.level for s in searches]
    level, joined = joins[0], 0
    pos = np.zeros(0, dtype=np.int64)
    while True:
        if joined < n and joins[joined] == level:
            end = joined
            while end < n and joins[end] == level:
                end += 1
            pos = np.concatenate([pos] + [layout.of_free[searches[k].frontier] + base[k] for k in range(joined, end)])
            joined = end
        if target is not None:  # a reached target sets its search's stop
            at = flat[base + np.maximum(target, 0)].astype(np.int64)
            np.minimum(stop, np.where((target >= 0) & (at != UNREACHED), at + margin, stop), out=stop)
        finished = ~saved & (level >= stop)
        finished[joined:] = False
        if finished.any():
            who = pos // size
            out = finished[who]
            _save(searches, finished, layout.free_of[pos[out] % size], who[out], level)
            saved |= finished
            pos = pos[~out]
        if not pos.size:
            if joined == n:
                break
            level = joins[joined]  # nothing to expand until the next search joins
            continue
        level += 1
        if level >= UNREACHED - 1:
            raise ValueError("a shortest path on this map is {} moves or longer; distance tables "
                             "hold at most {}".format(UNREACHED - 1, UNREACHED - 2))
        parts = []
        for off in layout.offsets:
            cand = pos + off
            cand = cand[flat[cand] == UNREACHED]
            flat[cand] = level  # taken now: the next direction will not find it again
            parts.append(cand)
        pos = np.concatenate(parts)
    for k in np.flatnonzero(~saved):  # ran out of cells: the row is complete
        searches[k].frontier, searches[k].level = np.zeros(0, dtype=np.int64), level
    table[rows, :layout.of_free.size] = grids[:, layout.of_free]


def _save(searches: List[Search], finished: np.ndarray, cells: np.ndarray, who: np.ndarray, level: int) -> None:
    """Give each finished search its frontier (its cells among `cells`) and level."""
    order = np.argsort(who, kind="stable")
    cells = cells[order]
    ends = np.cumsum(np.bincount(who, minlength=finished.size)).tolist()
    for k in np.flatnonzero(finished).tolist():
        searches[k].frontier, searches[k].level = cells[ends[k - 1] if k else 0:ends[k]], level
