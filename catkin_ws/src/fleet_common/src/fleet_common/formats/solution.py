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
compiled full match as it is read (a bad row stops the reading there) and all
rows become integers in one numpy call; only a row that fails is walked entry
by entry to name the column. Whether the plan is valid (moves, collisions,
soc, off-map cells) is the validator's job. Keys mapf-IR does not write get
a `FormatWarning` (in `warnings`, and issued) naming the nearest known key.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import FormatWarning, NotConvertibleError, SolutionFormatError
from ..grid import Coord, Grid
from ..limits import MAX_AGENTS, MAX_NUMBER_CHARS, excerpt
from ..plan import Plan
from .cellrows import FLIP_CODE, RowReader, flip_cells, format_cells, parse_cell_list
from .header import (
    MAPF_IR, ORIENTATION_KEY, Header, check_orientation, file_orientation, header_for_orientation,
    join_lines, write_text,
)
from .lines import Lines, open_lines, text_lines
from .mapsearch import load_map_grid

_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: Keys mapf-IR's solvers write (and our `orientation=`); others get a warning.
KNOWN_KEYS = ("instance", "agents", "map_file", "solver", "solved", "soc", "lb_soc", "makespan",
              "lb_makespan", "comp_time", "preprocessing_comp_time", "iter",
              "comp_time_complement",  # PIBT_COMPLETE's time in its complement search
              ORIENTATION_KEY)


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
        #: what the reader doubted (unknown header keys), also issued as warnings
        self.warnings: List[FormatWarning] = []

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
                        "expected 'key=value' after ',' in an iter= line, got {}".format(
                            excerpt(part)), self.header.path, e.line, col)
                record[key] = _number(value)
                col += len(part) + 1
            out.append(record)
        return out

    def replace_plan(self, plan: Plan) -> None:
        """Put `plan` in place of this solution's (a repaired one), the header's soc and makespan to match."""
        self.plan = plan
        self.header.set("soc", plan.soc)
        self.header.set("makespan", plan.makespan)

    def __repr__(self) -> str:
        return "Solution({!r}, solver={!r}, {})".format(self.path, self.solver, self.plan)


def _number(text: str) -> Union[int, float, str]:
    """An iter= value: a number when it reads as a (finite, short) one, else the text."""
    if len(text) > MAX_NUMBER_CHARS:
        return text
    try:
        return int(text)
    except ValueError:
        try:
            value = float(text)
        except ValueError:
            return text
        return value if value - value == 0 else text  # not inf or nan


def parse_solution(text: str, path: Optional[str] = None,
                   map_dirs: Optional[Sequence[Path]] = (), grid: Optional[Grid] = None) -> Solution:
    """Parse solution text. `grid` given: use it instead of reading `map_file`.

    The map is looked for in the file's folder, then `map_dirs` (None:
    `default_map_dirs()`).
    """
    return _parse(text_lines(text, path, SolutionFormatError), path, map_dirs, grid)


def read_solution(path: str, map_dirs: Optional[Sequence[Path]] = (),
                  grid: Optional[Grid] = None) -> Solution:
    with open_lines(str(path), SolutionFormatError) as lines:
        return _parse(lines, str(path), map_dirs, grid)


def _parse(lines: Lines, path: Optional[str], map_dirs: Optional[Sequence[Path]],
           grid: Optional[Grid]) -> Solution:
    numbered = iter(lines)
    header = Header(path=path)
    starts_no = 0
    for starts_no, line in numbered:
        if line.startswith("starts="):
            starts_line = line
            break
        key, eq, value = line.partition("=")
        if not eq or not _KEY.fullmatch(key):
            raise SolutionFormatError(
                "expected a 'key=value' header line (or 'starts='), got {}".format(excerpt(line)),
                path, starts_no, 1)
        header.append(key, value, starts_no)
    else:
        raise SolutionFormatError("missing 'starts=' line after the header", path,
                                  max(starts_no, 1))
    goals_no, goals_line = _expect(numbered, "goals=", "starts=", path, starts_no)
    solution_no, solution_line = _expect(numbered, "solution=", "goals=", path, goals_no)
    if solution_line != "solution=":
        raise SolutionFormatError("expected nothing after 'solution=' on its line",
                                  path, solution_no, len("solution=") + 1)
    if "agents" not in header:
        raise SolutionFormatError("missing 'agents=' line before 'starts='", path, starts_no)
    n = header.get_int("agents", SolutionFormatError, minimum=0) or 0
    if n > MAX_AGENTS:
        raise SolutionFormatError("agents={:,}: more than the {:,} agents FleetControl "
                                  "reads".format(n, MAX_AGENTS), path, header.line_of("agents"))
    orientation = file_orientation(header, SolutionFormatError)
    starts = parse_cell_list(starts_line, "starts=", n, path, starts_no)
    goals = parse_cell_list(goals_line, "goals=", n, path, goals_no)
    if grid is None:
        map_file = header.get_str("map_file")
        if not map_file:
            raise SolutionFormatError("missing 'map_file=' line before 'starts=' (needed to find "
                                      "the map)", path, header.line_of("map_file") or starts_no)
        grid = load_map_grid(map_file, path, map_dirs, header.line_of("map_file"))
    rows = RowReader(n, path)
    for no, row in numbered:
        rows.add(row, no)
    plan = None
    if rows.bodies:
        positions, codes = rows.arrays()
        if orientation == MAPF_IR:
            positions = flip_cells(positions, grid.height)
            codes = None if codes is None else FLIP_CODE[codes]
        plan = Plan(positions.astype(np.int32), codes)
    if orientation == MAPF_IR:
        starts, goals = flip_cells(starts, grid.height), flip_cells(goals, grid.height)
    sol = Solution(header, [tuple(c) for c in starts.tolist()], [tuple(c) for c in goals.tolist()],
                   plan, grid, path, orientation, lines.newline, lines.final_newline)
    for name in ("solved", "soc", "lb_soc", "makespan", "lb_makespan", "comp_time", "iterations"):
        getattr(sol, name)  # a bad value fails now, naming its line, not later
    sol.warnings = header.unknown_keys(KNOWN_KEYS, "a solution")
    for warning in sol.warnings:
        warnings.warn(warning, stacklevel=3)
    return sol


def _expect(numbered: Iterator[Tuple[int, str]], want: str, after: str, path: Optional[str],
            previous: int) -> Tuple[int, str]:
    """The next line, which must start with `want` (it follows the line `after`)."""
    what = "expected a '{}' line after '{}'".format(want, after)
    for no, line in numbered:
        if not line.startswith(want):
            raise SolutionFormatError(what, path, no, 1)
        return no, line
    raise SolutionFormatError(what, path, previous, 1)


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
        ends = [flip_cells(e, h) for e in ends]
        if positions is not None:
            positions = flip_cells(positions, h)
            codes = None if codes is None else FLIP_CODE[codes]
    out = header.lines()
    out.append("starts=" + format_cells(ends[0], None))
    out.append("goals=" + format_cells(ends[1], None))
    out.append("solution=")
    if positions is not None:
        for t in range(positions.shape[0]):
            out.append("%d:" % t + format_cells(positions[t], None if codes is None else codes[t]))
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
