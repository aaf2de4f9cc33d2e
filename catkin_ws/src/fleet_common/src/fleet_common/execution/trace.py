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

Counting: each visit of a robot to a cell (from the start of its move in to
the end of its move out) is one occupancy interval; a vertex collision is
one pair of robots whose intervals at one cell overlap, counted once however
long. A swap is counted as a swap and, since each robot occupies both cells,
also shows as vertex collisions; zero means none of either. Each vertex
collision records whether each robot was moving throughout the overlap: a
robot entering a cell where another stands still is a collision under any
robot size, while two robots moving on at once (following too closely) are
one only for robots as large as a cell.
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
    agents: Tuple[int, int]
    cells: Tuple[Coord, ...]
    time: float
    moving: Tuple[bool, bool]


class Trace:
    """Executed moves per robot, from `begin` on; robots rest between moves."""

    def __init__(self, starts: Sequence[Coord], begin: float = 0.0) -> None:
        self.starts: List[Coord] = [tuple(c) for c in starts]  # type: ignore[misc]
        self.begin = begin
        self.moves: List[List[Move]] = [[] for _ in self.starts]

    def add(self, agent: int, start: float, end: float, src: Coord, dst: Coord) -> None:
        here = self.moves[agent][-1].dst if self.moves[agent] else self.starts[agent]
        if tuple(src) != tuple(here) or end < start:
            raise ValueError("agent {} cannot move {}->{} over [{}, {}]: it is at {}".format(
                agent, src, dst, start, end, here))
        self.moves[agent].append(Move(start, end, tuple(src), tuple(dst)))  # type: ignore[arg-type]

    def final_cells(self) -> List[Coord]:
        return [m[-1].dst if m else s for s, m in zip(self.starts, self.moves)]

    def occupancy(self) -> Dict[Coord, List[Tuple[float, float, int, float, float]]]:
        """Per cell, one (start, end, robot, rest_start, rest_end) per visit.

        A visit lasts from the start of the move in (or `begin`) to the end of the
        move out (or forever); the robot is at rest in [rest_start, rest_end).
        """
        cells: Dict[Coord, List[Tuple[float, float, int, float, float]]] = {}
        for r, start in enumerate(self.starts):
            here, entered, since = start, self.begin, self.begin
            for m in self.moves[r]:
                cells.setdefault(here, []).append((entered, m.end, r, since, m.start))
                here, entered, since = m.dst, m.start, m.end
            cells.setdefault(here, []).append((entered, math.inf, r, since, math.inf))
        return cells


def find_collisions(trace: Trace) -> List[Collision]:
    """Every vertex and swap collision in `trace` (see the module docstring)."""
    found: List[Collision] = []
    for cell, spans in trace.occupancy().items():
        for one, two in _overlaps(spans):
            if two[2] < one[2]:
                one, two = two, one
            begin, end = max(one[0], two[0]), min(one[1], two[1])
            moving = tuple(max(v[3], begin) >= min(v[4], end) for v in (one, two))  # no rest inside
            found.append(Collision(VERTEX, (one[2], two[2]), (cell,), begin, moving))  # type: ignore[arg-type]
    edges: Dict[Tuple[Coord, Coord], List[tuple]] = {}
    for r, moves in enumerate(trace.moves):
        for m in moves:
            forward = m.src < m.dst
            key = (m.src, m.dst) if forward else (m.dst, m.src)
            edges.setdefault(key, []).append((m.start, m.end, r, forward))
    for key, spans in edges.items():
        for one, two in _overlaps(spans):
            if one[3] != two[3]:
                found.append(Collision(SWAP, (min(one[2], two[2]), max(one[2], two[2])), key,
                                       max(one[0], two[0]), (True, True)))
    found.sort(key=lambda c: (c.time, c.kind, c.agents))
    return found


def _overlaps(spans: List[tuple]) -> List[Tuple[tuple, tuple]]:
    """Pairs of (start, end, robot, ...) of different robots that overlap for a positive time."""
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


class CollisionCount:
    """The number of collisions `find_collisions` would find, kept up to date move by move.

    A running manager wants the count while the run goes on; judging the whole
    trace again costs time that grows with the run (60 ms at 300 robots after a
    few minutes), and the manager's loop must not stall. Moves are added in the
    order they completed (as a run log has them); each new visit of a cell is
    checked against the visits of that cell so far, each new move against the
    opposite moves over its edge. A pair whose overlap depends on an end not yet
    known (equal times) waits until `collisions` is read, which judges it with
    what is known then, as `find_collisions` would.
    """

    def __init__(self, starts: Sequence[Coord], begin: float = 0.0) -> None:
        self.vertex = 0
        self.swaps = 0
        self._visits: Dict[Coord, List[List]] = {}  # cell -> [enter, leave, robot] per visit
        self._edges: Dict[Tuple[Coord, Coord], List[Tuple[float, float, int, bool]]] = {}
        self._pending: List[Tuple[List, List]] = []
        self._here: List[List] = [self._enter(r, tuple(c), begin, begin)  # type: ignore[arg-type]
                                  for r, c in enumerate(starts)]

    @property
    def collisions(self) -> int:
        """Vertex and swap collisions together (a swap also counts as vertex collisions)."""
        return self.vertex + self.swaps + sum(1 for a, b in self._pending
                                              if max(a[0], b[0]) < min(a[1], b[1]))

    def add(self, agent: int, start: float, end: float, src: Coord, dst: Coord) -> None:
        """Robot `robot` moved `src`->`dst` over [start, end); ValueError (nothing counted)
        if it was not at `src`."""
        visit = self._here[agent]
        if visit[3] != tuple(src) or end < start:
            raise ValueError("agent {} cannot move {}->{} over [{}, {}]: it is at {}".format(
                agent, src, dst, start, end, visit[3]))
        visit[1] = end
        self._here[agent] = self._enter(agent, tuple(dst), start, end)  # type: ignore[arg-type]
        forward = tuple(src) < tuple(dst)
        key = (tuple(src), tuple(dst)) if forward else (tuple(dst), tuple(src))
        edge = self._edges.setdefault(key, [])  # type: ignore[arg-type]
        self.swaps += sum(1 for s, e, r, f in edge
                          if r != agent and f != forward and max(s, start) < min(e, end))
        edge.append((start, end, agent, forward))

    def stood(self, agent: int, cell: Coord, start: float, end: float) -> None:
        """Robot `agent` is found on `cell` at `end` with no move there completed: if that is not
        where the count has it, it went there over [start, end) (holding both cells meanwhile)."""
        if agent < len(self._here) and self._here[agent][3] != tuple(cell):
            self.add(agent, start, max(start, end), self._here[agent][3], tuple(cell))  # type: ignore[arg-type]

    def _enter(self, agent: int, cell: Coord, at: float, now: float) -> List:
        """A new visit from `at`; `now` is the latest completion (every open visit ends later)."""
        visit = [at, math.inf, agent, cell]
        for other in self._visits.setdefault(cell, []):
            if other[2] == agent:
                continue
            both_in = max(at, other[0])
            if both_in >= other[1]:
                continue  # the other had left before this one came
            if both_in < min(other[1], now):
                self.vertex += 1  # overlapping whenever the open ends turn out to be
            else:
                self._pending.append((visit, other))
        self._visits[cell].append(visit)
        return visit
