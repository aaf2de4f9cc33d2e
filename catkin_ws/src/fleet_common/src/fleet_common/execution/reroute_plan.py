"""The new plan of a reroute: every robot from the cut, a chosen few on new paths around the rest.

Given a run, its predicted schedule (`forecast`) and the robots to reroute (R):

1. The kept robots' schedule with R out of their way. Each cell's order of
   robots loses R's visits still to come: a kept robot that was to wait for
   one waits for the visitor before it instead. The cell an R robot is in
   (or will be in once its moves sent are done) is free for its next visitor
   from the step R may start its new path. Moves only leave the orders, so a
   kept robot is never predicted later than before.
2. The kept robots' paths, cell by step, become reservations
   (`planning.reservations`: cells at steps, reversed moves, move chains,
   parking at goals), and so do the targets of moves already sent, from the
   cut until their robot gets there: nobody may pass through such a cell
   before the robot that may already be on its way into it.
3. Each R robot in turn, from where its moves sent leave it and at the
   predicted step they are done, gets the quickest path to its goal by
   space-time A* (`planning.st_astar`) around the reservations; its path
   joins them. R robots not planned yet hold their cells until then.

Together that is one plan for every robot from the cut (base frame), valid by
construction: each path avoids everything reserved before it and the kept
paths keep every cell's order. Its steps are the prediction: the plan that
the hand-over (`handover`) gives the engine, whose dependency graph keeps
each cell's order and none of the timing.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, List, NamedTuple, Optional, Sequence, Set, Tuple

import numpy as np

from ..grid import Grid
from ..plan import Plan
from ..planning.deadline import Deadline
from ..planning.pibt_turns import path_moves_and_turns
from ..planning.reservations import Reservations
from ..planning.st_astar import space_time_astar
from .actions import ActionTable
from .cut import Cut
from .forecast import Schedule, earliest_starts
from .run import FAILED, RunState


class Proposal(NamedTuple):
    """A plan of every robot from the cut, who got a new path, when each is predicted to arrive
    (steps from the cut), and how many more moves and quarter turns each rerouted robot makes
    than before (`turns` may be below 0: a straighter way)."""

    plan: Plan
    agents: Tuple[int, ...]
    arrival: List[int]
    more: Dict[int, int]
    turns: Dict[int, int] = {}


#: Robots named in a reroute's line, the rest counted.
SHOWN = 4


@dataclass(frozen=True)
class Reroute:
    """A new plan from `cut` for every robot, `agents` on new paths because `around`, late by `late`
    steps (None: out), held up `held` (or, `last`, because `agents` were predicted last and a
    shorter way brings them in sooner, `around` late meanwhile: `RerouteRule.critical`);
    predicted `gain` steps sooner in all (arrivals summed), makespans (steps from the cut)
    `before` and `after`."""

    plan: Plan
    cut: Cut
    agents: Tuple[int, ...]
    around: int
    late: Optional[int]
    gain: int
    before: int
    after: int
    held: Tuple[int, ...]
    last: bool = False
    #: `agents` take part again away from their goals, where the plan had left them
    #: (`reroute.way_home`): ways there around the others
    home: bool = False

    def describe(self, name: Callable[[int], object] = str) -> str:
        """One line for the operator, e.g. "robots 3, 7 rerouted around robot 12, late 6 steps: 9
        steps sooner", "robot 12, late 6 steps, rerouted: it held up robots 3, 7; 9 steps
        sooner", or "robot 5, predicted last, rerouted onto a shorter way while robot 12 is late
        6 steps: 9 steps sooner" (`name`: an agent's name, e.g. its robot id)."""
        def robots(rs: Sequence[int]) -> str:  # at most SHOWN named: a reroute of everyone stays one line
            shown = ", ".join(str(name(r)) for r in rs[:SHOWN])
            more = " and {} more".format(len(rs) - SHOWN) if len(rs) > SHOWN else ""
            return "robot{} {}{}".format("s" if len(rs) > 1 else "", shown, more)
        late = "out" if self.late is None else "late {} step{}".format(self.late, "" if self.late == 1 else "s")
        sooner = "{} step{} sooner".format(self.gain, "" if self.gain == 1 else "s")
        if self.gain < 1:  # scope all pays on the makespan: the arrivals' sum may grow
            end = self.before - self.after
            sooner = "the last robot {} step{} sooner".format(end, "" if end == 1 else "s")
        if self.home:
            return "{}, away from {} goal{} in the plan, given {} there around the others".format(
                robots(self.agents), "its" if len(self.agents) == 1 else "their", "s" if len(self.agents) > 1 else "",
                "a way" if len(self.agents) == 1 else "ways")
        if self.last:
            return "{}, predicted last, rerouted onto {} while robot {} is {}: {}".format(
                robots(self.agents), "shorter ways" if len(self.agents) > 1 else "a shorter way",
                name(self.around), late, sooner)
        if self.around not in self.agents:
            return "{} rerouted around robot {}, {}: {}".format(robots(self.agents), name(self.around), late, sooner)
        others = [a for a in self.agents if a != self.around]
        return "robot {}, {}, rerouted{}: {}{}".format(
            name(self.around), late, " with " + robots(others) if others else "",
            "it held up {}; ".format(robots(self.held)) if self.held else "", sooner)


class Maps:
    """What space-time A* needs of one grid: moves per cell, distances to goals (kept)."""

    def __init__(self, grid: Grid) -> None:
        from ..planning.cells import moves
        self.grid = grid
        self.moves = moves(grid)
        self._h: Dict[int, List[int]] = {}

    def distances(self, goal: int) -> List[int]:
        h = self._h.get(goal)
        if h is None:
            from ..planning.dist_table import dist_lists
            h = self._h[goal] = list(dist_lists(self.grid, [self.grid.coord(goal)],
                                                unreachable=self.grid.num_cells + 1)[0])
        return h


def new_start(run: RunState, schedule: Schedule, base: Sequence[int], r: int) -> int:
    """The step robot r can start a new path: when its moves sent are done (0 if it has none)."""
    if run.dispatched[r] == base[r]:
        return 0
    return schedule.start[run.first[r] + run.dispatched[r] - 1] + 1


def behind_out(run: RunState, schedule: Schedule, base: Sequence[int], r: int) -> bool:
    """Whether robot r's moves sent wait, in `schedule`, for a robot that is out: placed behind
    everybody else (`forecast`), at steps that only order them. When r could start a new path is
    then unknown, and a schedule of the others without r (`kept_schedule`) places those steps
    elsewhere: a path from such a step would not fit the others' (big operator sessions, seed 73:
    a robot following a robot that followed a failed one was planned into the cell of its leader,
    which the others' schedule had leaving later)."""
    return schedule.later > 0 and run.dispatched[r] > base[r] and new_start(run, schedule, base, r) > schedule.later


def kept_schedule(run: RunState, schedule: Schedule, ready: Sequence[int], follow: bool,
                  base: Sequence[int], chosen: Sequence[int]) -> Schedule:
    """The schedule of the robots not `chosen`, with the chosen ones out of their way (step 1)."""
    lag = 0 if follow else 1
    mine = set(chosen)
    first, agent, dep0, succ = run.first, run.agent, run.dep, run.succ
    own = {r: first[r] + run.dispatched[r] for r in chosen}  # each one's first move not sent
    dep = list(dep0)
    released: Dict[int, int] = {}
    for r in chosen:
        u = own[r]
        released[u] = new_start(run, schedule, base, r) + lag
        for d in range(first[r] + base[r], u):  # moves sent: they happen as predicted
            released[d] = schedule.start[d] + lag
        for x in range(u + 1, first[r + 1]):
            v = succ[x]
            if v >= 0 and agent[v] not in mine:
                y = dep0[x - 1]  # the move out of the cell before r's visit to it
                while y >= 0 and agent[y] in mine and y > own[agent[y]]:
                    y = dep0[y - 1]
                dep[v] = y
    kept = [r for r in range(run.num_agents) if r not in mine]
    return earliest_starts(run, ready, follow, base, robots=kept, dep=dep, released=released)


def cells_by_step(run: RunState, schedule: Schedule, base: Sequence[int], robots: Sequence[int],
                  steps: int) -> np.ndarray:
    """(steps + 1, len(robots)) table cell ids: where each robot is at each step of `schedule`
    (it moves at the step its move starts and is in the target from the next one)."""
    first = run.first
    out = np.full((steps + 1, len(robots)), -1, dtype=np.int64)
    rows: List[int] = []
    cols: List[int] = []
    cells: List[int] = []
    for j, r in enumerate(robots):
        a0, end = first[r] + base[r], first[r + 1]
        out[0, j] = run.src[a0] if a0 < end else (run.dst[end - 1] if end > first[r] else run.table.start_cell[r])
        for a in range(a0, end):
            s = schedule.start.get(a)
            if s is None or s + 1 > steps:
                break
            rows.append(s + 1)
            cols.append(j)
            cells.append(run.dst[a])
    out[rows, cols] = cells
    index = np.where(out >= 0, np.arange(steps + 1)[:, None], 0)
    np.maximum.accumulate(index, axis=0, out=index)
    return np.take_along_axis(out, index, axis=0)


def grid_ids(table: ActionTable, grid: Grid, cells: np.ndarray) -> np.ndarray:
    """Table cell ids as the grid's cell ids."""
    y, x = np.divmod(cells, table.width)
    return (y + table.y0) * grid.width + x + table.x0


def reserve(res: Reservations, ids: np.ndarray, arrival: np.ndarray, park: bool = True) -> None:
    """Reserve the paths in `ids` ((steps + 1, robots) grid ids) as `Reservations.add_path` would
    each robot's path up to its arrival, all at once."""
    v = res.num_cells
    steps = ids.shape[0] - 1
    t = np.arange(steps + 1)[:, None]
    live = t < arrival[None, :] if park else t <= arrival[None, :]
    keys = (t * v + ids)[live]
    res.vertex.update(keys.tolist())
    if keys.size:
        cells, times = keys % v, keys // v
        last = np.full(v, -1, dtype=np.int64)
        np.maximum.at(last, cells, times)
        for c in np.nonzero(last >= 0)[0].tolist():
            if res.last.get(c, -1) < last[c]:
                res.last[c] = int(last[c])
        res.horizon = max(res.horizon, int(times.max()))
    if steps:
        moved = (ids[1:] != ids[:-1]) & (t[1:] <= arrival[None, :])
        tt = np.broadcast_to(t[1:], moved.shape)[moved]
        frm, to = ids[:-1][moved], ids[1:][moved]
        res.edge.update(((tt * v + to) * v + frm).tolist())  # the reverse move would be a swap
        if tt.size:
            res.horizon = max(res.horizon, int(tt.max()))
        if not res.rotations:
            res.follow.update(zip(((tt - 1) * v + frm).tolist(), to.tolist()))
    if park:
        ends = ids[np.minimum(arrival, steps), np.arange(ids.shape[1])]
        for c, s in zip(ends.tolist(), arrival.tolist()):
            res.park(c, s)


def plan_around(run: RunState, grid: Grid, maps: Maps, schedule: Schedule, ready: Sequence[int],
                follow: bool, base: Sequence[int], chosen: Sequence[int],
                deadline: Deadline, goals: Optional[Dict[int, Tuple[int, int]]] = None) -> Optional[Proposal]:
    """Plan `chosen` (in this order) around the others, from the cut whose moves to start from are
    `base` (`cut.Cut.base`), each to its plan's goal (or to the cell `goals` gives it); None when
    one of them finds no path, or waits for a robot that is out (`behind_out`). Raises
    `st_astar.DeadlineReached` when `deadline` expires."""
    table, n = run.table, run.num_agents
    if any(behind_out(run, schedule, base, r) for r in chosen):
        return None
    kept_s = kept_schedule(run, schedule, ready, follow, base, chosen)
    mine = set(chosen)
    kept = [r for r in range(n) if r not in mine]
    steps = max(kept_s.makespan, 1)
    kept_ids = grid_ids(table, grid, cells_by_step(run, kept_s, base, kept, steps))
    v = grid.num_cells
    res = Reservations(v)
    reserve(res, kept_ids, np.array([kept_s.arrival[r] for r in kept], dtype=np.int64))
    _park_behind_out(run, grid, kept_s, base, kept, kept_ids, res)
    _hold_targets(run, grid, kept_s, schedule, base, chosen, res)
    starts = {r: new_start(run, schedule, base, r) for r in chosen}
    longest = max(starts.values(), default=0)
    before = grid_ids(table, grid, cells_by_step(run, schedule, base, chosen, max(longest, 1)))
    holding: Set[int] = set()
    for j, r in enumerate(chosen):  # moves sent, and the cell they leave it in until it is planned
        s = starts[r]
        reserve(res, before[:s + 1, [j]], np.array([s]), park=False)
        key = (s + 1) * v + int(before[s, j])
        if key not in res.vertex:
            holding.add(key)
            res.vertex.add(key)
    paths: Dict[int, List[int]] = {}
    for j, r in enumerate(chosen):
        s = starts[r]
        here = int(before[s, j])
        key = (s + 1) * v + here
        if key in holding:  # its own hold, not someone else's reservation
            res.vertex.discard(key)
        goal = grid.index((goals or {}).get(r) or table.goal(r))
        path = space_time_astar(maps.moves, here, goal, maps.distances(goal), res, deadline, start_time=s)
        if path is None:
            return None
        full = before[:s, j].tolist() + path
        res.add_path(full)
        paths[r] = full
    arrival = _as_late_as_before(kept_s, schedule, kept)
    more: Dict[int, int] = {}
    turns: Dict[int, int] = {}
    for r, p in paths.items():
        arrival[r] = len(p) - 1
        more[r] = sum(1 for a, b in zip(p, p[1:]) if a != b) - (run.count(r) - base[r])
        came = _came_from(run, grid, r, base[r])
        lead = [came] if came is not None else []  # its heading at the cut
        a0, end = run.first[r] + base[r], run.first[r + 1]
        old = lead + ([grid.index(table.coord(run.src[a0]))] + [grid.index(table.coord(run.dst[a]))
                                                                for a in range(a0, end)] if a0 < end else [])
        turns[r] = quarter_turns(lead + p, grid.width) - quarter_turns(old, grid.width)
    length = max([steps] + [len(p) - 1 for p in paths.values()])
    ids = np.empty((length + 1, n), dtype=np.int64)
    ids[:steps + 1, kept] = kept_ids
    ids[steps + 1:, kept] = kept_ids[-1]
    for r, p in paths.items():
        ids[:len(p), r] = p
        ids[len(p):, r] = p[-1]
    pos = np.stack([ids % grid.width, ids // grid.width], axis=2)
    return Proposal(Plan(pos.astype(np.int32)), tuple(chosen), arrival, more, turns)


def quarter_turns(cells: Sequence[int], width: int) -> int:
    """Quarter turns a robot makes along `cells` (grid indices, waits allowed): 1 at a corner, 2
    where it goes back the way it came."""
    return path_moves_and_turns([(c % width, c // width) for c in cells])[1]


def _came_from(run: RunState, grid: Grid, r: int, k: int) -> Optional[int]:
    """The cell robot r drove from into the start of its move k (its heading then), or None."""
    a = run.first[r] + k - 1
    if k == 0 or a >= run.first[r + 1]:
        return None
    return grid.index(run.table.coord(run.src[a]))


def _as_late_as_before(kept_s: Schedule, schedule: Schedule, kept: Sequence[int]) -> List[int]:
    """The kept robots' predicted arrivals, but those waiting for a robot out as `schedule` had
    them: each schedule places such moves behind its own last move, so the two differ by
    where each schedule ends, not by anything a reroute changes (a gain of that kind made the
    rule reroute a robot again and again: `_park_behind_out`)."""
    arrival = list(kept_s.arrival)
    for r in kept:
        if schedule.later and schedule.arrival[r] >= schedule.later:
            arrival[r] = schedule.arrival[r]
    return arrival


def _park_behind_out(run: RunState, grid: Grid, kept_s: Schedule, base: Sequence[int], kept: Sequence[int],
                     kept_ids: np.ndarray, res: Reservations) -> None:
    """Keep the robots planned anew out of the way of the robots waiting for a robot that is out,
    and of that robot, for good: each stands where it is when its wait begins (`Schedule.later`)
    until the robot out is back, and every cell it then enters is taken from the step the
    schedule places that behind the rest. A path into one of those cells after that step would
    wait for the robot out (big session 257 of the wide operator sessions: robot 11 was rerouted
    round a failed robot through a cell the failed robot was to enter, waited there for it, was
    found held up and rerouted again, every 2.2 s, for ever); a path through it before that step
    goes first, as a robot out cannot."""
    later = kept_s.later
    if not later:
        return
    first, table = run.first, run.table
    for j, r in enumerate(kept):
        waits = [a for a in range(first[r] + base[r], first[r + 1]) if kept_s.start.get(a, 0) >= later]
        if not waits:
            continue
        res.park(int(kept_ids[min(later, kept_ids.shape[0] - 1), j]), later)
        for a in waits:
            res.park(grid.index(table.coord(run.dst[a])), kept_s.start[a] + 1)


def _hold_targets(run: RunState, grid: Grid, kept_s: Schedule, schedule: Schedule, base: Sequence[int],
                  chosen: Sequence[int], res: Reservations) -> None:
    """Reserve the target of every move sent (and of a failed robot's next move: it may be
    halfway, enabled again or not) from the cut until its robot enters it."""
    table = run.table
    mine = set(chosen)
    for r in range(run.num_agents):
        a = run.first[r] + base[r]
        if a >= run.first[r + 1] or not (run.dispatched[r] > base[r] or run.out[r] == FAILED or run.halfway[r]):
            continue
        for b in range(a, run.first[r] + max(run.dispatched[r], base[r] + 1)):
            s = (schedule if r in mine else kept_s).start[b]
            cell = grid.index(table.coord(run.dst[b]))
            for t in range(s + 1):
                res.block_cell(cell, t)
