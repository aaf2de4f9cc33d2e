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

from ..grid import Coord
from .header import read_text
from .instance import Instance, parse_instance
from .solution import Solution, parse_solution

__all__ = ["is_solution_text", "read_problem", "starts_and_goals"]

_SOLUTION_LINE = re.compile(r"^\s*(solution|starts)\s*=", re.M)


def is_solution_text(text: str) -> bool:
    return _SOLUTION_LINE.search(text) is not None


def read_problem(path: Union[str, Path], map_dirs: Sequence[Path] = (),
                 text: Optional[str] = None) -> Union[Instance, Solution]:
    """The instance or solution in `path` (or in `text`, named `path`)."""
    name = str(path)
    if text is None:
        text = read_text(name)
    dirs = [Path(name).parent, *map_dirs]
    return parse_solution(text, name, dirs) if is_solution_text(text) else parse_instance(text, name, dirs)


def starts_and_goals(problem: Union[Instance, Solution]) -> Tuple[List[Coord], List[Coord]]:
    return list(problem.starts), list(problem.goals)
