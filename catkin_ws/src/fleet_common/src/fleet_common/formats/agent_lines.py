"""Agent lines of mapf-IR instances, `sx,sy,gx,gy`: their shape, and their cells on the map.

mapf-IR matches agent lines with a regular expression and silently skips any
line that does not fit (`12, 7,16,18`); here such a line is an error that says
which field and column break the shape. Cells are checked as written in the
file (so the message matches what the user sees), one line at a time as the
file is read (`AgentCells`), and returned in the base frame.
"""
from __future__ import annotations

import re
from typing import Dict, List, Optional, Tuple

from ..errors import InstanceFormatError
from ..grid import Coord, Grid
from ..limits import MAX_CELL_DIGITS
from .header import MAPF_IR

#: One agent line, exactly as mapf-IR's regular expression reads it.
AGENT_LINE = re.compile(r"(\d+),(\d+),(\d+),(\d+)", re.ASCII)
_FIELDS = ("sx", "sy", "gx", "gy")


def agent_line_error(line: str, path: Optional[str], no: int) -> InstanceFormatError:
    """Say where an agent line leaves the `sx,sy,gx,gy` shape (digits only)."""
    pos = 0
    for k, field in enumerate(_FIELDS):
        if pos >= len(line):
            what = "line ends early: expected {} ('sx,sy,gx,gy')".format(field)
            return InstanceFormatError(what, path, no, pos + 1)
        if not line[pos].isdigit():
            what = "expected a digit for {}, got {!r} (agent lines are 'sx,sy,gx,gy', " \
                   "digits only, no spaces)".format(field, line[pos])
            return InstanceFormatError(what, path, no, pos + 1)
        while pos < len(line) and line[pos].isdigit():
            pos += 1
        if k < 3 and (pos >= len(line) or line[pos] != ","):
            got = "the end of the line" if pos >= len(line) else repr(line[pos])
            what = "expected ',' after {}, got {} ('sx,sy,gx,gy')".format(field, got)
            return InstanceFormatError(what, path, no, pos + 1)
        pos += 1 if k < 3 else 0
    what = "unexpected {!r} after gy; an agent line is exactly 'sx,sy,gx,gy'".format(line[pos])
    return InstanceFormatError(what, path, no, pos + 1)


def looks_like_agent_line(line: str) -> bool:
    first = line.lstrip()[:1]
    return "," in line and (first.isdigit() or first in "-+(")


class AgentCells:
    """Checks agent lines one at a time on `grid`: each cell on the map, free, and no two
    agents starting (or ending) on one cell; `starts` and `goals` in the base frame."""

    def __init__(self, grid: Grid, orientation: str, path: Optional[str]) -> None:
        self.grid = grid
        self.flip = orientation == MAPF_IR
        self.path = path
        self.starts: List[Coord] = []
        self.goals: List[Coord] = []
        self._taken: Tuple[Dict[Coord, Tuple[int, int]], Dict[Coord, Tuple[int, int]]] = ({}, {})

    def add(self, no: int, m: "re.Match[str]") -> None:
        """Agent line `no`, matched by AGENT_LINE."""
        agent = len(self.starts)
        w, h = self.grid.width, self.grid.height
        for group in range(1, 5):
            if len(m.group(group)) > MAX_CELL_DIGITS:
                raise InstanceFormatError("coordinate with more than {} digits".format(
                    MAX_CELL_DIGITS), self.path, no, m.start(group) + 1)
        sx, sy, gx, gy = (int(v) for v in m.groups())
        for k, (x, y), out in ((0, (sx, sy), self.starts), (1, (gx, gy), self.goals)):
            what = ("start", "goal")[k]
            col = m.start(1 + 2 * k) + 1
            if not (x < w and y < h):
                raise InstanceFormatError(
                    "{} ({},{}) of agent {} is off the map ({} wide, {} high)".format(
                        what, x, y, agent, w, h), self.path, no, col)
            base = (x, h - 1 - y) if self.flip else (x, y)
            if not self.grid.free[base[1], base[0]]:
                raise InstanceFormatError("{} ({},{}) of agent {} is on a blocked cell".format(
                    what, x, y, agent), self.path, no, col)
            if base in self._taken[k]:
                other, other_line = self._taken[k][base]
                raise InstanceFormatError(
                    "agent {} {}s at ({},{}), where agent {} {}s too (line {})".format(
                        agent, ("start", "end")[k], x, y, other, ("start", "end")[k], other_line),
                    self.path, no, col)
            self._taken[k][base] = (agent, no)
            out.append(base)
