"""The one plan validator: the oracle for solvers, tests, the CLI and the manager.

`validate_plan` checks a `Plan` against its grid (cells on the map and free,
moves between 4-neighbours or waits), against itself (vertex conflicts: two
agents in one cell at one step; swap conflicts: two agents exchanging cells in
one step) and optionally against the starts, goals, soc and makespan a file
claims. Following moves (an agent entering a cell that another leaves in the
same step) are legal in mapf-IR and reported as information unless
`strict_following` is set. So are rotations (3 or more agents each entering
the cell the next one leaves, a closed chain of following moves; see
`rotations`), unless `strict_rotations` or `strict_following` is set: robots
occupy both cells while they move, so they cannot perform one. Findings and
their kinds are in `findings`.

Everything is vectorised over the (steps, agents) position array, so plans of
thousands of agents and steps check in well under a second; Python loops run
only over the findings.
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence, Tuple

import numpy as np

from .findings import (
    AGENTS, BLOCKED, ERROR, FOLLOWING, GOAL, INFO, JUMP, MAKESPAN, OFF_MAP, ROTATION, SOC, START, SWAP,
    VERTEX, Finding, Report,
)
from .grid import Coord, Grid
from .plan import Plan
from .rotations import cycle_leaders, follow_links, walk_cycle

__all__ = [
    "validate_plan", "Finding", "Report", "ERROR", "INFO", "OFF_MAP", "BLOCKED", "JUMP", "VERTEX", "SWAP",
    "FOLLOWING", "ROTATION", "START", "GOAL", "AGENTS", "SOC", "MAKESPAN",
]

#: Moves as parallel arrays: (step, from cell, to cell, agent).
Movers = Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _cell(pos: np.ndarray) -> Coord:
    return (int(pos[0]), int(pos[1]))


def _identity(c: Coord) -> Coord:
    return c


def validate_plan(plan: Plan, grid: Grid, starts: Optional[Sequence[Coord]] = None,
                  goals: Optional[Sequence[Coord]] = None, soc: Optional[int] = None,
                  makespan: Optional[int] = None, strict_following: bool = False,
                  strict_rotations: bool = False, max_findings_per_kind: int = 1000,
                  show: Callable[[Coord], Coord] = _identity) -> Report:
    """Check `plan` on `grid`; see the module docstring for what is checked.

    Coordinates in messages are base-grid cells passed through `show` (give
    `grid.flip_y` to speak in a mapf-IR file's own coordinates); `Finding.cell`
    is always the base cell. At most `max_findings_per_kind` findings of each
    kind are listed (a broken 1,000-step plan would otherwise bury the first,
    most useful ones); `Report.count` counts them all.
    """
    report = Report()
    add = _Collector(report, max_findings_per_kind, show)
    pos = plan.positions
    n = pos.shape[1]

    if starts is not None and len(starts) != n:
        add(ERROR, AGENTS, "plan has {} agents but {} starts are given".format(n, len(starts)))
    if goals is not None and len(goals) != n:
        add(ERROR, AGENTS, "plan has {} agents but {} goals are given".format(n, len(goals)))

    inside = _check_cells(pos, grid, add)
    _check_moves(pos, add)
    if n > 1:
        ids = np.where(inside, pos[:, :, 1].astype(np.int64) * grid.width + pos[:, :, 0], -1 - np.arange(n))
        _check_vertex(ids, pos, add)
        followers = _check_swaps_and_following(ids, pos, grid, add, strict_following)
        _check_rotations(followers, pos, n, add, strict_rotations or strict_following)
    _check_endpoints(plan, starts, goals, add)

    if makespan is not None and makespan != plan.makespan:
        add(ERROR, MAKESPAN, "header says makespan={} but the plan's makespan is {}".format(makespan, plan.makespan))
    if soc is not None and soc != plan.soc:
        add(ERROR, SOC, "header says soc={} but the plan's sum of costs is {}".format(soc, plan.soc))
    return report


class _Collector:
    def __init__(self, report: Report, limit: int, show: Callable[[Coord], Coord]) -> None:
        self.show = show
        self.report = report
        self.limit = limit
        self.counts = report.counts

    def __call__(self, severity: str, kind: str, message: str, timestep: Optional[int] = None,
                 agents: Tuple[int, ...] = (), cell: Optional[Coord] = None) -> None:
        count = self.counts.get(kind, 0)
        self.counts[kind] = count + 1
        if count < self.limit:
            self.report.findings.append(Finding(severity, kind, message, timestep, agents, cell))
        elif count == self.limit:
            self.report.findings.append(Finding(
                severity, kind, "... more findings of kind '{}' not listed".format(kind)))


def _check_cells(pos: np.ndarray, grid: Grid, add: _Collector) -> np.ndarray:
    xs, ys = pos[:, :, 0], pos[:, :, 1]
    inside = (xs >= 0) & (xs < grid.width) & (ys >= 0) & (ys < grid.height)
    for t, i in zip(*np.nonzero(~inside)):
        add(ERROR, OFF_MAP, "agent {} at t={} is at {} outside the {}x{} map".format(
            i, t, add.show(_cell(pos[t, i])), grid.width, grid.height), int(t), (int(i),), _cell(pos[t, i]))
    free = np.zeros(inside.shape, dtype=bool)
    free[inside] = grid.free[ys[inside], xs[inside]]
    for t, i in zip(*np.nonzero(inside & ~free)):
        add(ERROR, BLOCKED, "agent {} at t={} is on blocked cell {}".format(
            i, t, add.show(_cell(pos[t, i]))), int(t), (int(i),), _cell(pos[t, i]))
    return inside


def _check_moves(pos: np.ndarray, add: _Collector) -> None:
    if pos.shape[0] < 2:
        return
    dist = np.abs(np.diff(pos, axis=0)).sum(axis=2)  # (T, N)
    for t, i in zip(*np.nonzero(dist > 1)):
        add(ERROR, JUMP, "agent {} jumps from {} at t={} to {} at t={} (not a neighbouring cell)".format(
            i, add.show(_cell(pos[t, i])), t, add.show(_cell(pos[t + 1, i])), t + 1), int(t + 1), (int(i),), _cell(pos[t + 1, i]))


def _check_vertex(ids: np.ndarray, pos: np.ndarray, add: _Collector) -> None:
    order = np.argsort(ids, axis=1, kind="stable")
    srt = np.take_along_axis(ids, order, axis=1)
    dup = srt[:, 1:] == srt[:, :-1]
    for t in np.nonzero(dup.any(axis=1))[0]:
        row = ids[t]
        cells, counts = np.unique(row, return_counts=True)
        for c in cells[counts > 1]:
            agents = tuple(int(a) for a in np.nonzero(row == c)[0])
            cell = _cell(pos[t, agents[0]])
            add(ERROR, VERTEX, "vertex conflict at t={}: agents {} all at {}".format(
                t, ", ".join(map(str, agents)), add.show(cell)), int(t), agents, cell)


def _check_swaps_and_following(ids: np.ndarray, pos: np.ndarray, grid: Grid, add: _Collector,
                               strict_following: bool) -> Movers:
    """Report swaps and following moves; return the following moves (step, from, to, agent)."""
    steps, n = ids.shape
    if steps < 2:
        return (np.zeros(0, dtype=np.int64),) * 4
    cells = np.int64(max(grid.num_cells, 1)) + n  # room for the negative off-map ids
    shift = ids + n  # all non-negative
    frm, to = shift[:-1], shift[1:]
    t_idx = np.broadcast_to(np.arange(steps - 1)[:, None], frm.shape)
    moving = frm != to
    tm, fm, om = t_idx[moving], frm[moving], to[moving]
    agent_idx = np.broadcast_to(np.arange(n)[None, :], frm.shape)[moving]

    # swap: someone moves a->b and someone else b->a in the same step
    key = (tm * cells + fm) * cells + om
    rev = (tm * cells + om) * cells + fm
    hit = np.isin(rev, key)
    seen = set()
    for k in np.nonzero(hit)[0]:
        t, i = int(tm[k]), int(agent_idx[k])
        partners = np.nonzero((ids[t + 1] == ids[t][i]) & (ids[t] == ids[t + 1][i]))[0].tolist()
        for j in partners:
            pair = (min(i, j), max(i, j), t)
            if pair in seen:
                continue
            seen.add(pair)
            add(ERROR, SWAP, "swap conflict at t={}->{}: agents {} and {} exchange {} and {}".format(
                t, t + 1, pair[0], pair[1], add.show(_cell(pos[t, pair[0]])),
                add.show(_cell(pos[t, pair[1]]))), t + 1, (pair[0], pair[1]), _cell(pos[t + 1, pair[0]]))

    # following: a mover enters a cell that another agent occupied at the previous step and leaves
    keys = (t_idx * cells + frm).ravel()
    order = np.argsort(keys, kind="stable")  # one cell held by several (a vertex conflict): lowest agent
    at = order[np.minimum(np.searchsorted(keys[order], tm * cells + om), keys.size - 1)]
    enters = (keys[at] == tm * cells + om) & ~hit
    # an occupant that stays is a vertex conflict, reported above
    found = np.nonzero(enters & (to.ravel()[at] != frm.ravel()[at]))[0]
    severity = ERROR if strict_following else INFO
    for k in found[: add.limit + 1].tolist():  # the rest are only counted
        t, i, j = int(tm[k]), int(agent_idx[k]), int(at[k] % n)
        add(severity, FOLLOWING, "following move at t={}->{}: agent {} enters {} as agent {} leaves it".format(
            t, t + 1, i, add.show(_cell(pos[t + 1, i])), j), t + 1, (i, j), _cell(pos[t + 1, i]))
    if found.size:
        add.counts[FOLLOWING] = int(found.size)
    return tm[enters], fm[enters], om[enters], agent_idx[enters]


def _check_rotations(followers: Movers, pos: np.ndarray, n: int, add: _Collector, strict: bool) -> None:
    # only following moves can close a cycle; swaps (the 2-cycles) are not among them
    step, src, dst, agent = followers
    links = follow_links(step, src, dst)
    leaders = cycle_leaders(links, n)
    severity, note = (ERROR, "") if strict else (INFO, "legal in mapf-IR, but ")
    for first in leaders[: add.limit + 1].tolist():  # the rest are only counted
        cycle = walk_cycle(links, first)
        t, agents = int(step[first]), tuple(int(a) for a in agent[cycle])
        cells = ", ".join(str(add.show(_cell(pos[t + 1, a]))) for a in agents)
        add(severity, ROTATION, "rotation at t={}->{}: agents {} each enter the cell the next one leaves "
            "({}); {}robots cannot execute it".format(t, t + 1, ", ".join(map(str, agents)), cells, note),
            t + 1, agents, _cell(pos[t + 1, agents[0]]))
    if leaders.size:
        add.counts[ROTATION] = int(leaders.size)


def _check_endpoints(plan: Plan, starts: Optional[Sequence[Coord]], goals: Optional[Sequence[Coord]],
                     add: _Collector) -> None:
    for label, kind, want, t in (("start", START, starts, 0), ("goal", GOAL, goals, plan.makespan)):
        if want is None:
            continue
        have = plan.positions[t]
        for i, cell in enumerate(want[: plan.num_agents]):
            got = _cell(have[i])
            if got != (int(cell[0]), int(cell[1])):
                add(ERROR, kind, "agent {} {}s at {} but its {} is {}".format(
                    i, "start" if label == "start" else "end", add.show(got), label,
                    add.show((int(cell[0]), int(cell[1])))), t, (i,), got)
