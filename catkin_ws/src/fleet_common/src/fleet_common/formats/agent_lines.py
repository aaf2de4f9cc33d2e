"""Agent lines of mapf-IR instances, `sx,sy,gx,gy`: their shape, and their cells on the map.

mapf-IR matches agent lines with a regular expression and silently skips any
line that does not fit (`12, 7,16,18`); here such a line is an error that says
which field and column break the shape. Cells are checked as written in the
file (so the message matches what the user sees) and returned in the base frame.
"""
from __future__ import annotations

import re
from typing import Dict, List, Optional, Tuple

from ..errors import InstanceFormatError
from ..grid import Coord, Grid
from .header import MAPF_IR

#: One agent line, exactly as mapf-IR's regular expression reads it.
AGENT_LINE = re.compile(r"(\d+),(\d+),(\d+),(\d+)")
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


def agents_to_base(agent_lines: List[Tuple[int, "re.Match[str]"]], grid: Grid,
                    orientation: str, path: Optional[str]) -> Tuple[List[Coord], List[Coord]]:
    """Check every cell (as written in the file) and return base-frame starts, goals."""
    w, h = grid.width, grid.height
    flip = orientation == MAPF_IR
    starts: List[Coord] = []
    goals: List[Coord] = []
    taken: Tuple[Dict[Coord, Tuple[int, int]], Dict[Coord, Tuple[int, int]]] = ({}, {})
    for agent, (no, m) in enumerate(agent_lines):
        sx, sy, gx, gy = (int(v) for v in m.groups())
        for k, (x, y), out in ((0, (sx, sy), starts), (1, (gx, gy), goals)):
            what = ("start", "goal")[k]
            col = m.start(1 + 2 * k) + 1
            if not (x < w and y < h):
                raise InstanceFormatError(
                    "{} ({},{}) of agent {} is off the map ({} wide, {} high)".format(
                        what, x, y, agent, w, h), path, no, col)
            base = (x, h - 1 - y) if flip else (x, y)
            if not grid.free[base[1], base[0]]:
                raise InstanceFormatError("{} ({},{}) of agent {} is on a blocked cell".format(
                    what, x, y, agent), path, no, col)
            if base in taken[k]:
                other, other_line = taken[k][base]
                raise InstanceFormatError(
                    "agent {} {}s at ({},{}), where agent {} {}s too (line {})".format(
                        agent, ("start", "end")[k], x, y, other, ("start", "end")[k], other_line),
                    path, no, col)
            taken[k][base] = (agent, no)
            out.append(base)
    return starts, goals
