"""Benchmark: the execution engine's Action Dependency Graph and per-event cost.

1. ADG construction (actions, per-cell visit index, type-2 edges, cycle check)
   and the whole `Engine(plan)` set-up, for 1,500 agents x 1,000 steps on two
   synthetic plans: "shuttle" (bench/read_validate.py's plan: every agent moves
   every step along its own column, 1.5 million actions and no shared cell)
   and "rings" (125 rings of 16 cells, 12 agents each in groups of three, all
   moving every step: every action enters a cell just left by another robot,
   a third of them following moves, so 1.5 million type-2 edges).
2. The cost of one completion event (`Engine.handle(ActionCompleted(...))`, the
   dispatch decisions it causes included), measured on every completion of a
   simulated run with moderate random delays: on the shipped mapf-IR plan
   pibt_sample.txt (100 robots, 218 following moves), and on rings at 300
   robots (1,000 steps) and 1,500 robots (200 steps), under both strategies.
   Median and 99th percentile. (When this was written, the built-in solvers'
   plans for the 300-agent instances contained rotations, which the engine
   refuses; they are rotation-free now, rings stay for comparable figures.)

    .venv/bin/python bench/engine.py [--repeat 3]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import List

import numpy as np

from fleet_common.execution import ActionCompleted, Engine
from fleet_common.execution.actions import ActionTable
from fleet_common.execution.adg import build_adg
from fleet_common.delays import parse_delay_model, simulator_durations
from fleet_common.execution.simulate import simulate_engine
from fleet_common.formats import default_map_dirs, read_solution
from fleet_common.plan import Plan

sys.path.insert(0, str(Path(__file__).resolve().parent))
from read_validate import shuttle_plan  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"


def ring_plan(agents: int, steps: int) -> Plan:
    """Agents circling 5x5-block borders (16 cells), 12 per ring: 3 cells taken, 1 free."""
    ring = [(x, 0) for x in range(4)] + [(4, y) for y in range(4)] + \
        [(x, 4) for x in range(4, 0, -1)] + [(0, y) for y in range(4, 0, -1)]
    ring_xy = np.array(ring, dtype=np.int32)
    slots = np.array([i for i in range(16) if i % 4 != 3])  # 12 agents per ring
    rings = -(-agents // len(slots))
    which = np.arange(agents) // len(slots)
    slot = slots[np.arange(agents) % len(slots)]
    t = np.arange(steps + 1)[:, None]
    pos = ring_xy[(slot[None, :] + t) % 16]  # (steps + 1, agents, 2)
    pos[:, :, 0] += (which % 25 * 5)[None, :]
    pos[:, :, 1] += (which // 25 * 5)[None, :]
    assert rings <= 25 * 25
    return Plan(pos)


def best_median(fn, repeat: int) -> List[float]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return [min(times), statistics.median(times)]


def event_costs(plan: Plan, strategy: str, seed: int = 0) -> np.ndarray:
    engine = Engine(plan, strategy)
    costs: List[float] = []
    handle = engine.handle
    clock = time.perf_counter

    def timed(event):  # type: ignore[no-untyped-def]
        if type(event) is ActionCompleted:
            t0 = clock()
            out = handle(event)
            costs.append(clock() - t0)
            return out
        return handle(event)

    engine.handle = timed  # type: ignore[method-assign]
    waits, durations = simulator_durations(parse_delay_model("moderate"), engine.table.agent,
                                           engine.table.num_agents, seed)
    result = simulate_engine(engine, durations, waits=waits)
    if not result.finished or result.collisions:
        raise SystemExit("benchmark run failed: finished={}, collisions={}".format(
            result.finished, len(result.collisions)))
    return np.array(costs) * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    print("ADG construction, 1500 agents x 1000 steps (best / median of {} runs):".format(args.repeat))
    for name, plan in (("shuttle", shuttle_plan(1500, 1000)), ("rings", ring_plan(1500, 1000))):
        table = ActionTable.from_plan(plan)
        graph = build_adg(table)
        adg = best_median(lambda: build_adg(ActionTable.from_plan(plan)), args.repeat)
        eng = best_median(lambda: Engine(plan, "adg"), args.repeat)
        print("  {:8} {:>9,} actions {:>9,} type-2 edges ({:,} following): ADG {:.2f} / {:.2f} s, "
              "Engine(plan) {:.2f} / {:.2f} s".format(
                  name, table.num_actions, int((graph.dep >= 0).sum()), graph.num_following,
                  adg[0], adg[1], eng[0], eng[1]))

    sample = read_solution(SHARED / "solutions" / "pibt_sample.txt", map_dirs=default_map_dirs()).plan
    print("one completion event, moderate delays (microseconds):")
    for name, plan in (("pibt_sample.txt", sample), ("rings 300 x 1000", ring_plan(300, 1000)),
                       ("rings 1500 x 200", ring_plan(1500, 200))):
        for strategy in ("adg", "step"):
            costs = event_costs(plan, strategy)
            print("  {:24} {:>4} robots {:5} {:>9,} events: median {:5.1f}  p99 {:6.1f}  max {:8.1f}".format(
                name, plan.num_agents, strategy, costs.size, float(np.median(costs)),
                float(np.percentile(costs, 99)), float(costs.max())))


if __name__ == "__main__":
    main()
