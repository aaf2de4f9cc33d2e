"""Benchmark: rotation repair (`fleet_common.planning.repair.repair_rotations`).

1. Plans with mapf-IR's semantics (`rotations=True`) from the built-in PIBT
   and LaCAM on shipped instances (arena 300 agents, the issue's target: under
   1 s; random-32-32-20 110, lak307d 300, lak503d 500 agents): rotations in
   the plan, repair time (best of --repeat, wall and this process's CPU
   time, which other sessions on a shared machine inflate less), what changed (agents, extra soc
   and makespan), and the repaired plan's check (strict validation).
2. Many small random plans like the property test's (maps 5-10 cells a side,
   15 % blocked, 20-35 % of the free cells taken, PIBT or LaCAM in mapf-IR
   mode, plans with rotations only): how far the repaired sum of costs is from
   the original (the test bounds it by a factor of 2), and the slowest repair.

    .venv/bin/python bench/repair.py [--repeat 3] [--random 300]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from fleet_common.formats import read_instance
from fleet_common.planning import solve
from fleet_common.planning.repair import repair_rotations
from fleet_common.validate import validate_plan

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_planning_repair import random_problem  # noqa: E402  (the property test's plans)

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
INSTANCES = ("arena_300agents_1", "random-32-32-20_110agents_1", "lak307d_300agents_well-formed_1",
             "lak503d_500agents_well-formed_1")


def shipped(repeat: int) -> None:
    print("{:<32} {:>6}  {:<6} {:>9} {:>9} {:>8} {:>7} {:>9} {:>9}  {}".format(
        "instance", "agents", "solver", "rotations", "best ms", "cpu ms", "touched", "extra soc", "extra mk",
        "check"))
    for name in INSTANCES:
        inst = read_instance(SHARED / "instances" / (name + ".txt"), [SHARED / "maps"])
        for solver in ("pibt", "lacam"):
            plan = solve(solver, inst.grid, inst.starts, inst.goals, deadline=60, rotations=True).plan
            if plan is None:
                print("{:<32} {:>6}  {:<6} no plan".format(name, len(inst.starts), solver))
                continue
            times, cpu = [], []
            for _ in range(repeat):
                began, began_cpu = time.perf_counter(), time.process_time()
                result = repair_rotations(plan, inst.grid, deadline=None)
                times.append((time.perf_counter() - began) * 1000)
                cpu.append((time.process_time() - began_cpu) * 1000)
            ok = validate_plan(result.plan, inst.grid, starts=inst.starts, goals=inst.goals,
                               strict_rotations=True).ok
            print("{:<32} {:>6}  {:<6} {:>9} {:>9.1f} {:>8.1f} {:>7} {:>+9} {:>+9}  {}".format(
                name, plan.num_agents, solver, len(result.rotations), min(times), min(cpu), len(result.agents),
                result.extra_soc, result.extra_makespan, "valid, no rotations" if ok else "INVALID"))


def small_random(count: int) -> None:
    rng = np.random.default_rng(1)
    ratios, slowest, tried = [], 0.0, 0
    while len(ratios) < count:
        tried += 1
        found = random_problem(int(rng.integers(10 ** 6)), int(rng.integers(5, 11)), int(rng.integers(5, 11)),
                               float(rng.uniform(0.2, 0.35)), str(rng.choice(["pibt", "lacam"])))
        if found is None:
            continue
        grid, plan = found
        began = time.perf_counter()
        result = repair_rotations(plan, grid, deadline=None)
        slowest = max(slowest, time.perf_counter() - began)
        ratios.append(result.plan.soc / plan.soc)
    print("{} random plans with rotations ({} drawn): repaired soc / original soc median {:.3f}, "
          "95th percentile {:.3f}, max {:.3f}; slowest repair {:.0f} ms".format(
              count, tried, statistics.median(ratios), float(np.percentile(ratios, 95)), max(ratios),
              slowest * 1000))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--random", type=int, default=300, help="random plans in part 2 (0: skip)")
    args = parser.parse_args()
    print("load average {:.1f} {:.1f} {:.1f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    shipped(args.repeat)
    if args.random:
        small_random(args.random)


if __name__ == "__main__":
    main()
