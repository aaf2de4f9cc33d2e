"""Rerouting held-up robots (issue 28, deliverable 2): what it gains, what a decision costs.

The evaluation's two plans (random-32-32-20, 70 agents, planned by LaCAM; the
300-robot arena, planned by PIBT, as experiments/evaluation.yaml plans them),
robots of the lab's size, LoRR delay events p = 0.1 of 1-5 moves, paired
seeds (every configuration meets the same delays): adg, adg + reroute,
reorder, reorder + reroute. Prints per configuration the executed makespan
over the planned one (mean and 95 % interval, 1.96 standard errors), the
paired change against adg, the lower bound (every robot alone with its own
delays) over the planned makespan, the bound no execution can beat (every
robot alone on a shortest path, its k-th move meeting its k-th move's fate
as in the simulator, whatever the path), reroutes per run and robots moved per
run, and the rule's cost: ms per look (a decision: who is held up, the
prediction, the planning when someone is) and ms per look that found a
reroute (a replan), plus the hand-over. Then p = 0: every configuration's
makespan, and the number of reroutes (none).

    .venv/bin/python bench/reroute.py [SEEDS [FIRST]]     # default 10 seeds from 10
        [--plans random70,arena300] [--configs adg,adg+reroute,reorder,reorder+reroute]
                                                           # +trim after any: the plan and every reroute trimmed
                                                           # +reroute-all: RerouteRule(scope="all")
        [--rule KEY=VALUE ...]                             # a RerouteRule's settings, e.g. slack=none
        [--baseline KEY=VALUE ...]                         # also adg + reroute by this rule, compared

`--baseline` adds a configuration, adg + reroute by a second rule (settings
as for `--rule`; none given: the defaults), and each seed's change from it
to adg + reroute by `--rule`: two rules compared on the same delays.

The seeds start at 10 by default: the rule's default settings were chosen on
seeds 0-9 (random70) and 0-3 (arena300; 0-9 for `slack`).
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

from fleet_common.delays import parse_delay_model
from fleet_common.execution import Engine
from fleet_common.execution.reroute import RerouteRule
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.plan_loading import load_plan
from fleet_common.planning.dist_table import dist_array
from fleet_common.robot_size import TURTLEBOT2

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
PLANS = {"random70": ("random-32-32-20_70agents_1.txt", "lacam", 70),
         "arena300": ("arena_300agents_1.txt", "pibt", 300)}


def parse_config(text: str) -> tuple:
    """(strategy, reroute key, trim) of e.g. "adg", "adg+reroute", "reorder+reroute-all+trim"."""
    strategy, *rest = text.split("+")
    trim = rest[-1:] == ["trim"]
    reroute = "+".join(rest[:-1] if trim else rest)
    if strategy not in ("adg", "reorder") or reroute not in ("", "reroute", "reroute-all"):
        raise argparse.ArgumentTypeError("a configuration is adg or reorder, alone or +reroute (held scope) "
                                         "or +reroute-all (scope all), then +trim to trim the plan and "
                                         "every reroute's (planning.trim)")
    return (strategy, {"": "none", "reroute": "auto", "reroute-all": "all"}[reroute], trim)


def rule_of(settings: List[str]) -> RerouteRule:
    """A RerouteRule from KEY=VALUE settings, the others default."""
    types = {f.name: f.type for f in dataclasses.fields(RerouteRule)}
    values: Dict[str, object] = {}
    for item in settings:
        key, _, value = item.partition("=")
        if key not in types:
            raise SystemExit("bench/reroute.py: unknown rule setting {!r}; expected one of {}".format(
                key, ", ".join(types)))
        values[key] = None if value == "none" else (int(value) if types[key] == "int" else float(value))
    return RerouteRule(**values)  # type: ignore[arg-type]


def trimmed_rule(rule, trim: bool):
    """`rule` (a RerouteRule, or "none") with its trim set to `trim`."""
    return dataclasses.replace(rule, trim=True) if trim and isinstance(rule, RerouteRule) else rule


def shortest_bound(plan: Plan, grid: Grid, result) -> float:
    """The makespan no execution of `plan` can beat on `result`'s delays: each robot alone on a
    shortest way to its goal. The simulator gives a robot's k-th move the k-th fate of the robot
    whatever its path (`simulate._Simulation`), and fates only add time, so a robot's time is at
    least that of its first `distance` fates."""
    run = Engine(plan, "adg").run  # the plan's moves in the order `result`'s fates are drawn in
    each = result.waits + result.durations
    bound = 0.0
    for r in range(run.num_agents):
        first = run.first[r]
        distance = int(dist_array(grid, run.table.goal(r))[grid.index(run.table.start(r))])
        bound = max(bound, float(each[first:first + distance].sum()))
    return bound


def interval(values: List[float]) -> str:
    a = np.asarray(values, dtype=float)
    half = 1.96 * a.std(ddof=1) / math.sqrt(a.size) if a.size > 1 else 0.0
    return "{:.3f} +- {:.3f}".format(a.mean(), half)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seeds", type=int, nargs="?", default=10)
    parser.add_argument("first", type=int, nargs="?", default=10)
    parser.add_argument("--plans", default=",".join(PLANS))
    parser.add_argument("--configs", default="adg,adg+reroute,reorder,reorder+reroute")
    parser.add_argument("--rule", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--baseline", nargs="*", default=None, metavar="KEY=VALUE")
    args = parser.parse_args()
    seeds, first = args.seeds, args.first
    configs = tuple(parse_config(c) for c in args.configs.split(","))
    rules = {"auto": rule_of(args.rule), "all": RerouteRule(scope="all")}
    if args.baseline is not None:
        rules["baseline"] = rule_of(args.baseline)
        configs += (("adg", "baseline", False),)
    labels = {"none": "", "auto": " + reroute", "baseline": " + reroute, baseline", "all": " + reroute (all)"}
    model = parse_delay_model("events=bernoulli:0.1:1-5")
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    for key, rule in rules.items():
        print("{}: {}".format({"auto": "rule", "all": "scope all"}.get(key, key), rule))
    for name in args.plans.split(","):
        file, solver, n = PLANS[name]
        loaded = load_plan(SHARED / "instances" / file, n, name, [SHARED / "maps"] + default_map_dirs(),
                           solver=solver, seed=0)
        plan, grid = loaded.plan, loaded.grid
        print("\n{}: {} robots, planned by {}, makespan {}; {} paired seeds from {}, p = 0.1, {}".format(
            name, n, solver, plan.makespan, seeds, first, TURTLEBOT2.describe()))
        ratio: Dict[tuple, List[float]] = {c: [] for c in configs}
        reroutes: Dict[tuple, List[int]] = {c: [] for c in configs}
        moved: Dict[tuple, List[int]] = {c: [] for c in configs}
        wall: Dict[tuple, float] = {c: 0.0 for c in configs}
        bound: List[float] = []
        shortest: List[float] = []
        looks = {k: 0 for k in ("auto", "all")}
        found = dict(looks)
        look_s = {k: 0.0 for k in looks}
        found_s, hand_s = dict(look_s), dict(look_s)
        for seed in range(first, first + seeds):
            for config in configs:
                strategy, reroute, trim = config
                began = time.perf_counter()
                result = simulate(plan, strategy, model, seed=seed, size=TURTLEBOT2, grid=grid,
                                  reroute=trimmed_rule(rules.get(reroute, reroute), trim), trim=trim)
                wall[config] += time.perf_counter() - began
                assert result.finished and not result.collisions and result.refused == 0, (name, config, seed)
                ratio[config].append(result.metrics.makespan / plan.makespan)
                reroutes[config].append(len(result.reroutes))
                moved[config].append(sum(len(r.agents) for _, r in result.reroutes))
                if config == configs[0]:
                    bound.append(result.lower_bound / plan.makespan)
                    shortest.append(shortest_bound(plan, grid, result) / plan.makespan)
                if reroute in looks:
                    rr = result.rerouter
                    assert rr is not None
                    looks[reroute] += rr.looks
                    found[reroute] += rr.found
                    look_s[reroute] += rr.seconds
                    found_s[reroute] += rr.found_seconds
                    hand_s[reroute] += result.handover_seconds
        base = ratio[configs[0]]
        print("  lower bound / planned makespan: {}; on shortest paths (no execution beats it): {}".format(
            interval(bound), interval(shortest)))
        print("  {:<26} {:>16} {:>20} {:>9} {:>12} {:>8}".format(
            "configuration", "executed/planned", "paired vs adg", "reroutes", "robots moved", "s a run"))
        for config in configs:
            change = [100.0 * (x - b) / b for x, b in zip(ratio[config], base)]
            print("  {:<26} {:>16} {:>18}% {:>9.1f} {:>12.1f} {:>8.1f}".format(
                config[0] + labels[config[1]] + (" + trim" if config[2] else ""), interval(ratio[config]), interval(change), float(np.mean(reroutes[config])),
                float(np.mean(moved[config])), wall[config] / seeds))
        if ("adg", "baseline", False) in ratio and ("adg", "auto", False) in ratio:
            change = [100.0 * (x - b) / b for x, b in zip(ratio[("adg", "auto", False)],
                                                          ratio[("adg", "baseline", False)])]
            print("  adg + reroute paired vs adg + reroute, baseline: {}%".format(interval(change)))
        for key in looks:
            if not looks[key]:
                continue
            print("  the rule's cost{} ({} robots): {:.2f} ms a look ({} looks), {:.1f} ms a look that found a "
                  "reroute ({}), {:.1f} ms a hand-over".format(
                      " (scope all)" if key == "all" else "", n, 1e3 * look_s[key] / max(looks[key], 1), looks[key],
                      1e3 * found_s[key] / max(found[key], 1), found[key],
                      1e3 * hand_s[key] / max(found[key], 1)))
        zero = parse_delay_model("none")
        flat = []
        for strategy, reroute, trim in configs:
            result = simulate(plan, strategy, zero, seed=0, size=TURTLEBOT2, grid=grid,
                              reroute=trimmed_rule(rules.get(reroute, reroute), trim), trim=trim)
            flat.append("{}{}{} {:.3f} ({} reroutes)".format(strategy, labels[reroute], " + trim" if trim else "",
                                                          result.metrics.makespan / plan.makespan,
                                                          len(result.reroutes)))
        print("  p = 0: " + "; ".join(flat))
    print("\nload average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
