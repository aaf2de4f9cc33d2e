"""Checks a MAPF problem before any search, so that solvers only see solvable-looking input.

A problem is a grid, one start and one goal per agent (base frame). Rejected,
with the agent and the cell named: different numbers of starts and goals,
cells off the map or blocked, two agents starting (or ending) on one cell, and
a goal in another connected component than its start (unreachable whatever
the others do). Problems that pass may still have no solution (a robot parked
on its goal in the only corridor); that is the solvers' to report.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Sequence

from ..errors import FleetError
from ..grid import Coord, Grid
from .components import component_labels

#: At most this many problems are named in one message; the rest are counted.
MAX_LISTED = 5
#: Largest goals x cells the built-in solvers accept: they keep one uint16
#: distance table per goal over the whole map (2 bytes an entry, see dist_table),
#: so this is about 3.2 GB of tables; the search itself needs tens of MB more.
MAX_TABLE_ENTRIES = 1_600_000_000
#: Bytes a distance-table entry takes.
TABLE_ENTRY_BYTES = 2


class InvalidProblemError(FleetError, ValueError):
    """Starts and goals that no solver should be given; `problems` lists them all."""

    def __init__(self, problems: Sequence[str]) -> None:
        self.problems = list(problems)
        shown = "; ".join(self.problems[:MAX_LISTED])
        more = len(self.problems) - MAX_LISTED
        if more > 0:
            shown += "; and {} more".format(more)
        super().__init__(shown)


class ProblemTooLargeError(FleetError):
    """More agents x cells than the built-in solvers' distance tables fit in memory."""


def check_size(grid: Grid, num_agents: int, free_cells_only: bool = False) -> None:
    """Refuse, before allocating anything, problems whose distance tables would not fit.

    `num_agents` counts distinct goals: agents sharing a goal share its table.
    `free_cells_only`: the solver's tables cover the free cells only (PIBT and
    LaCAM, see `goal_distances`), not every cell of the map.
    """
    free = int(grid.free.sum())
    goals = min(num_agents, free)
    entries = goals * ((free + 1) if free_cells_only else grid.num_cells)
    if entries > MAX_TABLE_ENTRIES:
        raise ProblemTooLargeError(
            "{} agents on a {}x{} map need {} million distance-table entries (about {:.1f} GB of "
            "memory), more than the built-in solvers allow ({} million, {:.1f} GB); run a mapf-IR "
            "solver for instances this large".format(
                num_agents, grid.width, grid.height, entries // 1_000_000,
                entries * TABLE_ENTRY_BYTES / 1e9, MAX_TABLE_ENTRIES // 1_000_000,
                MAX_TABLE_ENTRIES * TABLE_ENTRY_BYTES / 1e9))


def cell_problem(grid: Grid, cell: Coord, what: str, agent: int) -> Optional[str]:
    """Why `cell` cannot hold agent `agent`'s `what` ("start", "goal"), or None."""
    if not grid.in_bounds(cell):
        return "agent {}: {} {} is outside the {}x{} map".format(
            agent, what, _fmt(cell), grid.width, grid.height)
    if not grid.is_free(cell):
        return "agent {}: {} {} is on a blocked cell".format(agent, what, _fmt(cell))
    return None


def duplicate_problems(cells: Sequence[Coord], what: str,
                       agents: Optional[Sequence[int]] = None) -> List[str]:
    """One message per agent whose cell an earlier agent already has.

    `agents` names the agent of each cell (default: its position in `cells`).
    """
    names = list(range(len(cells))) if agents is None else list(agents)
    first: Dict[Coord, int] = {}
    out: List[str] = []
    for k, c in enumerate(cells):
        key = (int(c[0]), int(c[1]))
        if key in first:
            out.append("agents {} and {} have the same {} {}".format(first[key], names[k], what, _fmt(key)))
        else:
            first[key] = names[k]
    return out


def check_problem(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord]) -> None:
    """Raise `InvalidProblemError` naming every agent whose start or goal is unusable."""
    if len(starts) != len(goals):
        raise InvalidProblemError(["{} starts but {} goals: every agent needs both".format(
            len(starts), len(goals))])
    problems: List[str] = []
    placed = True
    for i, (s, g) in enumerate(zip(starts, goals)):
        for cell, what in ((s, "start"), (g, "goal")):
            msg = cell_problem(grid, cell, what, i)
            if msg is not None:
                problems.append(msg)
                placed = False
    problems += duplicate_problems(starts, "start")
    problems += duplicate_problems(goals, "goal")
    if placed:
        problems += unreachable_problems(grid, starts, goals)
    if problems:
        raise InvalidProblemError(problems)


def unreachable_problems(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord]) -> List[str]:
    labels = component_labels(grid)
    w = grid.width
    out = []
    for i, (s, g) in enumerate(zip(starts, goals)):
        if labels[s[1] * w + s[0]] != labels[g[1] * w + g[0]]:
            out.append("agent {}: goal {} cannot be reached from start {} (no free path on the map)".format(
                i, _fmt(g), _fmt(s)))
    return out


def _fmt(c: Coord) -> str:
    return "({}, {})".format(int(c[0]), int(c[1]))
