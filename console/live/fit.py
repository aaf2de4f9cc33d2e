"""Does a plan or an instance fit the fleet a manager runs? One clear reason when it does not.

Before the console sends a plan to the manager (`load`), it checks what the
manager will check, against the run setup the manager sent: the same map,
cell for cell; one agent per robot; and which robot takes which agent (plan
agent i runs on the i-th robot of the fleet). The manager decides (it checks
again and may refuse); this only saves the operator a round trip and words
the answer. Pure.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Tuple

from fleet_common.control import RunSetup
from fleet_common.grid import Grid

__all__ = ["Fit", "fit"]


@dataclass(frozen=True)
class Fit:
    ok: bool
    reason: str                      # why not, or what fits: "5 agents on lab.map; agent 0 -> robot 1, ..."
    robots: Tuple[int, ...] = ()     # the robot that takes each agent


def _map_words(name: str, grid: Grid) -> str:
    return "{} ({} x {})".format(name or "its map", grid.width, grid.height)


def fit(name: str, grid: Grid, agents: int, setup: RunSetup) -> Fit:
    """Whether `agents` agents on `grid` (a file called `name`) can run on the fleet of `setup`."""
    fleet_grid = Grid.from_rows(list(setup.rows), blocked="@", name=setup.map_name)
    if grid != fleet_grid:
        return Fit(False, "{} is for map {}; this fleet runs on {}: open a plan for that map".format(
            name, _map_words(grid.name, grid), _map_words(setup.map_name, fleet_grid)))
    robots = tuple(setup.plan.robots)
    if agents != len(robots):
        return Fit(False, "{} has {} agent{} but this fleet has {} robot{} (agent i runs on the i-th "
                   "robot): open a plan for {} agents".format(
                       name, agents, "s" if agents != 1 else "", len(robots), "s" if len(robots) != 1 else "",
                       len(robots)))
    pairs: List[str] = ["agent {} -> robot {}".format(i, rid) for i, rid in enumerate(robots[:6])]
    if len(robots) > 6:
        pairs.append("... agent {} -> robot {}".format(len(robots) - 1, robots[-1]))
    return Fit(True, "{} agents on {}; {}".format(agents, _map_words(setup.map_name, fleet_grid),
                                                  ", ".join(pairs)), robots)
