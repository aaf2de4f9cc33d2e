"""Replanning every robot from the cut with a MAPF solver (an experiment for issue 28's 20 %).

Today's rule (`execution.reroute`) gives a few held-up robots (or the late
one) new paths by space-time A* around everyone else's predicted schedule.
This experiment asks whether replanning ALL robots from the cut, with the
project's own PIBT or LaCAM (which react to where the late robots stand),
gives a lower executed makespan.

The plan from the cut (base frame, as `reroute_plan`'s): every robot's moves
sent (from its base, `cut.Cut.base`) are its first moves, as soon as the
dependency graph lets them go with no delay (`forecast.earliest_starts`,
ready 0), then the solver's moves to its goal. With `hold` a robot that the
forecast predicts to stand still (a stalled late robot, and who follows it)
also stays where its moves sent leave it for that many steps more. PIBT
(`pibt`): one loop of `PIBTStep.step` with those cells fixed in advance, the
others free from step 1. LaCAM (`lacam`, no hold): every robot stays after
its moves sent until the last of them is done, then a LaCAM plan from there.
The plan is checked (`validate_plan`, no rotation) and the hand-over
(`Engine.adopt`, in the simulator) must accept it.

The rule: look at most once every `every` plan steps, only when some robot
is late by `gap` steps or more and delayed itself (`reroute.behind`,
`reroute.delayed`, today's definition); predict the run as it stands and on
the new plan (the same forecast, the same `ready`: a stalled robot stands as
long again) and hand over when the predicted makespan is lower by `margin`
steps or more.

    .venv/bin/python bench/replan_all.py [SEEDS [FIRST]]   # default 4 seeds from 0
        [--plans arena300,random70] [--configs adg,adg+reroute,adg+replan]
        [--solver pibt|lacam] [--gap K] [--margin M] [--every E] [--hold] [--budget S]
        [--hold-more S] [--hold-chain] [--prio pibt|arrival|alone] [--critical K] [--clear K]

A configuration is a strategy (adg, reorder) and the rerouters asked in turn
(`Either`): e.g. reorder+replan, adg+replan+reroute (the replan first, today's
rule when it finds nothing). The variants tried for issue 28's -20 % (on top
of the replan above; bench/README.md has the figures):

- `--hold-more S`: a robot standing still is held S steps more than forecast;
  `--hold-chain`: a robot whose next move waits for a standing robot stays too.
- `--prio`: PIBT's priorities in a replan (`PRIORITIES`): its own (longer
  distance first), the forecast's predicted arrival on the current plan
  (latest first), or each robot's fixed steps plus its distance left.
- `--critical K`: replan only when a robot predicted within K steps of the
  predicted makespan is late or held up by a late one.
- `--clear K`: in the replan, the robots predicted within K steps of the last
  arrival take, among the moves that bring them closer, one into a cell
  nobody stands in, rather than follow a robot out of its cell (`steer`): a
  robot that follows another waits out every delay of its leader.

Prints per configuration the executed makespan over the planned one (mean
and 95 % interval), the paired change against the first configuration (and
against adg+reroute, if run), replans handed over per run (and refused: a
run with one fails, as one with a collision), the solver's seconds per
replan attempt, and p = 0 (no replan: the ADG's makespan).
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import time
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from fleet_common.delays import parse_delay_model
from fleet_common.execution.cut import cut_of
from fleet_common.execution.engine import Engine
from fleet_common.execution.forecast import earliest_starts, ready_steps, unplaced
from fleet_common.execution.reroute import Reroute, Rerouter, behind, delayed, expected_steps, held_up
from fleet_common.execution.run import RunState
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.plan_loading import load_plan
from fleet_common.planning.cells import NIL
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.lacam import lacam
from fleet_common.planning.pibt import tie_ranks
from fleet_common.planning.pibt_step import PIBTStep
from fleet_common.robot_size import TURTLEBOT2
from fleet_common.validate import validate_plan

from reroute import PLANS, SHARED, interval  # noqa: E402  (bench/reroute.py: the same plans, the same intervals)


def prefix(run: RunState, grid: Grid, base: Sequence[int], ready: Sequence[int], follow: bool,
           hold: bool, more: int = 0, chain: bool = False) -> Tuple[List[int], List[List[int]], List[int]]:
    """Per robot: its grid cell at the cut (its base), its cells at steps 1.. while its moves sent
    are made as soon as possible and everyone else stays (then, with `hold`, kept where they leave
    it for the steps the forecast has it stand still: `more` steps more for a robot standing
    still now; with `chain`, a robot sent nothing whose next move the forecast has waiting for a
    standing robot stays until then too), and the step until which it is fixed."""
    n = run.num_agents
    zero = earliest_starts(run, [0] * n, follow, base)
    table, first = run.table, run.first
    if hold:
        late = earliest_starts(run, ready, follow, base)
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
    # everyone stays until the last move sent is made: a robot may already be in a cell that its
    # moves sent (even completed ones, `cut.Cut.base`) enter later in the plan, so nobody else may
    # go there first (the engine would send them in); then the held robots stay longer
    done = max((len(cells) for cells in fixed), default=0)
    for r, cells in enumerate(fixed):
        until[r] = max(until[r], done)
        cells += [cells[-1] if cells else at[r]] * (until[r] - len(cells))
    return at, fixed, until


def solve_from(grid: Grid, goals: Sequence[Tuple[int, int]], at: Sequence[int], fixed: Sequence[List[int]],
               until: Sequence[int], solver: str, deadline: Deadline, seed: int,
               limit: int, first: Union[None, str, Sequence[float]] = None,
               clear: Optional[float] = None) -> Optional[Plan]:
    """A plan for every robot from cells `at`, its first `until[r]` steps `fixed[r]`; None if the
    solver finds none within `limit` steps or the deadline. PIBT's priorities: `first` (higher
    first; "alone": each robot's fixed steps plus its distance to its goal after them), ties
    broken as PIBT breaks them (longer distance first, then at random); None: PIBT's own.
    `clear`: a robot predicted to arrive within that many steps of the last (fixed steps, then
    its distance) takes, among its moves that bring it closer, one into a cell nobody stands in
    (`steer`) if there is one, rather than follow a robot out of its cell (whose delays it would
    then wait out behind it)."""
    n = len(at)
    stepper = PIBTStep(grid, goals)
    free = stepper.free
    ids = free.index
    q = [int(ids[c]) for c in at]
    fix = [[int(ids[c]) for c in cells] for cells in fixed]
    configs = [q]
    if solver == "lacam":  # everyone stays after its moves sent until the last of them, then LaCAM
        horizon = min(until, default=0)  # hold does not apply: LaCAM starts everyone together
        for t in range(1, horizon + 1):
            q = [f[t - 1] for f in fix]
            configs.append(q)
        w = grid.width
        starts = [(int(free.ids[v]) % w, int(free.ids[v]) // w) for v in q]
        result = lacam(grid, starts, goals, deadline, seed=seed)
        if result.plan is None:
            return None
        tail = result.plan.positions
        head = stepper.plan(configs).positions
        return Plan(np.concatenate([head, tail[1:]], axis=0) if tail.shape[0] > 1 else head)
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


#: PIBT's priorities in a replan: its own (longer distance first), the forecast's predicted
#: arrival on the current plan (latest first), or each robot's fixed steps plus its distance left
PRIORITIES = ("pibt", "arrival", "alone")


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


class ReplanAll(Rerouter):
    """Replans every robot from the cut when one is late and the prediction says it pays."""

    def __init__(self, grid: Grid, solver: str = "pibt", gap: int = 3, margin: float = 2.0,
                 every: float = 5.0, hold: bool = False, budget: float = 2.0, prio: str = "pibt",
                 critical: Optional[float] = None, more: int = 0, chain: bool = False,
                 clear: Optional[float] = None) -> None:
        """`prio`: PIBT's priorities (`PRIORITIES`); `critical`: look only when a robot predicted
        to arrive within that many steps of the predicted makespan is late or held up by a late
        one; `more`, `chain`: see `prefix`; `clear`: see `solve_from`."""
        super().__init__(grid, timed=False)
        self.grid, self.solver, self.gap, self.margin = grid, solver, gap, margin
        self.every, self.hold, self.budget = every, hold, budget
        self.prio, self.critical, self.more, self.chain, self.clear = prio, critical, more, chain, clear
        #: looks with a late robot left alone: nobody near the predicted makespan held up
        self.spared = 0
        self._seed = 0
        #: replan attempts (a solver ran), their seconds, solver failures, plans not paying
        self.tries = 0
        self.solve_seconds = 0.0
        self.failed = 0
        self.unpaid = 0

    def consider(self, engine: Engine, now: float) -> Optional[Reroute]:
        run = engine.run
        steps = run.clock.steps(now)
        if steps < self._next or engine.paused or any(o is not None for o in run.out):
            return None
        self._next = steps + self.every
        began = time.perf_counter()
        self.looks += 1
        try:
            return self._look(engine, now)
        finally:
            self.seconds += time.perf_counter() - began

    def _look(self, engine: Engine, now: float) -> Optional[Reroute]:
        run, follow = engine.run, engine.follow
        if self._expected is None or self._expected[0] is not run:
            self._expected = (run, expected_steps(engine))
        expected = self._expected[1]
        lags = {r: behind(engine, r, now, expected) for r in range(run.num_agents)}
        late = [r for r, lag in lags.items() if lag is not None and lag >= self.gap and delayed(engine, r, now)]
        if not late:
            return None
        cut = cut_of(engine, now)
        base = cut.base
        ready = ready_steps(run, now)
        before = earliest_starts(run, ready, follow, base)
        if unplaced(run, before, base, range(run.num_agents)):
            return None
        if self.critical is not None:
            last = before.makespan - self.critical
            groups = held_up(engine, now, self.gap, expected)
            hit = set(late) | set(groups) | {h for hs in groups.values() for h in hs}
            if not any(before.arrival[r] >= last for r in hit):
                self.spared += 1
                return None
        at, fixed, until = prefix(run, self.grid, base, ready, follow, self.hold, self.more, self.chain)
        table = run.table
        goals = [table.goal(r) for r in range(run.num_agents)]
        self.tries += 1
        t0 = time.perf_counter()
        self._seed += 1
        first: Union[None, str, List[int]] = None
        if self.prio == "arrival":
            first = before.arrival
        elif self.prio == "alone":
            first = "alone"
        plan = solve_from(self.grid, goals, at, fixed, until, self.solver, Deadline(self.budget), self._seed,
                          limit=4 * before.makespan + 200, first=first, clear=self.clear)
        self.solve_seconds += time.perf_counter() - t0
        if plan is None:
            self.failed += 1
            return None
        report = validate_plan(plan, self.grid, strict_rotations=True, max_findings_per_kind=1)
        if not report.ok:
            raise SystemExit("replan_all: a plan that is not valid: {}".format(report.errors[0]))
        new = Engine(plan, engine.strategy.name, follow=follow, step_time=run.clock.step_time,
                     **engine.strategy.settings())
        # the same prediction on the new plan: each robot's first move there is its move `base` here
        shifted = [ready[r] if run.completed[r] == base[r] else 0 for r in range(run.num_agents)]
        after = earliest_starts(new.run, shifted, follow, [0] * run.num_agents)
        if before.makespan - after.makespan < self.margin:
            self.unpaid += 1
            return None
        worst = max(late, key=lambda r: lags[r] or 0)
        self.found += 1
        return Reroute(plan, cut, tuple(range(run.num_agents)), worst, lags[worst],
                       sum(before.arrival) - sum(after.arrival), before.makespan, after.makespan, ())


class Either(Rerouter):
    """Two rerouters in turn: what the first finds, else what the second finds (both keep their own
    pace and counts; a new plan restarts both)."""

    def __init__(self, grid: Grid, first: Rerouter, second: Rerouter) -> None:
        super().__init__(grid, timed=False)
        self.first, self.second = first, second

    def consider(self, engine: Engine, now: float) -> Optional[Reroute]:
        found = self.first.consider(engine, now)
        return found if found is not None else self.second.consider(engine, now)

    def restart(self) -> None:
        self.first.restart()
        self.second.restart()


def parse_config(text: str) -> Tuple[str, Tuple[str, ...]]:
    """"adg", "reorder+replan", "adg+replan+reroute", ...: the strategy, then the rerouters asked
    in that order."""
    strategy, *rerouters = text.split("+")
    if strategy not in ("adg", "reorder") or any(r not in ("reroute", "replan") for r in rerouters) \
            or len(set(rerouters)) < len(rerouters):
        raise SystemExit("replan_all: a configuration is adg or reorder, then +replan and/or +reroute "
                         "(asked in that order), got {!r}".format(text))
    return strategy, tuple(rerouters)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seeds", type=int, nargs="?", default=4)
    parser.add_argument("first", type=int, nargs="?", default=0)
    parser.add_argument("--plans", default="arena300")
    parser.add_argument("--configs", default="adg,adg+reroute,adg+replan")
    parser.add_argument("--solver", default="pibt", choices=("pibt", "lacam"))
    parser.add_argument("--gap", type=int, default=3)
    parser.add_argument("--margin", type=float, default=2.0)
    parser.add_argument("--every", type=float, default=5.0)
    parser.add_argument("--hold", action="store_true")
    parser.add_argument("--budget", type=float, default=2.0)
    parser.add_argument("--prio", default="pibt", choices=PRIORITIES, help="PIBT's priorities in a replan")
    parser.add_argument("--critical", type=float, default=None, metavar="K",
                        help="replan only when a robot predicted within K steps of the makespan is held up")
    parser.add_argument("--hold-more", type=int, default=0, metavar="S",
                        help="with --hold, a robot standing still is held S steps more")
    parser.add_argument("--hold-chain", action="store_true",
                        help="with --hold, a robot whose next move waits for a standing robot stays too")
    parser.add_argument("--clear", type=float, default=None, metavar="K",
                        help="robots predicted within K steps of the last arrival move into empty cells "
                             "rather than follow")
    parser.add_argument("--no-zero", action="store_true", help="skip the p = 0 check")
    args = parser.parse_args()
    configs = args.configs.split(",")
    parsed = {c: parse_config(c) for c in configs}
    model = parse_delay_model("events=bernoulli:0.1:1-5")
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    print("replan: solver {}, gap {}, margin {}, every {}, hold {} (more {}, chain {}), budget {} s, "
          "priorities {}, critical {}, clear {}".format(args.solver, args.gap, args.margin, args.every, args.hold,
                                                        args.hold_more, args.hold_chain, args.budget, args.prio,
                                                        args.critical, args.clear))

    def replan_of(grid: Grid) -> ReplanAll:
        return ReplanAll(grid, args.solver, args.gap, args.margin, args.every, args.hold, args.budget,
                         args.prio, args.critical, args.hold_more, args.hold_chain, args.clear)

    def reroute_of(config: str, grid: Grid) -> Optional[Rerouter]:
        made = [replan_of(grid) if r == "replan" else Rerouter(grid, timed=False) for r in parsed[config][1]]
        if not made:
            return None
        return made[0] if len(made) == 1 else Either(grid, made[0], made[1])

    def replans(rr: Optional[Rerouter]) -> List[ReplanAll]:
        if isinstance(rr, Either):
            return replans(rr.first) + replans(rr.second)
        return [rr] if isinstance(rr, ReplanAll) else []

    for name in args.plans.split(","):
        file, solver, n = PLANS[name]
        loaded = load_plan(SHARED / "instances" / file, n, name, [SHARED / "maps"] + default_map_dirs(),
                           solver=solver, seed=0)
        plan, grid = loaded.plan, loaded.grid
        print("\n{}: {} robots, planned by {}, makespan {}; {} paired seeds from {}, p = 0.1, {}".format(
            name, n, solver, plan.makespan, args.seeds, args.first, TURTLEBOT2.describe()))
        sys.stdout.flush()
        ratio: Dict[str, List[float]] = {c: [] for c in configs}
        count: Dict[str, List[int]] = {c: [] for c in configs}
        refused: Dict[str, List[int]] = {c: [] for c in configs}
        wall: Dict[str, float] = {c: 0.0 for c in configs}
        bound: List[float] = []
        tries = failed = unpaid = spared = 0
        solve_s = 0.0
        for seed in range(args.first, args.first + args.seeds):
            for config in configs:
                began = time.perf_counter()
                rr = reroute_of(config, grid)
                result = simulate(plan, parsed[config][0], model, seed=seed, size=TURTLEBOT2, grid=grid,
                                  reroute=rr)
                wall[config] += time.perf_counter() - began
                assert result.finished and not result.collisions and result.refused == 0, (name, config, seed)
                ratio[config].append(result.metrics.makespan / plan.makespan)
                count[config].append(len(result.reroutes))
                refused[config].append(result.refused)
                if config == configs[0]:
                    bound.append(result.lower_bound / plan.makespan)
                for ra in replans(rr):
                    tries, failed, unpaid = tries + ra.tries, failed + ra.failed, unpaid + ra.unpaid
                    spared += ra.spared
                    solve_s += ra.solve_seconds
            print("  seed {}: {}".format(seed, "; ".join("{} {:.3f} ({})".format(c, ratio[c][-1], count[c][-1])
                                                         for c in configs)))
            sys.stdout.flush()
        base = ratio[configs[0]]
        print("  lower bound / planned makespan: {}".format(interval(bound)))
        other = "adg+reroute" if "adg+reroute" in configs and configs[0] != "adg+reroute" else None
        print("  {:<22} {:>16} {:>20} {:>20} {:>8} {:>8} {:>8}".format(
            "configuration", "executed/planned", "paired vs " + configs[0],
            "paired vs " + other if other else "", "changes", "refused", "s a run"))
        for config in configs:
            change = [100.0 * (x - b) / b for x, b in zip(ratio[config], base)]
            versus = ""
            if other:
                versus = interval([100.0 * (x - b) / b for x, b in zip(ratio[config], ratio[other])]) + "%"
            print("  {:<22} {:>16} {:>18}% {:>20} {:>8.1f} {:>8.1f} {:>8.1f}".format(
                config, interval(ratio[config]), interval(change), versus, float(np.mean(count[config])),
                float(np.mean(refused[config])), wall[config] / args.seeds))
        if tries:
            print("  replan: {} solver runs, {:.0f} ms each; {} found no plan, {} did not pay; {} looks left "
                  "alone (nobody critical held up)".format(tries, 1e3 * solve_s / tries, failed, unpaid, spared))
        if not args.no_zero:
            zero = parse_delay_model("none")
            flat = []
            for config in configs:
                result = simulate(plan, parsed[config][0], zero, seed=0, size=TURTLEBOT2, grid=grid,
                                  reroute=reroute_of(config, grid))
                flat.append("{} {:.3f} ({} changes)".format(config, result.metrics.makespan / plan.makespan,
                                                           len(result.reroutes)))
            print("  p = 0: " + "; ".join(flat))
        sys.stdout.flush()
    print("\nload average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
