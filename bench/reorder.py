"""Benchmark: what the re-ordering strategy costs per decision, against the ADG's.

The issue's budget: the strategy's decision per completion at 300 robots under
100 microseconds on average, inside the manager's loop. Measured here on the
engine alone (what the manager's loop calls for every robot's completed move,
and every half plan step for the plan's clock), on the mapf-IR evaluation
plans solved as experiments/evaluation.yaml solves them: random-32-32-20 with
70 agents (LaCAM) and arena with 300 agents (PIBT), robots of the lab's size
(TurtleBot 2), the League of Robot Runners' delays at p = 0.1 (before each
move, with probability p, the robot stands still for 1 to 5 moves), the same
delays for both strategies (paired seeds).

Per strategy: every completion event's cost (`Engine.handle(ActionCompleted)`,
the dispatches and passes it decides included), mean, median, p99 and max,
in microseconds; the Tick's (the plan clock's look at the waiting robots,
re-ordering only); and the executed makespan over the planned one, so the
cost is read beside what it buys.

    .venv/bin/python bench/reorder.py [--seeds 3] [--p 0.1]
"""
from __future__ import annotations

import argparse
import platform
import os
import time
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

from fleet_common.delays import parse_delay_model, simulator_fates
from fleet_common.execution import ActionCompleted, Engine
from fleet_common.execution.events import Tick
from fleet_common.execution.simulate import simulate_engine
from fleet_common.formats import default_map_dirs
from fleet_common.formats.instance import read_instance
from fleet_common.plan import Plan
from fleet_common.planning import solve
from fleet_common.robot_size import TURTLEBOT2

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
PLANS = (("random-32-32-20, 70 agents", "random-32-32-20_70agents_1.txt", "lacam"),
         ("arena, 300 agents", "arena_300agents_1.txt", "pibt"))


def evaluation_plan(file: str, solver: str) -> Plan:
    inst = read_instance(SHARED / "instances" / file, map_dirs=default_map_dirs())
    result = solve(solver, inst.grid, inst.starts, inst.goals, 60.0, seed=0)
    if result.plan is None:
        raise SystemExit("{} found no plan for {}".format(solver, file))
    return result.plan


def timed_run(plan: Plan, strategy: str, p: float, seed: int) -> Tuple[List[float], List[float], float, int]:
    """(completion costs, tick costs) in microseconds, executed/planned makespan, passes."""
    engine = Engine(plan, strategy, follow=True)
    completions: List[float] = []
    ticks: List[float] = []
    handle = engine.handle
    clock = time.perf_counter

    def timed(event):  # type: ignore[no-untyped-def]
        kind = type(event)
        if kind is ActionCompleted or kind is Tick:
            t0 = clock()
            out = handle(event)
            (completions if kind is ActionCompleted else ticks).append((clock() - t0) * 1e6)
            return out
        return handle(event)

    engine.handle = timed  # type: ignore[method-assign]
    fates = simulator_fates(parse_delay_model("events=bernoulli:{:g}:1-5".format(p)), engine.table.agent,
                            engine.table.num_agents, seed)
    result = simulate_engine(engine, fates=fates, size=TURTLEBOT2)
    if not result.finished or result.collisions:
        raise SystemExit("benchmark run failed: finished={}, collisions={}".format(
            result.finished, len(result.collisions)))
    return completions, ticks, result.metrics.makespan / plan.makespan, len(engine.run.passes)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--p", type=float, default=0.1)
    args = ap.parse_args()
    print("python {}, {}, {} cores; LoRR delays p = {:g}, {} seeds, robots of the lab's size".format(
        platform.python_version(), platform.machine(), os.cpu_count(), args.p, args.seeds))
    for name, file, solver in PLANS:
        plan = evaluation_plan(file, solver)
        print("{} ({} plan, makespan {}):".format(name, solver, plan.makespan))
        for strategy in ("adg", "reorder"):
            runs: Dict[str, List[float]] = {"completion": [], "tick": []}
            ratios, passes = [], 0
            for seed in range(args.seeds):
                completions, ticks, ratio, made = timed_run(plan, strategy, args.p, seed)
                runs["completion"] += completions
                runs["tick"] += ticks
                ratios.append(ratio)
                passes += made
            line = "  {:8} executed/planned {:.3f}, passes {:5.1f} per run".format(
                strategy, float(np.mean(ratios)), passes / args.seeds)
            for kind, costs in runs.items():
                if costs:
                    c = np.array(costs)
                    line += "; {} ({:,}): mean {:.1f} median {:.1f} p99 {:.1f} max {:.0f} us".format(
                        kind, c.size, c.mean(), float(np.median(c)), float(np.percentile(c, 99)), c.max())
            print(line)


if __name__ == "__main__":
    main()
