"""The grid every part of FleetControl plans and moves on.

Coordinate convention (stated once, here): a `Coord` is `(x, y)` in the *base
grid*, the lab's reference frame: origin at the bottom-left cell, x to the
right, y up, one unit a cell. Files in mapf-IR orientation (origin top-left,
y down) are flipped by the readers and writers in `fleet_common.formats`, and
nowhere else. Cells are 4-connected; a robot may also wait in place.
"""
from __future__ import annotations

from typing import Dict, Iterable, Iterator, List, Sequence, Tuple

import numpy as np

Coord = Tuple[int, int]

#: Characters that block a cell under mapf-IR's rule; every other one is free.
MAPF_IR_BLOCKED = frozenset("T@")
#: The strict MovingAI rule: water (`W`) and out-of-bounds (`O`) block too.
MOVINGAI_BLOCKED = frozenset("T@WO")


class Grid:
    """A rectangular 4-connected grid of free and blocked cells (base frame).

    `free[y, x]` is True where a robot may stand; row 0 is the bottom row.
    """

    __slots__ = ("free", "name", "_adjacency", "derived")

    def __init__(self, free: np.ndarray, name: str = "") -> None:
        free = np.asarray(free, dtype=bool)
        if free.ndim != 2:
            raise ValueError("grid must be 2-D, got shape {}".format(free.shape))
        self.free = free
        self.free.setflags(write=False)
        self.name = name
        self._adjacency: List[List[int]] = []
        #: Data computed from the grid and kept with it (distance tables, ...), by key.
        self.derived: Dict[object, object] = {}

    @classmethod
    def from_rows(
        cls, rows: Sequence[str], blocked: Iterable[str] = MAPF_IR_BLOCKED, name: str = ""
    ) -> "Grid":
        """Build from text rows listed top to bottom, as in a `.map` file."""
        blocked_set = frozenset(blocked)
        height = len(rows)
        width = len(rows[0]) if rows else 0
        free = np.ones((height, width), dtype=bool)
        for file_y, row in enumerate(rows):
            if len(row) != width:
                raise ValueError("row {} has {} cells, expected {}".format(file_y, len(row), width))
            base_y = height - 1 - file_y
            for x, ch in enumerate(row):
                if ch in blocked_set:
                    free[base_y, x] = False
        return cls(free, name=name)

    @property
    def width(self) -> int:
        return int(self.free.shape[1])

    @property
    def height(self) -> int:
        return int(self.free.shape[0])

    @property
    def num_cells(self) -> int:
        return self.width * self.height

    def in_bounds(self, c: Coord) -> bool:
        return 0 <= c[0] < self.width and 0 <= c[1] < self.height

    def is_free(self, c: Coord) -> bool:
        return self.in_bounds(c) and bool(self.free[c[1], c[0]])

    def index(self, c: Coord) -> int:
        """Cell id `y * width + x`, used by array-based code (distance tables)."""
        return c[1] * self.width + c[0]

    def coord(self, index: int) -> Coord:
        return (index % self.width, index // self.width)

    def neighbors(self, c: Coord) -> List[Coord]:
        """Free 4-neighbours of `c`, in a fixed order (left, right, down, up)."""
        x, y = c
        out = []
        for n in ((x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)):
            if self.is_free(n):
                out.append(n)
        return out

    def adjacency(self) -> List[List[int]]:
        """Neighbour cell ids per cell id (empty for blocked cells); built once."""
        if not self._adjacency:
            w, h = self.width, self.height
            table: List[List[int]] = [[] for _ in range(w * h)]
            free = self.free
            for y in range(h):
                for x in range(w):
                    if not free[y, x]:
                        continue
                    table[y * w + x] = [
                        ny * w + nx
                        for nx, ny in ((x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1))
                        if 0 <= nx < w and 0 <= ny < h and free[ny, nx]
                    ]
            self._adjacency = table
        return self._adjacency

    def free_cells(self) -> Iterator[Coord]:
        ys, xs = np.nonzero(self.free)
        for x, y in zip(xs.tolist(), ys.tolist()):
            yield (x, y)

    def flip_y(self, c: Coord) -> Coord:
        """Between the base grid and mapf-IR's top-left frame (its own inverse)."""
        return (c[0], self.height - 1 - c[1])

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Grid) and np.array_equal(self.free, other.free)

    def __hash__(self) -> int:
        return hash((self.free.shape, self.free.tobytes()))

    def __repr__(self) -> str:
        return "Grid({!r}, {}x{}, {} free)".format(
            self.name, self.width, self.height, int(self.free.sum())
        )
