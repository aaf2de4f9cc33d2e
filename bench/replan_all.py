"""Replanning every robot from the cut with a MAPF solver (an experiment for issue 28's 20 %).

Today's rule (`execution.reroute`) gives a few held-up robots (or the late
one) new paths by space-time A* around everyone else's predicted schedule.
This experiment asks whether replanning ALL robots from the cut, with the
project's own PIBT or LaCAM (which react to where the late robots stand),
gives a lower executed makespan. Its chosen setting (`--gap 1 --margin 1
--every 2 --hold --clear 20`) is now the product's `RerouteRule(scope="all")`
(`execution.reroute_all`: `prefix`, `solve_from`, `steer`, `replan`); this
script keeps the variants around it (LaCAM, priorities, `--critical`, the
hold's variants), run through the product's `replan` with their own plan.

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
import sys
import time
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from fleet_common.delays import parse_delay_model
from fleet_common.execution.engine import Engine
from fleet_common.execution.forecast import Schedule
from fleet_common.execution.reroute import (Reroute, RerouteRule, Rerouter, behind, delayed, expected_steps,
                                            held_up)
from fleet_common.execution.reroute_all import prefix, replan, solve_from
from fleet_common.execution.run import RunState
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.plan_loading import load_plan
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.lacam import lacam
from fleet_common.planning.pibt_step import PIBTStep
from fleet_common.robot_size import TURTLEBOT2

from reroute import PLANS, SHARED, interval  # noqa: E402  (bench/reroute.py: the same plans, the same intervals)


def solve_lacam(grid: Grid, goals: Sequence[Tuple[int, int]], at: Sequence[int], fixed: Sequence[List[int]],
                until: Sequence[int], deadline: Deadline, seed: int) -> Optional[Plan]:
    """Every robot stays after its moves sent until the last of them (`prefix`, no hold: LaCAM
    starts everyone together), then a LaCAM plan from there; None if LaCAM finds none in time."""
    stepper = PIBTStep(grid, goals)
    free = stepper.free
    ids = free.index
    q = [int(ids[c]) for c in at]
    fix = [[int(ids[c]) for c in cells] for cells in fixed]
    configs = [q]
    for t in range(1, min(until, default=0) + 1):
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


#: PIBT's priorities in a replan: its own (longer distance first), the forecast's predicted
#: arrival on the current plan (latest first), or each robot's fixed steps plus its distance left
PRIORITIES = ("pibt", "arrival", "alone")


class ReplanAll(Rerouter):
    """The product's scope "all" (`reroute_all.replan`, through `Rerouter`), with the experiment's
    variants: with none set (`solver` pibt, `hold`, `prio` pibt, no `critical`, `more` 0, no
    `chain`) it is exactly `Rerouter(grid, RerouteRule(scope="all", ...), timed=False)`."""

    def __init__(self, grid: Grid, solver: str = "pibt", gap: int = 3, margin: float = 2.0,
                 every: float = 5.0, hold: bool = False, budget: float = 2.0, prio: str = "pibt",
                 critical: Optional[float] = None, more: int = 0, chain: bool = False,
                 clear: Optional[float] = None) -> None:
        """`prio`: PIBT's priorities (`PRIORITIES`); `critical`: look only when a robot predicted
        to arrive within that many steps of the predicted makespan is late or held up by a late
        one; `more`, `chain`: see `reroute_all.prefix`; `clear`: see `reroute_all.steer`;
        `budget`: LaCAM's seconds (PIBT runs to the end, as the simulator's rerouters do)."""
        super().__init__(grid, RerouteRule(scope="all", gap=gap, margin=margin, every=every, clear=clear),
                         timed=False)
        self.grid, self.solver, self.hold, self.budget = grid, solver, hold, budget
        self.prio, self.critical, self.more, self.chain = prio, critical, more, chain
        self.variant = (solver, hold, prio, critical, more, chain) != ("pibt", True, "pibt", None, 0, False)
        #: looks with a late robot left alone: nobody near the predicted makespan held up
        self.spared = 0
        #: replan attempts (a solver ran), their seconds, solver failures
        self.tries = 0
        self.solve_seconds = 0.0
        self.failed = 0
        self._now = 0.0

    @property
    def unpaid(self) -> int:
        """Plans found that did not pay (or changed nobody's path)."""
        return self.tries - self.failed - self.found

    def consider(self, engine: Engine, now: float) -> Optional[Reroute]:
        steps = engine.run.clock.steps(now)
        if steps < self._next or engine.paused:
            return None
        self._next = steps + self.rule.pace
        began = time.perf_counter()
        self._now = now
        if self._expected is None or self._expected[0] is not engine.run:
            self._expected = (engine.run, expected_steps(engine))
        found = replan(engine, self.grid, now, self.rule.gap, self.rule.margin, self.rule.clear, Deadline(None),
                       self._expected[1], self._plan_from if self.variant else self._counted)
        self.looks += 1
        self.seconds += time.perf_counter() - began
        self.found += found is not None
        return found

    def _counted(self, engine: Engine, before: Schedule, base: Sequence[int], ready: Sequence[int], seed: int,
                 deadline: Deadline) -> Optional[Plan]:
        """The product's plan (`prefix` held, `solve_from` steered), counted."""
        run = engine.run
        at, fixed, until = prefix(run, self.grid, base, ready, engine.follow, hold=True)
        return self._solve(lambda: solve_from(self.grid, goals_of(run), at, fixed, until, deadline, seed,
                                              limit=4 * before.makespan + 200, clear=self.rule.clear))

    def _plan_from(self, engine: Engine, before: Schedule, base: Sequence[int], ready: Sequence[int], seed: int,
                   deadline: Deadline) -> Optional[Plan]:
        """The experiment's variants of the plan from the cut."""
        run = engine.run
        if self.critical is not None:
            last = before.makespan - self.critical
            expected = self._expected[1] if self._expected else expected_steps(engine)
            t = self._now  # the look's time
            groups = held_up(engine, t, self.rule.gap, expected)
            late = [r for r in range(run.num_agents) if (behind(engine, r, t, expected) or 0) >= self.rule.gap
                    and delayed(engine, r, t)]
            hit = set(late) | set(groups) | {h for hs in groups.values() for h in hs}
            if not any(before.arrival[r] >= last for r in hit):
                self.spared += 1
                return None
        at, fixed, until = prefix(run, self.grid, base, ready, engine.follow, self.hold, self.more, self.chain)
        if self.solver == "lacam":
            return self._solve(lambda: solve_lacam(self.grid, goals_of(run), at, fixed, until,
                                                   Deadline(self.budget), seed))
        first: Union[None, str, List[int]] = None
        if self.prio == "arrival":
            first = before.arrival
        elif self.prio == "alone":
            first = "alone"
        return self._solve(lambda: solve_from(self.grid, goals_of(run), at, fixed, until, deadline, seed,
                                              limit=4 * before.makespan + 200, first=first,
                                              clear=self.rule.clear))

    def _solve(self, solve: Callable[[], Optional[Plan]]) -> Optional[Plan]:
        self.tries += 1
        t0 = time.perf_counter()
        plan = solve()
        self.solve_seconds += time.perf_counter() - t0
        self.failed += plan is None
        return plan


def goals_of(run: RunState) -> List[Tuple[int, int]]:
    return [run.table.goal(r) for r in range(run.num_agents)]


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
