"""Rerouting every robot: a new plan for the whole fleet from the cut, by PIBT (`RerouteRule` scope "all").

Today's rule (`reroute`, scope "held") gives the few robots a late robot
holds up new paths around everyone else's predicted schedule. Scope "all"
replans every robot from the cut with the project's PIBT, which sees where
the late robots stand; on the 300-robot arena it took the ADG's executed
makespan 23 % down where today's rule took 12 % (bench/README.md, "Replanning
every robot from the cut", measured in bench/replan_all.py, now this module).
Pure: values in (an engine, its grid, the time), a plan out.

When. At most once every `rule.every` plan steps (the driver's pace), when
some robot is late (`reroute.behind` by `rule.gap` steps or more and
`reroute.delayed`: today's definition, so a run without delays never
replans), no robot is out (a robot out has no way to its goal to plan) or
halfway in a move it failed in (`RunState.halfway`: it keeps that move),
and no robot waits, in a move made again from the cut, for a move taken
back (`cut.behind_taken_back`: no plan from that cut fits).

The plan from the cut (`prefix`, then `solve_from`), in the cut's base frame
(`cut.Cut.base`, as `reroute_plan`'s):

1. every robot's moves sent are its first moves, each made as soon as the
   dependency graph lets it go with no delay (`forecast.earliest_starts`,
   ready 0);
2. everyone stays where those moves leave it until the LAST of them, over
   the whole fleet, is made: a robot of real size may already be in a cell
   that a move sent enters later in the old plan (a follower, `Cut.base`),
   so nobody else may be planned into any such cell first. Without this
   step the simulator's judge found two robots at one place;
3. a robot the forecast has standing still (a stalled late robot, its
   followers) stays where its moves sent leave it for as long as the
   forecast has it stand (`hold`): PIBT would otherwise plan others to wait
   for it in vain;
4. from there, PIBT steps (`PIBTStep.step`) to every goal, those cells fixed
   in advance; before each step the robots predicted within `rule.clear`
   steps of the last arrival take, among the moves that bring them closer,
   one into a cell nobody stands in (`steer`), rather than follow a robot out
   of its cell (a robot of real size that follows another waits out every
   delay of its leader).

It pays when the forecast of the rest of the run on the new plan (the same
`ready`: a stalled robot stands as long again) ends `rule.margin` steps or
more before the forecast on the current one; `cost`, `later`, `slack`,
`tries` and `per_move` are the held scope's and play no part here.

Why the hand-over is safe. The plan goes through today's `handover` and
`Engine.adopt` unchanged, and the engine's one rule (nobody enters a cell
before the previous visitor's move out of it is released) is what keeps the
run safe, whatever the plan:

- moves sent are kept: every robot's moves sent and not completed at the
  cut are its first moves in the new plan (step 1), so nothing sent is
  taken back and their completions arrive as the new plan's moves;
- everyone stays until they are made (step 2), so in the new plan's
  dependency graph no move made or sent waits for a move not made: the new
  plan has nobody enter a cell before the robot in it (or driving into it)
  has left;
- the fit check (`Engine.adopt`/`_misfit`) refuses, changing nothing, any
  plan in which a move made or sent waits for a move that is not (a defect
  here would be caught there: `validate_plan` checks the plan itself).

No deadlock. The new plan is a valid MAPF plan (checked: one robot in a
cell at a step, no swaps), so its dependency graph (each cell's visitors in
the plan's order, each robot's moves in order) follows the plan's steps and
has no cycle; the moves sent are placed first in it, and adopt refuses a
plan where one would wait for a move not made. The engine then runs an
acyclic graph, as it runs any plan.

With a live fleet (`fleet_manager.rerouting`) the look runs on a snapshot
while the robots go on. `agents` (those whose remaining path changes, often
most of the fleet) are the robots the hand-over checks: if any of them was
sent a move between the snapshot and the hand-over, the plan is dropped
(`HandoverError`, `Cut.moved`). At scale some robot always would be (300
robots moving, a look of 25-200 ms), so in auto mode the manager sends no
new move while a look is in flight (`Freeze`, at most `reroute.FREEZE`
steps); a robot finishing a move it had been sent at the cut keeps the
plan, which starts it with that move. Robots whose path is unchanged may
move meanwhile: the fit check decides for them.

Cost: two forecasts and one PIBT run of up to `4 x makespan + 200` steps with
the steering (Python) per look: 25 ms at 300 robots on the bench's machine.
"""
from __future__ import annotations

import random
from typing import Callable, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..errors import FleetError
from ..grid import Grid
from ..plan import Plan
from ..planning.cells import NIL
from ..planning.deadline import Deadline
from ..planning.pibt import tie_ranks
from ..planning.pibt_step import PIBTStep
from ..validate import validate_plan
from .cut import behind_taken_back, cut_of
from .engine import Engine
from .forecast import Schedule, earliest_starts, ready_steps, unplaced
from .lateness import behind, held_up, late_robots
from .reroute_plan import Reroute
from .run import RunState
from .trim_cut import trim_from_cut


__all__ = ["prefix", "solve_from", "steer", "sent_made", "changed", "replan", "ReplanError", "PlanFrom"]


class ReplanError(FleetError):
    """A replan's plan that is not valid: a defect of this module, never the run's fault."""


def prefix(run: RunState, grid: Grid, base: Sequence[int], ready: Sequence[int], follow: bool,
           hold: bool = True, more: int = 0, chain: bool = False) -> Tuple[List[int], List[List[int]], List[int]]:
    """Per robot: its grid cell at the cut (its base), its cells at steps 1.. while its moves sent
    are made as soon as possible and everyone else stays (then, with `hold`, kept where they leave
    it for the steps the forecast has it stand still: `more` steps more for a robot standing
    still now; with `chain`, a robot sent nothing whose next move the forecast has waiting for a
    standing robot stays until then too), and the step until which it is fixed."""
    n = run.num_agents
    zero = earliest_starts(run, [0] * n, follow, base)
    table, first = run.table, run.first
    late = earliest_starts(run, ready, follow, base) if hold else zero
    at: List[int] = []
    fixed: List[List[int]] = []
    until: List[int] = []
    for r in range(n):
        a0, sent, end = first[r] + base[r], first[r] + run.dispatched[r], first[r + 1]
        here = run.src[a0] if a0 < end else (run.dst[end - 1] if end > first[r] else table.start_cell[r])
        cell = grid.index(table.coord(here))
        at.append(cell)
        cells: List[int] = []
        for a in range(a0, sent):
            s = zero.start[a]
            cells += [cell] * (s - len(cells))  # waits before the move (steps 1..s)
            cell = grid.index(table.coord(run.dst[a]))
            cells.append(cell)  # in the target from step s + 1
        fixed.append(cells)
        stay = 0
        if hold and sent > a0:
            stay = late.start[sent - 1] + 1 + (more if ready[r] > 0 else 0)
        elif hold and chain and a0 < end and late.start[a0] > zero.start[a0]:
            stay = late.start[a0]  # it follows a robot standing still: it waits where it is, as planned
        until.append(stay)
    done = sent_made(fixed)
    for r, cells in enumerate(fixed):
        until[r] = max(until[r], done)
        cells += [cells[-1] if cells else at[r]] * (until[r] - len(cells))
    return at, fixed, until


def sent_made(fixed: Sequence[List[int]]) -> int:
    """The step by which every robot's moves sent are made (`fixed`: their cells): everyone stays
    until then. A robot may already be in a cell that its moves sent (even completed ones,
    `cut.Cut.base`) enter later in the plan, so nobody else may go there first (the engine would
    send them in); then the held robots stay longer."""
    return max((len(cells) for cells in fixed), default=0)


def steer(stepper: PIBTStep, q: Sequence[int], nxt: Sequence[int], until: Sequence[int], t: int,
          clear: float) -> Optional[List[int]]:
    """`nxt` with the next cells of the robots predicted last (within `clear` steps of the latest
    predicted arrival, not fixed at step t) fixed into cells free in `q` that bring them closer, where
    one exists: they do not follow anyone out of a cell. None when no robot is steered."""
    n = len(q)
    stepper.cover(q)
    dist = stepper.dist
    eta = [max(t - 1, until[i]) + dist[i][q[i] if until[i] < t else nxt[i]] for i in range(n)]
    last = max(eta, default=0) - clear
    standing = set(q)
    taken = {v for v in nxt if v != NIL}
    out: Optional[List[int]] = None
    for i in sorted((i for i in range(n) if eta[i] >= last and until[i] < t and dist[i][q[i]] > 0),
                    key=lambda i: -eta[i]):
        here = dist[i][q[i]]
        closer = [u for u in stepper.adj[q[i]] if dist[i][u] < here]
        free = [u for u in closer if u not in standing and u not in taken]
        if not free:
            continue  # no way closer but behind someone: PIBT decides
        if out is None:
            out = list(nxt)
        out[i] = free[0]
        taken.add(free[0])
    return out


def solve_from(grid: Grid, goals: Sequence[Tuple[int, int]], at: Sequence[int], fixed: Sequence[List[int]],
               until: Sequence[int], deadline: Deadline, seed: int, limit: int,
               first: Union[None, str, Sequence[float]] = None, clear: Optional[float] = None) -> Optional[Plan]:
    """A PIBT plan for every robot from cells `at`, its first `until[r]` steps `fixed[r]`; None if
    none within `limit` steps or the deadline. PIBT's priorities: `first` (higher first; "alone":
    each robot's fixed steps plus its distance to its goal after them), ties broken as PIBT
    breaks them (longer distance first, then at random); None: PIBT's own. `clear`: see `steer`
    (None: no steering)."""
    n = len(at)
    stepper = PIBTStep(grid, goals)
    ids = stepper.free.index
    q = [int(ids[c]) for c in at]
    fix = [[int(ids[c]) for c in cells] for cells in fixed]
    configs = [q]
    rng = random.Random(seed)
    goal_ids = stepper.goals
    ties = tie_ranks(stepper, q, rng)
    if isinstance(first, str):  # "alone"
        ends = [f[-1] if f else v for f, v in zip(fix, q)]
        stepper.cover(ends)
        first = [len(f) + stepper.dist[i][v] for i, (f, v) in enumerate(zip(fix, ends))]
    if first is not None:  # ranks 0..n-1 by `first`, then by PIBT's own ties
        keys, own = first, ties
        ties = [0] * n
        for k, i in enumerate(sorted(range(n), key=lambda i: (keys[i], own[i]))):
            ties[i] = k
    rank = np.asarray(ties, dtype=np.int64)
    prio = rank.copy()
    goal_array = np.asarray(goal_ids, dtype=np.int64)
    horizon = max(until, default=0)
    for t in range(1, limit + 1):
        if deadline.expired():
            return None
        away = np.fromiter(q, np.int64, n) != goal_array
        prio = np.where(away, prio + n, rank)
        moving = np.flatnonzero(away)
        # agents resting on their goals last, but in the order: a fixed move may need their cell
        order = moving[np.argsort(-prio[moving])].tolist() + np.flatnonzero(~away).tolist()
        nxt = [NIL] * n
        for i in range(n):
            if t <= until[i]:
                nxt[i] = fix[i][t - 1]
        salt = rng.randrange(1 << 20)
        steered = steer(stepper, q, nxt, until, t, clear) if clear is not None else None
        if steered is not None and stepper.step(q, steered, order, salt, moving.tolist()):
            nxt = steered
        elif not stepper.step(q, nxt, order, salt, moving.tolist()):
            return None
        q = nxt
        configs.append(q)
        if t >= horizon and q == goal_ids:
            return stepper.plan(configs)
    return None


def changed(run: RunState, base: Sequence[int], plan: Plan) -> Tuple[int, ...]:
    """The robots whose remaining path (cells from their base on, waits left out) differs in `plan`."""
    table, first = run.table, run.first
    out = []
    for r in range(run.num_agents):
        a0, end = first[r] + base[r], first[r + 1]
        here = run.src[a0] if a0 < end else (run.dst[end - 1] if end > first[r] else table.start_cell[r])
        old = [table.coord(here)] + [table.coord(run.dst[a]) for a in range(a0, end)]
        path = plan.path(r)
        new = [c for i, c in enumerate(path) if i == 0 or c != path[i - 1]]
        if [tuple(c) for c in old] != new:
            out.append(r)
    return tuple(out)


#: How a replan's plan is made, for experiments (bench/replan_all.py): (engine, the forecast as it
#: stands, base, ready, seed, deadline) -> a plan from the cut or None. The product's: `prefix`
#: with the hold, then `solve_from` with the steering.
PlanFrom = Callable[[Engine, Schedule, Sequence[int], Sequence[int], int, Deadline], Optional[Plan]]


def replan(engine: Engine, grid: Grid, now: float, gap: int, margin: float, clear: Optional[float],
           deadline: Deadline, expected: Sequence[int], plan_from: Optional[PlanFrom] = None,
           trim: Optional[Deadline] = None) -> Optional[Reroute]:
    """A new plan for every robot from the cut that is predicted to end `margin` steps sooner, as a
    `Reroute`, or None (see the module docstring). `plan_from`: see `PlanFrom`. `trim`: the plan
    is trimmed (`trim_cut`, within that deadline) before it is judged."""
    run, follow = engine.run, engine.follow
    if any(o is not None for o in run.out) or any(run.halfway):
        return None  # a robot out, or halfway in a move it failed in: see the module docstring
    late = late_robots(engine, now, gap, expected)
    if not late:
        return None
    cut = cut_of(engine, now)
    if behind_taken_back(engine, cut, sent=True):
        return None  # no plan from this cut would fit (`cut.behind_taken_back`)
    base = cut.base
    ready = ready_steps(run, now)
    n = run.num_agents
    before = earliest_starts(run, ready, follow, base)
    if unplaced(run, before, base, range(n)):
        return None  # a prediction that cannot be made (nothing to compare with): no change
    seed = int(run.clock.steps(now)) + 1  # the same run, the same plans
    if plan_from is not None:
        plan = plan_from(engine, before, base, ready, seed, deadline)
    else:
        at, fixed, until = prefix(run, grid, base, ready, follow, hold=True)
        goals = [run.table.goal(r) for r in range(n)]
        plan = solve_from(grid, goals, at, fixed, until, deadline, seed, limit=4 * before.makespan + 200,
                          clear=clear)
    if plan is None:
        return None
    report = validate_plan(plan, grid, strict_rotations=True, max_findings_per_kind=1)
    if not report.ok:  # never, by construction (PIBT's steps); refused all the same
        raise ReplanError("a reroute's plan is not valid: {}".format(report.errors[0]))
    if trim is not None:
        plan = trim_from_cut(plan, cut, grid, range(n), run.out, run.halfway, trim)
    new = Engine(plan, engine.strategy.name, follow=follow, step_time=run.clock.step_time,
                 **engine.strategy.settings())
    # the same prediction on the new plan: each robot's first move there is its move `base` here
    shifted = [ready[r] if run.completed[r] == base[r] else 0 for r in range(n)]
    after = earliest_starts(new.run, shifted, follow, [0] * n)
    if before.makespan - after.makespan < margin:
        return None
    agents = changed(run, base, plan)
    if not agents:
        return None
    lags = {r: behind(engine, r, now, expected) or 0 for r in late}
    worst = max(late, key=lambda r: (lags[r], -r))
    held = tuple(held_up(engine, now, gap, expected).get(worst, ()))
    return Reroute(plan, cut, agents, worst, lags[worst], sum(before.arrival) - sum(after.arrival),
                   before.makespan, after.makespan, held)
