"""mapf-IR instance (problem) files: a map, agents, and their starts and goals.

    map_file=arena.map        # key=value lines; unknown keys are kept
    agents=2
    seed=0
    random_problem=0
    max_timestep=500
    max_comp_time=30000
    36,33,5,23                # agent lines `sx,sy,gx,gy`, digits only
    3,17,23,33

Lines starting with `#` are comments, blank lines are allowed. mapf-IR reads
these lines by regular expression and silently drops any it does not
recognise (`12, 7,16,18`, `1,2,3`, surplus agent lines); we raise an
`InstanceFormatError` naming the line and column instead, and a key it does
not know gets a `FormatWarning` naming the nearest known one (`max_titep=`).
With `random_problem=1` mapf-IR draws starts and goals itself: such a file
has no agent lines and `starts`/`goals` stay empty (`is_random`).

Lines are checked as they are read: the header is checked, and the map read,
at the first agent line (mapf-IR, too, reads agent lines only after the map
and the number of agents), and each agent line is checked on the map there,
so a 50 MB file with a bad line 33 is refused after 33 lines.

Coordinates in the file are top-left, y down, unless the header says
`orientation=base`; `starts`/`goals` are always base frame. Agents are
numbered from 0 in messages, as in mapf-IR. Comments, blank lines and line
endings are kept, so writing an unchanged instance reproduces its bytes.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

from ..errors import FormatWarning, InstanceFormatError
from ..grid import Coord, Grid
from ..limits import MAX_AGENTS, excerpt
from .agent_lines import AGENT_LINE, AgentCells, agent_line_error, looks_like_agent_line
from .header import (
    BASE, MAPF_IR, ORIENTATION_KEY, Header, check_orientation, file_orientation,
    header_for_orientation, join_lines, write_text,
)
from .lines import Lines, open_lines, text_lines
from .mapsearch import load_map_grid

_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: Keys mapf-IR understands; each may appear once.
KNOWN_KEYS = ("map_file", "agents", "seed", "random_problem", "max_timestep",
              "max_comp_time", "well_formed")
#: Keys that change how agent lines read: they must come before the first one.
_LAYOUT_KEYS = ("map_file", "agents", "random_problem", ORIENTATION_KEY)
#: mapf-IR's defaults (default_params.hpp), used for fresh files.
DEFAULT_MAX_TIMESTEP = 5000
DEFAULT_MAX_COMP_TIME = 60000

# layout tokens: where header entries and agent lines sit among verbatim lines
_KEY_SLOT = ("key", "")
_AGENT_SLOT = ("agent", "")


class Instance:
    """A MAPF problem; `starts`/`goals` in the base frame, agent i at index i."""

    def __init__(
        self, map_file: str, grid: Grid, starts: List[Coord], goals: List[Coord],
        header: Header, path: Optional[str] = None, orientation: str = MAPF_IR,
        layout: Optional[List[Tuple[str, str]]] = None, newline: str = "\n",
        final_newline: bool = True,
    ) -> None:
        self.map_file = map_file
        self.grid = grid
        self.starts = starts
        self.goals = goals
        self.header = header
        self.path = path
        self.orientation = orientation
        #: file lines in order: header slots, agent slots and verbatim (comment/blank) lines
        self.layout: List[Tuple[str, str]] = list(layout or [])
        self.newline = newline
        self.final_newline = final_newline
        #: what the reader doubted (unknown header keys), also issued as warnings
        self.warnings: List[FormatWarning] = []

    def _int(self, key: str) -> Optional[int]:
        return self.header.get_int(key, InstanceFormatError, minimum=0)

    def _flag(self, key: str) -> Optional[bool]:
        return self.header.get_bool(key, InstanceFormatError)

    @property
    def num_agents(self) -> int:
        return self._int("agents") or 0

    @property
    def seed(self) -> Optional[int]:
        return self._int("seed")

    @property
    def random_problem(self) -> bool:
        return bool(self._flag("random_problem"))

    @property
    def is_random(self) -> bool:
        """mapf-IR draws starts and goals itself; `starts`/`goals` are empty."""
        return self.random_problem

    @property
    def max_timestep(self) -> Optional[int]:
        return self._int("max_timestep")

    @property
    def max_comp_time(self) -> Optional[int]:
        return self._int("max_comp_time")

    @property
    def well_formed(self) -> Optional[bool]:
        return self._flag("well_formed")

    def __repr__(self) -> str:
        return "Instance({!r}, map={!r}, agents={})".format(self.path, self.map_file, self.num_agents)


def parse_instance(
    text: str, path: Optional[str] = None, map_dirs: Optional[Sequence[Path]] = (),
    grid: Optional[Grid] = None,
) -> Instance:
    """Parse instance text. `grid` given: use it instead of reading `map_file`.

    The map is looked for in the file's folder, then `map_dirs`
    (None: `default_map_dirs()`).
    """
    return _parse(text_lines(text, path, InstanceFormatError), path, map_dirs, grid)


def read_instance(path: str, map_dirs: Optional[Sequence[Path]] = ()) -> Instance:
    with open_lines(str(path), InstanceFormatError) as lines:
        return _parse(lines, str(path), map_dirs, None)


def _parse(lines: Lines, path: Optional[str], map_dirs: Optional[Sequence[Path]],
           grid: Optional[Grid]) -> Instance:
    header = Header(path=path)
    layout: List[Tuple[str, str]] = []
    cells: Optional[AgentCells] = None
    agents = 0
    map_file = ""
    for no, line in lines:
        if line.startswith("#") or not line.strip():
            layout.append(("text", line))
            continue
        m = AGENT_LINE.fullmatch(line)
        if m is not None:
            if cells is None:  # the first agent line: the header is complete
                map_file, agents = _check_header(header, no, path)
                orientation = file_orientation(header, InstanceFormatError)
                if grid is None:
                    grid = load_map_grid(map_file, path, map_dirs, header.line_of("map_file"))
                cells = AgentCells(grid, orientation, path)
            if len(cells.starts) == agents:
                raise InstanceFormatError("more agent lines than agents={} (line {})".format(
                    agents, header.line_of("agents")), path, no)
            cells.add(no, m)
            layout.append(_AGENT_SLOT)
            continue
        key, eq, value = line.partition("=")
        if eq and _KEY.fullmatch(key):
            if key in KNOWN_KEYS and key in header:
                raise InstanceFormatError("'{}=' given twice (first on line {})".format(
                    key, header.line_of(key)), path, no)
            if cells is not None and key in _LAYOUT_KEYS:
                raise InstanceFormatError(
                    "'{}=' after the agent lines; it says how they read, so it must come before "
                    "them".format(key), path, no)
            header.append(key, value, no)
            layout.append(_KEY_SLOT)
            continue
        if looks_like_agent_line(line):
            raise agent_line_error(line, path, no)
        raise InstanceFormatError(
            "expected a comment ('# ...'), a 'key=value' line or an agent line 'sx,sy,gx,gy'; "
            "got {}".format(excerpt(line)), path, no, 1)

    if cells is None:  # no agent lines: a random problem, or an error
        map_file, agents = _check_header(header, None, path)
        if grid is None:
            grid = load_map_grid(map_file, path, map_dirs, header.line_of("map_file"))
        cells = AgentCells(grid, file_orientation(header, InstanceFormatError), path)
    _check_values(header)
    if len(cells.starts) < agents and not header.get_bool("random_problem", InstanceFormatError):
        raise InstanceFormatError(
            "agents={} but {} agent line(s) 'sx,sy,gx,gy' follow".format(agents, len(cells.starts)),
            path, header.line_of("agents"))
    inst = Instance(map_file, cells.grid, cells.starts, cells.goals, header, path,
                    file_orientation(header, InstanceFormatError), layout, lines.newline,
                    lines.final_newline)
    inst.warnings = header.unknown_keys(KNOWN_KEYS + (ORIENTATION_KEY,), "an instance")
    for warning in inst.warnings:
        warnings.warn(warning, stacklevel=3)
    return inst


def _check_header(header: Header, first_agent_line: Optional[int],
                  path: Optional[str]) -> Tuple[str, int]:
    """(map_file, agents) once the header is complete: at the first agent line (its number)
    or at the end of a file without one (None)."""
    where = 1 if first_agent_line is None else first_agent_line
    for key, what in (("map_file", "the map to plan on"), ("agents", "the number of agents")):
        if key not in header:
            if first_agent_line is None:
                raise InstanceFormatError("missing '{}=' line ({})".format(key, what), path, 1)
            raise InstanceFormatError(
                "agent line before '{}=' ({}); mapf-IR reads agent lines only after it knows "
                "the map and the number of agents".format(key, what), path, where)
    map_file = header.get_str("map_file") or ""
    if not map_file:
        raise InstanceFormatError("'map_file=' is empty; expected a .map file name",
                                  path, header.line_of("map_file"))
    agents = header.get_int("agents", InstanceFormatError, minimum=1) or 0
    if agents > MAX_AGENTS:
        raise InstanceFormatError("agents={:,}: more than the {:,} agents FleetControl "
                                  "reads".format(agents, MAX_AGENTS), path, header.line_of("agents"))
    _check_values(header)
    if first_agent_line is not None and header.get_bool("random_problem", InstanceFormatError):
        raise InstanceFormatError(
            "agent line with random_problem=1 (line {}); mapf-IR ignores it and draws "
            "random starts and goals: remove the agent lines or set random_problem=0".format(
                header.line_of("random_problem")), path, first_agent_line)
    return map_file, agents


def _check_values(header: Header) -> None:
    """The known keys' values (a bad one fails naming its line)."""
    for key in ("seed", "max_timestep", "max_comp_time"):
        header.get_int(key, InstanceFormatError, minimum=0)
    header.get_bool("random_problem", InstanceFormatError)
    header.get_bool("well_formed", InstanceFormatError)


def format_instance(inst: Instance, orientation: Optional[str] = None) -> str:
    """The file text; `orientation` None keeps the file's own, else 'mapf-ir' or 'base'."""
    target = check_orientation(orientation, inst.orientation)
    header = header_for_orientation(inst.header, target)
    if header.get_str("map_file") != inst.map_file:
        header.set("map_file", inst.map_file)
    if not inst.random_problem:
        header.set("agents", len(inst.starts))
    h = inst.grid.height
    agents = []
    for (sx, sy), (gx, gy) in zip(inst.starts, inst.goals):
        if target == MAPF_IR:
            sy, gy = h - 1 - sy, h - 1 - gy
        agents.append("{},{},{},{}".format(sx, sy, gx, gy))
    entries = header.lines()
    out: List[str] = []
    ei = ai = 0
    for kind, text in inst.layout:
        if kind == "key":
            if ei < len(entries):
                out.append(entries[ei])
                ei += 1
        elif kind == "agent":
            # header entries added since reading go before the first agent line
            out.extend(entries[ei:])
            ei = len(entries)
            if ai < len(agents):
                out.append(agents[ai])
                ai += 1
        else:
            out.append(text)
    out.extend(entries[ei:])
    out.extend(agents[ai:])
    return join_lines(out, inst.newline, inst.final_newline)


def write_instance(inst: Instance, path: str, orientation: Optional[str] = None) -> None:
    write_text(str(path), format_instance(inst, orientation))


def make_instance(grid: Grid, map_file: str, starts: Sequence[Coord], goals: Sequence[Coord],
                  **header_values: object) -> Instance:
    """A fresh instance in mapf-IR's `makeScenFile` layout (base-frame cells)."""
    starts = [(int(x), int(y)) for x, y in starts]
    goals = [(int(x), int(y)) for x, y in goals]
    if len(starts) != len(goals):
        raise ValueError("{} starts but {} goals".format(len(starts), len(goals)))
    for what, cells in (("start", starts), ("goal", goals)):
        for i, c in enumerate(cells):
            if not grid.is_free(c):
                raise ValueError("{} {} of agent {} is not a free cell of the map".format(what, c, i))
        if len(set(cells)) != len(cells):
            raise ValueError("two agents share a {}".format(what))
    values: Dict[str, object] = {
        "map_file": map_file, "agents": len(starts), "seed": 0, "random_problem": 0,
        "max_timestep": DEFAULT_MAX_TIMESTEP, "max_comp_time": DEFAULT_MAX_COMP_TIME,
    }
    values.update(header_values)
    header = Header()
    for key, value in values.items():
        header.append(key, int(value) if isinstance(value, bool) else value)
    orientation = BASE if str(values.get("orientation", "")) == BASE else MAPF_IR
    return Instance(map_file, grid, starts, goals, header, None, orientation)
