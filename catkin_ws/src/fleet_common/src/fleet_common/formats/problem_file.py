"""A problem or its plan: read either a mapf-IR instance or a solution for its starts and goals.

Several tools accept both (the manager runs a solution or plans an instance;
the virtual fleet puts its robots on the starts of either). A solution has a
`solution=` block (mapf-IR writes it even for a failed run) or `starts=`; an
instance has neither, and its own reader says what is wrong with anything else.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import List, Optional, Sequence, Tuple, Union

from ..grid import Coord, Grid
from .header import read_text
from .instance import Instance, parse_instance
from .solution import Solution, parse_solution

__all__ = ["is_solution_text", "read_problem", "starts_and_goals", "map_file_of"]

_SOLUTION_LINE = re.compile(r"^\s*(solution|starts)\s*=", re.M)
_MAP_FILE = re.compile(r"^map_file=([^\r\n]*)", re.M)


def is_solution_text(text: str) -> bool:
    return _SOLUTION_LINE.search(text) is not None


def read_problem(path: Union[str, Path], map_dirs: Sequence[Path] = (),
                 text: Optional[str] = None, grid: Optional[Grid] = None) -> Union[Instance, Solution]:
    """The instance or solution in `path` (or in `text`, named `path`); on `grid` if given (its
    map_file= is then not looked up)."""
    name = str(path)
    if text is None:
        text = read_text(name)
    dirs = [Path(name).parent, *map_dirs]
    if is_solution_text(text):
        return parse_solution(text, name, dirs, grid)
    return parse_instance(text, name, dirs, grid)


def map_file_of(text: str) -> Optional[str]:
    """The `map_file=` of a problem's text (None if it names none)."""
    found = _MAP_FILE.search(text)
    return found.group(1).strip() if found else None


def starts_and_goals(problem: Union[Instance, Solution]) -> Tuple[List[Coord], List[Coord]]:
    return list(problem.starts), list(problem.goals)
