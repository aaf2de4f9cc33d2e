"""mapf-IR solution files (solver output), read and written fast.

    instance=../instances/x.txt     # key=value lines in order, repeats and
    agents=2                        # unknown keys kept (IR adds `iter=` lines)
    map_file=x.map
    ...
    starts=(3,1),(1,3),
    goals=(4,1),(5,1),
    solution=
    0:(3,1),(1,3),                  # one row per step t = 0, 1, 2, ...
    1:(4,1),(0,3),

An entry may carry a heading, `(x,y,X_PLUS),`, as mapf-visualizer reads it.
Our rule: the first row decides: either every entry of every row has a
heading or none has (`Plan.orientations` is None then). A failed run leaves
the block after `solution=` empty (`plan` None). Coordinates are top-left,
y down, unless the header says `orientation=base`; in memory everything is
base frame, headings too (Y_PLUS and Y_MINUS swap when flipping).

Speed: a 1,500-agent, 1,000-step file is 14 MB. Each row is checked by one
compiled full match and all rows become integers in one numpy call; only a
row that fails is walked entry by entry to name the column. Whether the plan
is valid (moves, collisions, soc, off-map cells) is the validator's job.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import MapNotFoundError, NotConvertibleError, SolutionFormatError
from ..grid import Coord, Grid
from ..plan import Orientation, Plan
from .header import (
    MAPF_IR, Header, check_orientation, file_orientation, header_for_orientation, join_lines,
    read_text, split_lines, write_text,
)
from .mapfile import read_map
from .mapsearch import default_map_dirs, resolve_map

_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_HEADING = r"[XY]_(?:PLUS|MINUS)"
# up to 9 digits keeps every coordinate, flipped or not, inside int32
_ENTRY = r"\(\d{1,9},\d{1,9}\),"
_ENTRY_HEADING = r"\(\d{1,9},\d{1,9}," + _HEADING + r"\),"
_ONE = re.compile(r"\((\d{1,9}),(\d{1,9})(?:,(" + _HEADING + r"))?\),")
_NAMES = [o.name for o in sorted(Orientation)]
_CODES = {name: i for i, name in enumerate(_NAMES)}
_NAME_ARRAY = np.array(_NAMES, dtype=object)
_FLIP_CODE = np.array([Orientation(i).flipped_y().value for i in range(len(_NAMES))], np.int8)
_row_patterns: Dict[Tuple[int, bool], "re.Pattern[str]"] = {}


def _row_pattern(n: int, headings: bool) -> "re.Pattern[str]":
    key = (n, headings)
    if key not in _row_patterns:
        entry = _ENTRY_HEADING if headings else _ENTRY
        _row_patterns[key] = re.compile("(?:{}){{{}}}".format(entry, n))
    return _row_patterns[key]


class Solution:
    """A solver's output; starts, goals and plan in the base frame."""

    def __init__(
        self, header: Header, starts: List[Coord], goals: List[Coord], plan: Optional[Plan],
        grid: Grid, path: Optional[str] = None, orientation: str = MAPF_IR,
        newline: str = "\n", final_newline: bool = True,
    ) -> None:
        self.header = header
        self.starts = starts
        self.goals = goals
        self.plan = plan
        self.grid = grid
        self.path = path
        self.orientation = orientation
        self.newline = newline
        self.final_newline = final_newline

    def _int(self, key: str) -> Optional[int]:
        return self.header.get_int(key, SolutionFormatError)

    instance = property(lambda self: self.header.get_str("instance"))
    map_file = property(lambda self: self.header.get_str("map_file"))
    solver = property(lambda self: self.header.get_str("solver"))
    agents = property(lambda self: self.header.get_int("agents", SolutionFormatError, 0))
    soc = property(lambda self: self._int("soc"))
    lb_soc = property(lambda self: self._int("lb_soc"))
    makespan = property(lambda self: self._int("makespan"))
    lb_makespan = property(lambda self: self._int("lb_makespan"))

    @property
    def solved(self) -> bool:
        return bool(self.header.get_bool("solved", SolutionFormatError))

    @property
    def comp_time(self) -> Optional[Union[int, float]]:
        return self.header.get_number("comp_time", SolutionFormatError)

    @property
    def iterations(self) -> List[Dict[str, Union[int, float, str]]]:
        """One dict per `iter=` line, e.g. {'iter': 0, 'comp_time': 0, 'soc': 31, ...}."""
        out = []
        for e in self.header.entries:
            if e.key != "iter":
                continue
            record: Dict[str, Union[int, float, str]] = {}
            col = len("iter=") + 1
            for i, part in enumerate(e.value.split(",")):
                key, eq, value = ("iter", "=", part) if i == 0 else part.partition("=")
                if not eq or not key:
                    raise SolutionFormatError(
                        "expected 'key=value' after ',' in an iter= line, got {!r}".format(part),
                        self.header.path, e.line, col)
                record[key] = _number(value)
                col += len(part) + 1
            out.append(record)
        return out

    def __repr__(self) -> str:
        return "Solution({!r}, solver={!r}, {})".format(self.path, self.solver, self.plan)


def _number(text: str) -> Union[int, float, str]:
    try:
        return int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return text


def _entries_error(body: str, n: int, headings: Optional[bool], path: Optional[str],
                   no: int, offset: int) -> SolutionFormatError:
    """Walk a row that failed its full match: say where and what was expected."""
    pos = count = 0
    shape = "'(x,y,X_PLUS),'" if headings else "'(x,y),'"
    while pos < len(body):
        m = _ONE.match(body, pos)
        col = offset + pos + 1
        if m is None:
            rest = body[pos:pos + 12]
            long_number = re.match(r"\(\d*,?\d{10}", body[pos:])
            what = ("coordinate with more than 9 digits" if long_number else
                    "expected an entry {}, got {!r}".format(shape, rest))
            return SolutionFormatError(what, path, no, col)
        if headings is None and m.group(3):
            return SolutionFormatError("starts=/goals= entries carry no heading; expected "
                                       "'(x,y),'", path, no, col)
        if headings is not None and bool(m.group(3)) != headings:
            what = ("entry without a heading; the first solution row has headings on every "
                    "entry, so every row must" if headings else
                    "entry with a heading; the first solution row has none, so no row may")
            return SolutionFormatError(what, path, no, col)
        count += 1
        if count > n:
            return SolutionFormatError("more than {} entries (agents={})".format(n, n),
                                       path, no, col)
        pos = m.end()
    return SolutionFormatError("{} entries, expected {} (agents={})".format(count, n, n),
                               path, no, offset + len(body) + 1)


# Matched rows are ASCII; bytes.translate strips them to "x,y,...," at C speed.
# A heading's letters are kept as two digits: axis (X 0, Y 1), sign (PLUS 0, MINUS 2),
# so X_PLUS, Y_PLUS, X_MINUS, Y_MINUS read as 0, 10, 2, 12 (see _HEADING_CODE).
_DIGITS = bytes.maketrans(b"XYPM", b"0102")
_HEADING_CODE = np.zeros(13, dtype=np.int8)
_HEADING_CODE[[0, 10, 2, 12]] = [_CODES["X_PLUS"], _CODES["Y_PLUS"], _CODES["X_MINUS"],
                                 _CODES["Y_MINUS"]]


def _to_int_array(joined: str, n_values: int) -> np.ndarray:
    data = joined.encode("ascii").translate(_DIGITS, b"()_LUSIN")
    flat = np.fromstring(data, dtype=np.int64, sep=",")
    if flat.size != n_values:  # cannot happen after the full matches; never read short
        raise ValueError("expected {} numbers, converted {}".format(n_values, flat.size))
    return flat


def _parse_list(line: str, prefix: str, n: int, path: Optional[str], no: int) -> np.ndarray:
    body = line[len(prefix):]
    if _row_pattern(n, False).fullmatch(body) is None:
        raise _entries_error(body, n, None, path, no, len(prefix))
    return _to_int_array(body, 2 * n).reshape(n, 2)


def _parse_rows(rows: List[str], n: int, path: Optional[str],
                first_no: int) -> Tuple[np.ndarray, Optional[np.ndarray]]:
    """Rows `t:(x,y),...` as (T+1, n, 2) ints and (T+1, n) heading codes or None."""
    head = rows[0].partition(":")[2]
    headings = re.match(r"\(\d+,\d+,", head) is not None
    pattern = _row_pattern(n, headings)
    bodies = []
    for t, row in enumerate(rows):
        prefix = "%d:" % t
        no = first_no + t
        if not row.startswith(prefix):
            m = re.match(r"(\d+):", row)
            what = ("steps must count 0, 1, 2, ...: expected step {}, got {}".format(t, m.group(1))
                    if m else "expected '{}' (step number and ':') at the start of a solution "
                    "row".format(prefix))
            raise SolutionFormatError(what, path, no, 1)
        body = row[len(prefix):]
        if pattern.fullmatch(body) is None:
            raise _entries_error(body, n, headings, path, no, len(prefix))
        bodies.append(body)
    joined = "".join(bodies)
    if not headings:
        return _to_int_array(joined, 2 * n * len(rows)).reshape(len(rows), n, 2), None
    flat = _to_int_array(joined, 3 * n * len(rows)).reshape(len(rows), n, 3)
    return flat[..., :2], _HEADING_CODE[flat[..., 2]]


def _flip(cells: np.ndarray, height: int) -> np.ndarray:
    out = cells.copy()
    out[..., 1] = height - 1 - out[..., 1]
    return out


def parse_solution(text: str, path: Optional[str] = None,
                   map_dirs: Optional[Sequence[Path]] = (), grid: Optional[Grid] = None) -> Solution:
    """Parse solution text. `grid` given: use it instead of reading `map_file`.

    The map is looked for in the file's folder, then `map_dirs` (None:
    `default_map_dirs()`).
    """
    lines, newline, final_newline = split_lines(text)
    header = Header(path=path)
    no = 0
    while no < len(lines) and not lines[no].startswith("starts="):
        key, eq, value = lines[no].partition("=")
        if not eq or not _KEY.fullmatch(key):
            raise SolutionFormatError(
                "expected a 'key=value' header line (or 'starts='), got {!r}".format(lines[no]),
                path, no + 1, 1)
        header.append(key, value, no + 1)
        no += 1
    if no == len(lines):
        raise SolutionFormatError("missing 'starts=' line after the header", path, max(no, 1))
    for i, want in ((1, "goals="), (2, "solution=")):
        if no + i >= len(lines) or not lines[no + i].startswith(want):
            raise SolutionFormatError("expected a '{}' line after '{}'".format(
                want, lines[no + i - 1].partition("=")[0] + "="), path, min(no + i + 1, len(lines)), 1)
    if lines[no + 2] != "solution=":
        raise SolutionFormatError("expected nothing after 'solution=' on its line",
                                  path, no + 3, len("solution=") + 1)
    if "agents" not in header:
        raise SolutionFormatError("missing 'agents=' line before 'starts='", path, no + 1)
    n = header.get_int("agents", SolutionFormatError, minimum=0) or 0
    orientation = file_orientation(header, SolutionFormatError)
    starts = _parse_list(lines[no], "starts=", n, path, no + 1)
    goals = _parse_list(lines[no + 1], "goals=", n, path, no + 2)
    rows = lines[no + 3:]
    if grid is None:
        grid = _load_grid(header, path, map_dirs, no + 1)
    plan = None
    if rows:
        positions, codes = _parse_rows(rows, n, path, no + 4)
        if orientation == MAPF_IR:
            positions = _flip(positions, grid.height)
            codes = None if codes is None else _FLIP_CODE[codes]
        plan = Plan(positions.astype(np.int32), codes)
    if orientation == MAPF_IR:
        starts, goals = _flip(starts, grid.height), _flip(goals, grid.height)
    sol = Solution(header, [tuple(c) for c in starts.tolist()], [tuple(c) for c in goals.tolist()],
                   plan, grid, path, orientation, newline, final_newline)
    for name in ("solved", "soc", "lb_soc", "makespan", "lb_makespan", "comp_time", "iterations"):
        getattr(sol, name)  # a bad value fails now, naming its line, not later
    return sol


def _load_grid(header: Header, path: Optional[str], map_dirs: Optional[Sequence[Path]],
               starts_line: int) -> Grid:
    map_file = header.get_str("map_file")
    if not map_file:
        raise SolutionFormatError("missing 'map_file=' line before 'starts=' (needed to find "
                                  "the map)", path, header.line_of("map_file") or starts_line)
    dirs = default_map_dirs() if map_dirs is None else map_dirs
    try:
        found = resolve_map(map_file, Path(path).parent if path else None, dirs)
    except MapNotFoundError as err:
        raise MapNotFoundError(err.message, path, header.line_of("map_file")) from None
    return read_map(str(found)).grid


def read_solution(path: str, map_dirs: Optional[Sequence[Path]] = (),
                  grid: Optional[Grid] = None) -> Solution:
    return parse_solution(read_text(str(path)), str(path), map_dirs, grid)


def _format_cells(cells: np.ndarray, codes: Optional[np.ndarray]) -> str:
    n = cells.shape[0]
    if codes is None:
        return ("(%d,%d)," * n) % tuple(cells.ravel().tolist())
    flat = np.empty((n, 3), dtype=object)
    flat[:, :2] = cells
    flat[:, 2] = _NAME_ARRAY[codes]
    return ("(%d,%d,%s)," * n) % tuple(flat.ravel().tolist())


def format_solution(sol: Solution, orientation: Optional[str] = None) -> str:
    """The file text; `orientation` None keeps the file's own, else 'mapf-ir' or 'base'."""
    target = check_orientation(orientation, sol.orientation)
    header = header_for_orientation(sol.header, target)
    header.set("agents", len(sol.starts))
    h = sol.grid.height
    ends = [np.array(sol.starts, dtype=np.int64).reshape(-1, 2),
            np.array(sol.goals, dtype=np.int64).reshape(-1, 2)]
    positions = codes = None
    if sol.plan is not None:
        positions, codes = sol.plan.positions, sol.plan.orientations
        if codes is not None and (codes < 0).any():
            raise NotConvertibleError("some plan entries have a heading and some do not; a "
                                      "solution file has headings on every entry or on none")
    if target == MAPF_IR:
        ends = [_flip(e, h) for e in ends]
        if positions is not None:
            positions = _flip(positions, h)
            codes = None if codes is None else _FLIP_CODE[codes]
    out = header.lines()
    out.append("starts=" + _format_cells(ends[0], None))
    out.append("goals=" + _format_cells(ends[1], None))
    out.append("solution=")
    if positions is not None:
        for t in range(positions.shape[0]):
            out.append("%d:" % t + _format_cells(positions[t], None if codes is None else codes[t]))
    return join_lines(out, sol.newline, sol.final_newline)


def write_solution(sol: Solution, path: str, orientation: Optional[str] = None) -> None:
    write_text(str(path), format_solution(sol, orientation))


def make_solution(
    grid: Grid, map_file: str, plan: Optional[Plan], starts: Sequence[Coord],
    goals: Sequence[Coord], solver: str, solved: bool, comp_time: Union[int, float],
    lb_soc: Optional[int] = None, lb_makespan: Optional[int] = None,
    instance: Optional[str] = None, extra: Sequence[Tuple[str, object]] = (),
) -> Solution:
    """A fresh solution with mapf-IR's keys; `plan` None is a failed run (empty block).

    `lb_soc`/`lb_makespan` are written only when given; `extra` (key, value)
    pairs, such as `iter=` lines, follow `comp_time=`.
    """
    if plan is None and solved:
        raise ValueError("a solved run needs a plan")
    if len(starts) != len(goals):
        raise ValueError("{} starts but {} goals".format(len(starts), len(goals)))
    if plan is not None and plan.num_agents != len(starts):
        raise ValueError("plan has {} agents, starts {}".format(plan.num_agents, len(starts)))
    values: List[Tuple[str, object]] = [
        ("instance", instance or ""), ("agents", len(starts)), ("map_file", map_file),
        ("solver", solver), ("solved", int(bool(solved))),
        ("soc", 0 if plan is None else plan.soc), ("lb_soc", lb_soc),
        ("makespan", -1 if plan is None else plan.makespan), ("lb_makespan", lb_makespan),
        ("comp_time", comp_time),
    ]
    header = Header()
    for key, value in list(values) + list(extra):
        if value is not None:
            header.append(key, value)
    return Solution(header, [(int(x), int(y)) for x, y in starts],
                    [(int(x), int(y)) for x, y in goals], plan, grid)
