"""When a plan runs on the lab's fleet, and what its agents are then called.

A plan runs on the lab fleet when the robot definitions are named for it (a
`--definitions FILE` option), or, by default, when it is on the embedded lab
map and has no more agents than `robot_definitions.txt` has robots. Agent i
is then the robot on line i of the definitions, and people (the command
line, the console) call it by that robot's id, as the robots and the lab
staff do; elsewhere an agent is its 0-based index in the plan.
"""
from __future__ import annotations

import functools
from pathlib import Path
from typing import List, Optional, Sequence, Union

from ..errors import FleetError
from ..formats.mapfile import read_map
from ..grid import Grid
from ..robots import RobotDefinition, read_robot_definitions
from . import lab_map_path


class FleetTooSmallError(FleetError):
    """A plan with more agents than the named robot definitions have robots."""


@functools.lru_cache(maxsize=1)
def lab_grid() -> Grid:
    """The embedded lab map's grid (read once)."""
    return read_map(str(lab_map_path())).grid


def lab_fleet(grid: Grid, num_agents: int,
              definitions: Union[str, Path, None] = None) -> Optional[List[RobotDefinition]]:
    """The robots a plan of `num_agents` agents on `grid` runs on, agent i on robot i, or None.

    With `definitions` (a file) its robots, FleetTooSmallError if too few;
    otherwise the default definitions' robots when `grid` is the lab map and
    they are enough, else None (a plan for simulated robots, named by index).
    """
    if definitions is not None:
        robots = read_robot_definitions(definitions)
        if num_agents > len(robots):
            raise FleetTooSmallError("the plan has {} agents but {} defines {} robots".format(
                num_agents, definitions, len(robots)))
        return robots[:num_agents]
    if grid != lab_grid():
        return None
    robots = read_robot_definitions()
    return robots[:num_agents] if num_agents <= len(robots) else None


def robot_ids(robots: Optional[Sequence[RobotDefinition]]) -> Optional[List[int]]:
    """Agent index -> robot id, for `RepairResult.describe` and the like (None: no fleet)."""
    return None if robots is None else [r.id for r in robots]
