"""MovingAI `.scen` scenario files (version 1), turned into mapf-IR instances.

    version 1
    0	random-32-32-20.map	32	32	12	21	12	7	14.00000000

After the version line, one tab-separated line per agent: bucket, map name,
map width and height, start x y, goal x y, optimal length. Coordinates are
top-left, y down, like mapf-IR's, so `Scen` keeps them as written and
`scen_to_instance` flips them once it knows the grid. MAPF benchmarks take
the first N entries as the agents of an N-agent instance. Lines are checked as
they are read (formats/lines.py); numbers within the limits of
`fleet_common.limits` (no 5,000-digit bucket, no infinite optimal length).
"""
from __future__ import annotations

from typing import List, NamedTuple, Optional

from ..errors import ScenFormatError
from ..grid import Coord, Grid
from ..limits import MAX_CELL_DIGITS, DecodeError, excerpt, parse_float, parse_int
from .instance import Instance, make_instance
from .lines import Lines, open_lines, text_lines

_FIELDS = ("bucket", "map", "width", "height", "start x", "start y", "goal x", "goal y",
           "optimal length")
_VERSIONS = ("version 1", "version 1.0")


class ScenEntry(NamedTuple):
    bucket: int
    map_name: str
    width: int
    height: int
    start: Coord  # as written: top-left, y down
    goal: Coord
    optimal_length: float
    line: int
    #: 1-based column where each of the nine fields starts, for messages
    columns: tuple


class Scen:
    __slots__ = ("entries", "path")

    def __init__(self, entries: List[ScenEntry], path: Optional[str] = None) -> None:
        self.entries = entries
        self.path = path

    def __len__(self) -> int:
        return len(self.entries)

    def __repr__(self) -> str:
        return "Scen({!r}, {} entries)".format(self.path, len(self.entries))


def _parse_entry(line: str, no: int, path: Optional[str]) -> ScenEntry:
    fields = line.split("\t")
    if len(fields) != len(_FIELDS):
        hint = " (fields are separated by tabs)" if len(fields) == 1 and " " in line else ""
        raise ScenFormatError("expected {} tab-separated fields (bucket, map, width, height, "
                              "sx, sy, gx, gy, optimal length), got {:,}{}".format(
                                  len(_FIELDS), len(fields), hint), path, no, 1)
    columns = []
    col = 1
    for f in fields:
        columns.append(col)
        col += len(f) + 1
    numbers = []
    for k, (name, text) in enumerate(zip(_FIELDS, fields)):
        if k == 1:
            continue
        try:
            value = parse_float(text) if k == 8 else parse_int(text, MAX_CELL_DIGITS)
        except DecodeError:
            kind = "a finite number" if k == 8 else "an integer of at most {} digits".format(
                MAX_CELL_DIGITS)
            raise ScenFormatError("{} must be {}, got {}".format(name, kind, excerpt(text)),
                                  path, no, columns[k]) from None
        if value < 0:
            raise ScenFormatError("{} must not be negative, got {}".format(name, text),
                                  path, no, columns[k])
        numbers.append(value)
    bucket, width, height, sx, sy, gx, gy, optimal = numbers
    return ScenEntry(int(bucket), fields[1], int(width), int(height), (int(sx), int(sy)),
                     (int(gx), int(gy)), float(optimal), no, tuple(columns))


def parse_scen(text: str, path: Optional[str] = None) -> Scen:
    return _parse(text_lines(text, path, ScenFormatError), path)


def read_scen(path: str) -> Scen:
    with open_lines(str(path), ScenFormatError) as lines:
        return _parse(lines, str(path))


def _parse(lines: Lines, path: Optional[str]) -> Scen:
    entries: List[ScenEntry] = []
    blank: List[int] = []  # blank lines so far: allowed at the end only
    for no, line in lines:
        if no == 1:
            if line.strip() not in _VERSIONS:
                raise ScenFormatError("expected 'version 1' on the first line, got {}".format(
                    excerpt(line)), path, 1)
            continue
        if not line.strip():
            blank.append(no)
            continue
        if blank:
            _parse_entry("", blank[0], path)  # a blank line inside: the usual message
        entries.append(_parse_entry(line, no, path))
    if lines.count == 0:
        raise ScenFormatError("expected 'version 1' on the first line, got an empty file", path, 1)
    return Scen(entries, path)


def scen_to_instance(scen: Scen, grid: Grid, map_file: str,
                     agents: Optional[int] = None) -> Instance:
    """An instance of the first `agents` entries (all when None) on `grid`."""
    n = len(scen.entries) if agents is None else agents
    if n < 1 or n > len(scen.entries):
        raise ScenFormatError("asked for {} agents; the scen has {} entries".format(
            n, len(scen.entries)), scen.path, scen.entries[-1].line if scen.entries else 1)
    starts: List[Coord] = []
    goals: List[Coord] = []
    seen = ({}, {})  # cell -> line, for starts and for goals
    for e in scen.entries[:n]:
        if (e.width, e.height) != (grid.width, grid.height):
            raise ScenFormatError("the scen is for a {}x{} map, but the map is {}x{}".format(
                e.width, e.height, grid.width, grid.height), scen.path, e.line, e.columns[2])
        for k, cell, out in ((0, e.start, starts), (1, e.goal, goals)):
            what, col = ("start", "goal")[k], e.columns[4 + 2 * k]
            base = (cell[0], grid.height - 1 - cell[1])
            if not grid.is_free(base):
                place = "off the map" if not grid.in_bounds(base) else "on a blocked cell"
                raise ScenFormatError("{} ({},{}) is {}".format(what, cell[0], cell[1], place),
                                      scen.path, e.line, col)
            if base in seen[k]:
                raise ScenFormatError("{} ({},{}) is also the {} on line {}".format(
                    what, cell[0], cell[1], what, seen[k][base]), scen.path, e.line, col)
            seen[k][base] = e.line
            out.append(base)
    return make_instance(grid, map_file, starts, goals)
