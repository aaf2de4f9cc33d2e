"""PIBT as a solver: repeat PIBT steps until every agent is at its goal.

Priorities follow mapf-IR: an agent's priority is the number of steps since it
was last at its goal, ties broken by a larger start-to-goal distance, then at
random (from the seed). An agent stuck behind others soon outranks them. PIBT
is incomplete: it stops at `max_timestep` (the instance's, as mapf-IR does) or
at the deadline ("timeout"); use LaCAM where it cycles. Plans have no rotations unless `rotations` is set
(see `pibt_step`).
"""
from __future__ import annotations

import random
from typing import Callable, List, Optional, Sequence

import numpy as np

from ..formats.instance import DEFAULT_MAX_TIMESTEP
from ..grid import Coord, Grid
from ..plan import Plan
from .cells import NIL
from .deadline import Deadline
from .pibt_step import PIBTStep
from .result import NO_SOLUTION, TIMEOUT, SolveResult, failed, solved

NAME = "pibt"


def tie_ranks(stepper: PIBTStep, q: Sequence[int], rng: random.Random) -> List[int]:
    """Per agent its rank 0..n-1 among all: higher for a longer start-to-goal distance, else random."""
    n = len(q)
    stepper.cover(q)
    keys = [(stepper.dist[i][q[i]], rng.random()) for i in range(n)]
    rank = [0] * n
    for r, i in enumerate(sorted(range(n), key=keys.__getitem__)):
        rank[i] = r
    return rank


def pibt(grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord], deadline: Deadline,
         seed: int = 0, max_timestep: int = DEFAULT_MAX_TIMESTEP, rotations: bool = False) -> SolveResult:
    """Run PIBT until every agent is at its goal, `max_timestep` steps, or the deadline."""
    if [tuple(c) for c in starts] == [tuple(c) for c in goals]:
        return solved(Plan.from_paths([[c] for c in starts]), NAME, timesteps=0)
    return run_steps(PIBTStep(grid, goals, rotations=rotations), starts, deadline, seed, max_timestep, NAME)


def run_steps(stepper: PIBTStep, starts: Sequence[Coord], deadline: Deadline, seed: int, max_timestep: int,
              name: str, after: Optional[Callable[[List[int], List[int]], None]] = None) -> SolveResult:
    """PIBT steps by `stepper` from `starts` until every agent is at its goal; `after(q, next)` may
    change each step's next configuration (keeping it valid) before it is taken."""
    rng = random.Random(seed)
    n = len(starts)
    goal_ids = stepper.goals
    q = stepper.to_ids(starts)
    configs = [q]
    # Priorities as integers, steps since the goal x n + the agent's tie rank: the same order as
    # steps + rank / n, and all distinct, so any sort gives it. As arrays: a step's bookkeeping in
    # Python loops cost as much as the C step (brc202d).
    rank = np.asarray(tie_ranks(stepper, q, rng), dtype=np.int64)
    prio = rank.copy()
    goal_array = np.asarray(goal_ids, dtype=np.int64)
    for t in range(1, max_timestep + 1):
        if deadline.expired():
            return failed(name, TIMEOUT, "time limit reached at step {}".format(t - 1), timesteps=t - 1)
        away = np.fromiter(q, np.int64, n) != goal_array
        prio = np.where(away, prio + n, rank)
        moving = np.flatnonzero(away)
        # highest priority first; agents resting on their goals come last whatever their order:
        # left out, step() lets them stay unless another agent needs their cell
        order = moving[np.argsort(-prio[moving])].tolist()
        nxt = [NIL] * n
        if not stepper.step(q, nxt, order, rng.randrange(1 << 20), moving.tolist()):
            return failed(name, NO_SOLUTION, "PIBT found no next configuration at step {}".format(t))
        if after is not None:
            after(q, nxt)
        q = nxt
        configs.append(q)
        if q == goal_ids:
            return solved(stepper.plan(configs), name, timesteps=t)
    at_goal = sum(1 for a, b in zip(q, goal_ids) if a == b)
    return failed(name, TIMEOUT, "{} of {} agents not at their goals after max_timestep={} steps".format(
        n - at_goal, n, max_timestep), timesteps=max_timestep)
