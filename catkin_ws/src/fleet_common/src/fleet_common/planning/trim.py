"""Fewer moves, the same arrivals: each robot's path trimmed of the moves that do not bring it in sooner.

Why. Solvers that plan for speed (PIBT, LaCAM) let robots wind: on random-32-32-20
LaCAM's 70 robots make 1,814 moves where 1,512 would take each straight to its goal
(robot 26: 35 for 13), and a replan of every robot by PIBT from a cut winds as much.
Under delays every move is a chance to be late (the League of Robot Runners' model
draws a delay per move), and every cell a robot passes is one more order the ADG
keeps against the robots through it: a robot that winds is late more often and holds
more robots up, where in the same time it could have waited. Trimmed, LaCAM's plan
runs 10-12 % sooner under the ADG at p = 0.1, and a replan of every robot trimmed
before its hand-over takes rerouting past a fifth below the ADG (bench/README.md,
"Fewer moves, the same arrivals").

How (`trim_moves`). Robot by robot, the others' paths fixed, those with the most moves
to save first (a second round for what the first opened up): a layered search over
(cell, step), one layer a step up to the robot's arrival step in the plan, gives the
fewest moves to its goal by then, waits costing nothing, through cells that no other
robot holds at that step or at the step before or after, with its goal free of the
others from the step before its arrival on; the earliest arrival among the fewest
moves, the moves as early as they can be (a robot ahead of its schedule has time to
lose). The new path is taken only if it has fewer moves. Only the cells a way of fewer
moves can pass are searched: those whose distance from the start plus the distance to the
goal is under the moves to beat.

Why the plan stays valid, and nobody arrives later. Only the trimmed robot's path
changes, and at every step from `keep` on it is in a cell no other robot is in at
that step, the step before or the step after: so it meets nobody (a vertex conflict),
swaps with nobody (that needs the other in its cell one step later), follows nobody
and is followed by nobody, so it closes no rotation; from its arrival on it stays at
its goal, which nobody enters from the step before. The other robots' paths are as
they were, valid among themselves. Its arrival is at or before the one it had, so a
run without delays ends no later (`Engine`'s executed makespan is the plan's). The
result is checked all the same (`validate_plan`, rotations strict): a plan with any
error is never returned; the one given is, with `Trimmed.refused` saying why.

The run's safety does not rest on any of this: the engine's one rule (nobody enters a
cell before the previous visitor's move out of it is released) keeps robots apart
whatever plan it runs; trimming changes only which plan.

`keep`: plan steps kept as they are, for every robot or per robot (a plan from a cut:
the moves already sent, made first, and any hold that follows them, `reroute_all`);
`reserved`: (cell id, step) pairs, a cell no trimmed robot may be in up to that step (a
plan from a cut: the cell a move sent enters, until its robot is in: it may be on its
way, or there already, ahead of the plan's steps);
`robots`: those that may be trimmed (default: all); `deadline`: no robot is begun once
it has expired (what was trimmed by then is kept: each robot's trim leaves a valid
plan). Cost: per robot trimmed, the others' cells near its way at each step, and one
numpy pass per step over those cells (bench/trim.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..grid import Grid
from ..plan import Plan
from ..validate import validate_plan
from .deadline import Deadline
from .dist_table import dist_array

__all__ = ["Trimmed", "trim_moves", "moves_of"]

_FAR = np.int32(1 << 30)  # no way here


@dataclass(frozen=True)
class Trimmed:
    """The plan trimmed (or the one given, `refused` saying why), its moves before and after, the
    robots whose paths changed, and how many robots with moves to spare the deadline left as
    they were."""

    plan: Plan
    moves_before: int
    moves_after: int
    robots: Tuple[int, ...]
    refused: str = ""
    unreached: int = 0

    def describe(self) -> str:
        """One line, e.g. "trimmed: 156 moves fewer (1,814 to 1,658), 23 robots"."""
        if self.refused:
            return "not trimmed: {}".format(self.refused)
        late = "" if not self.unreached else "; time was up before {} more robot{} with moves to spare".format(
            self.unreached, "" if self.unreached == 1 else "s")
        if not self.robots:
            return ("trimmed: no robot has a move to spare" if not self.unreached else "trimmed: none") + late
        return "trimmed: {:,} moves fewer ({:,} to {:,}), {} robot{}".format(
            self.moves_before - self.moves_after, self.moves_before, self.moves_after, len(self.robots),
            "" if len(self.robots) == 1 else "s") + late


def moves_of(plan: Plan) -> int:
    """Moves in `plan`, of all its robots (`Plan.move_counts`)."""
    return int(plan.move_counts().sum())


def trim_moves(plan: Plan, grid: Grid, robots: Optional[Iterable[int]] = None,
               keep: Union[int, Sequence[int]] = 0, rounds: int = 2,
               deadline: Optional[Deadline] = None, reserved: Sequence[Tuple[int, int]] = ()) -> Trimmed:
    """`plan` with each of `robots` (default: all) on the fewest moves that bring it to its goal
    no later, around the others, its first `keep` steps as they are (see the module docstring)."""
    pos = plan.positions
    n = pos.shape[1]
    kept = [int(keep)] * n if isinstance(keep, int) else [int(k) for k in keep]
    ids = (pos[:, :, 1].astype(np.int64) * grid.width + pos[:, :, 0]).copy()  # (steps, n) cell ids
    before = moves_of(plan)
    chosen = range(n) if robots is None else sorted(set(robots))
    nb = _neighbours(grid)
    changed: List[int] = []
    unreached = 0
    for _ in range(max(rounds, 0)):
        spare = []
        for r in chosen:
            arrival, k = _arrival(ids[:, r]), kept[r]
            if arrival <= k:
                continue
            moves = int((ids[k + 1:, r] != ids[k:-1, r]).sum())
            to_goal = dist_array(grid, grid.coord(int(ids[-1, r])))
            extra = moves - int(to_goal[ids[k, r]])
            if extra > 0:
                spare.append((-extra, r, arrival, moves, to_goal))
        spare.sort(key=lambda s: (s[0], s[1]))
        found = 0
        for done, (_, r, arrival, moves, to_goal) in enumerate(spare):
            if deadline is not None and deadline.expired():
                unreached = len(spare) - done
                break
            k = kept[r]
            path = _fewest_moves(ids, r, k, arrival, moves, to_goal, nb, reserved)
            if path is not None:
                ids[k:k + len(path), r] = path
                ids[k + len(path):, r] = path[-1]
                changed.append(r)
                found += 1
        if not found or unreached:
            break
    trimmed = Plan(np.stack([ids % grid.width, ids // grid.width], axis=2).astype(np.int32))
    robots_changed = tuple(sorted(set(changed)))
    if not robots_changed:
        return Trimmed(plan, before, before, (), unreached=unreached)
    report = validate_plan(trimmed, grid, plan.starts, plan.goals, strict_rotations=True,
                           max_findings_per_kind=1)
    if not report.ok:  # never, by construction (see above); the plan given is kept all the same
        return Trimmed(plan, before, before, (), refused=str(report.errors[0].message))
    return Trimmed(trimmed, before, moves_of(trimmed), robots_changed, unreached=unreached)


def _arrival(path: np.ndarray) -> int:
    """The step from which a path of cell ids stays at its last cell (0: it never moves)."""
    away = np.nonzero(path != path[-1])[0]
    return int(away[-1]) + 1 if away.size else 0


def _neighbours(grid: Grid) -> np.ndarray:
    """(cells + 1, 4) neighbour ids of each cell, `cells` where there is none (cached on the grid)."""
    key = ("trim-neighbours",)
    table = grid.derived.get(key)
    if table is None:
        nc = grid.num_cells
        table = np.full((nc + 1, 4), nc, dtype=np.int64)
        for c, around in enumerate(grid.adjacency()):
            table[c, :len(around)] = around
        table.setflags(write=False)
        grid.derived[key] = table
    return table


def closed(held: np.ndarray) -> np.ndarray:
    """Where the trimmed robot may not be (step, cell): held by another robot at that step, the
    step before or the step after (see the module docstring for why each)."""
    blocked = held.copy()
    blocked[1:] |= held[:-1]
    blocked[:-1] |= held[1:]
    return blocked


def _within(cells: np.ndarray, start: int, to_goal: np.ndarray, most: int, nb: np.ndarray) -> np.ndarray:
    """Of `cells` (ids, each at most `most` moves from the goal), those a way of at most `most`
    moves from `start` to the goal passes: d(start, c) + d(c, goal) <= most, the distance from
    the start counted within `cells` (a way of at most `most` moves never leaves them)."""
    nc = nb.shape[0] - 1
    local = np.full(nc + 1, cells.size, dtype=np.int64)
    local[cells] = np.arange(cells.size)
    around = local[nb[cells]]
    far = np.iinfo(np.int64).max // 2
    dist = np.full(cells.size + 1, far, dtype=np.int64)
    frontier = np.array([local[start]], dtype=np.int64)
    dist[frontier] = 0
    fresh = np.zeros(cells.size + 1, dtype=bool)
    for d in range(1, most + 1):  # breadth first, a level at a time
        fresh[around[frontier].ravel()] = True
        fresh[cells.size] = False
        fresh &= dist == far
        frontier = np.nonzero(fresh)[0]
        if not frontier.size:
            break
        dist[frontier] = d
        fresh[frontier] = False
    keep = dist[:-1] + to_goal[cells] <= most
    return cells[keep]


def _fewest_moves(ids: np.ndarray, r: int, keep: int, arrival: int, moves: int, to_goal: np.ndarray,
                  nb: np.ndarray, reserved: Sequence[Tuple[int, int]] = ()) -> Optional[List[int]]:
    """Robot r's cells from step `keep` to its new arrival, fewer than `moves` moves, or None."""
    steps = ids.shape[0]
    start, goal = int(ids[keep, r]), int(ids[-1, r])
    nc = nb.shape[0] - 1
    # the cells a path of fewer moves may pass: from the start and on to the goal in fewer moves
    near = _within(np.nonzero((to_goal >= 0) & (to_goal < moves))[0], start, to_goal, moves - 1, nb)
    local = np.full(nc + 1, near.size, dtype=np.int64)  # global id -> local id (near.size: not near)
    local[near] = np.arange(near.size)
    around = local[nb[near]]  # (near, 4) local neighbour ids
    others = np.ones(ids.shape[1], dtype=bool)
    others[r] = False
    g = int(local[goal])
    # free_from[t]: nobody else at the goal at step t or later (beyond the plan: at their goals)
    at_goal = (ids[:, others] == goal).any(axis=1)
    free_from = ~np.flip(np.logical_or.accumulate(np.flip(np.append(at_goal, at_goal[-1]))))
    fewest_possible = int(to_goal[start])
    dist = np.full((arrival + 1, near.size + 1), _FAR, dtype=np.int32)
    dist[keep, local[start]] = 0
    t = keep
    while t < arrival:  # a chunk of steps at a time: most robots find their fewest moves early
        end = min(arrival, t + _CHUNK)
        blocked = _blocked(ids, others, local, near.size, t + 1, end, steps, reserved)
        for u in range(t, end):
            here = dist[u]
            best = np.minimum(here[:-1], here[around].min(axis=1) + 1)
            best[blocked[u + 1 - (t + 1)]] = _FAR
            dist[u + 1, :-1] = best
            if dist[u + 1, g] == fewest_possible and free_from[u]:
                arrival = u + 1  # no way has fewer moves, none arrives sooner with as few
                break
        t = end if end < arrival else arrival
    column = dist[keep + 1:arrival + 1, g]
    ok = (column < moves) & free_from[keep:arrival]
    if not ok.any():
        return None
    fewest = int(column[ok].min())
    t_in = keep + 1 + int(np.nonzero(ok & (column == fewest))[0][0])
    # back from the goal: stay wherever the same moves got there a step earlier (moves early)
    path = [g]
    c, d = g, fewest
    for u in range(t_in, keep, -1):
        if dist[u - 1, c] != d:
            c = next(int(p) for p in around[c] if p < near.size and dist[u - 1, p] == d - 1)
            d -= 1
        path.append(c)
    path.reverse()
    return [int(near[c]) for c in path]


#: Plan steps of the others' cells looked at at once (`_fewest_moves`)
_CHUNK = 32


def _blocked(ids: np.ndarray, others: np.ndarray, local: np.ndarray, size: int, first: int, last: int,
             steps: int, reserved: Sequence[Tuple[int, int]]) -> np.ndarray:
    """Rows `first`..`last` (steps) of where the trimmed robot may not be, over the `size` cells near
    its way (local ids; `local` maps a cell id to them, `size` where it is not near): `closed` of
    the others' cells, and the cells `reserved` up to their steps."""
    rows = np.clip(np.arange(first - 1, last + 2), 0, steps - 1)  # beyond the plan: at their goals
    cells = local[ids[rows][:, others]]
    held = np.zeros((rows.size, size + 1), dtype=bool)
    held[np.repeat(np.arange(rows.size), cells.shape[1]), cells.ravel()] = True
    blocked = closed(held)[1:-1, :size]
    for cell, until in reserved:  # nobody else's to enter up to that step
        if local[cell] < size and until >= first:
            blocked[:until - first + 1, local[cell]] = True
    return blocked
