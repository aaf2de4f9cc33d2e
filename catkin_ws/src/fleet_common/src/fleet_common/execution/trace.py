"""The executed trace of a run, and the collision checker that judges it.

A trace records, per robot, its start cell and each move as it really
happened: `(start, end, src, dst)` in continuous time. It is checked from
these executed positions alone, knowing nothing of plans or strategies.

What a collision is, in continuous time. Robots are as large as a cell, so a
robot occupies its cell while at rest and *both* cells while moving between
them, from the instant the move starts until it completes; occupancy is
half-open, [start, end), so a robot may start entering a cell at the very
instant the previous occupant's move out of it completes.

- vertex collision: two robots occupy one cell at the same instant (their
  occupancy intervals for that cell overlap for a positive time);
- swap collision: two robots traverse the same edge in opposite directions
  at overlapping times.

A swap is also seen as vertex collisions, and one incident may show as more
than one overlapping pair; the counts are of overlapping pairs as found, so
zero means none at all. Each vertex collision records whether each robot was
moving or at rest: a robot entering a cell where another stands still is a
collision under any robot size.
"""
from __future__ import annotations

import heapq
import math
from typing import Dict, List, NamedTuple, Sequence, Tuple

from ..grid import Coord

VERTEX = "vertex"
SWAP = "swap"


class Move(NamedTuple):
    start: float
    end: float
    src: Coord
    dst: Coord


class Collision(NamedTuple):
    kind: str
    robots: Tuple[int, int]
    cells: Tuple[Coord, ...]
    time: float
    moving: Tuple[bool, bool]


class Trace:
    """Executed moves per robot, from `begin` on; robots rest between moves."""

    def __init__(self, starts: Sequence[Coord], begin: float = 0.0) -> None:
        self.starts: List[Coord] = [tuple(c) for c in starts]  # type: ignore[misc]
        self.begin = begin
        self.moves: List[List[Move]] = [[] for _ in self.starts]

    def add(self, robot: int, start: float, end: float, src: Coord, dst: Coord) -> None:
        here = self.moves[robot][-1].dst if self.moves[robot] else self.starts[robot]
        if tuple(src) != tuple(here) or end < start:
            raise ValueError("robot {} cannot move {}->{} over [{}, {}]: it is at {}".format(
                robot, src, dst, start, end, here))
        self.moves[robot].append(Move(start, end, tuple(src), tuple(dst)))  # type: ignore[arg-type]

    def final_cells(self) -> List[Coord]:
        return [m[-1].dst if m else s for s, m in zip(self.starts, self.moves)]

    def occupancy(self) -> Dict[Coord, List[Tuple[float, float, int, bool]]]:
        """Per cell, (start, end, robot, moving) intervals; the last rest never ends."""
        cells: Dict[Coord, List[Tuple[float, float, int, bool]]] = {}
        for r, start in enumerate(self.starts):
            here, since = start, self.begin
            for m in self.moves[r]:
                if m.start > since:
                    cells.setdefault(here, []).append((since, m.start, r, False))
                cells.setdefault(m.src, []).append((m.start, m.end, r, True))
                cells.setdefault(m.dst, []).append((m.start, m.end, r, True))
                here, since = m.dst, m.end
            cells.setdefault(here, []).append((since, math.inf, r, False))
        return cells


def find_collisions(trace: Trace) -> List[Collision]:
    """Every vertex and swap collision in `trace` (see the module docstring)."""
    found: List[Collision] = []
    for cell, spans in trace.occupancy().items():
        for (s1, e1, r1, m1), (s2, e2, r2, m2) in _overlaps(spans):
            a, b = (r1, m1), (r2, m2)
            if b[0] < a[0]:
                a, b = b, a
            found.append(Collision(VERTEX, (a[0], b[0]), (cell,), max(s1, s2), (a[1], b[1])))
    edges: Dict[Tuple[Coord, Coord], List[Tuple[float, float, int, bool]]] = {}
    for r, moves in enumerate(trace.moves):
        for m in moves:
            forward = m.src < m.dst
            key = (m.src, m.dst) if forward else (m.dst, m.src)
            edges.setdefault(key, []).append((m.start, m.end, r, forward))
    for key, spans in edges.items():
        for (s1, e1, r1, f1), (s2, e2, r2, f2) in _overlaps(spans):
            if f1 != f2:
                found.append(Collision(SWAP, (min(r1, r2), max(r1, r2)), key, max(s1, s2), (True, True)))
    found.sort(key=lambda c: (c.time, c.kind, c.robots))
    return found


def _overlaps(spans: List[Tuple[float, float, int, bool]]) -> List[Tuple[tuple, tuple]]:
    """Pairs of intervals of different robots that overlap for a positive time."""
    spans = sorted(spans)
    active: List[Tuple[float, int]] = []  # heap of (end, index)
    pairs = []
    for i, span in enumerate(spans):
        while active and active[0][0] <= span[0]:
            heapq.heappop(active)
        for _, j in active:
            other = spans[j]
            if other[2] != span[2] and other[1] > span[0] and span[1] > span[0]:
                pairs.append((other, span))
        heapq.heappush(active, (span[1], i))
    return pairs
