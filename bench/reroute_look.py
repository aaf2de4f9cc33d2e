"""What a look for a reroute costs the manager at 300 robots: the snapshot in the loop, the look off it.

The manager (`fleet_manager.rerouting`) asks for a look while some robot is
held up, at most once a plan step: in its loop it checks who is held up
(`due`) and deep-copies the engine (`snapshot`, so that the worker thread
never reads the engine the loop mutates); the look itself (`look`: the
prediction, and the planning when someone is held up) runs in the worker
thread, within the rule's budget (0.25 s). This runs the 300-robot arena
(planned by PIBT, robots of the lab's size, LoRR delay events p = 0.1 of 1-5
moves) through the simulator with the manager's own `Rerouting` deciding, and
prints the loop's part (due, every turn; the snapshot, per look) and the
worker's (look), in ms, mean, max and first (the first look's engine holds the
whole plan; after a reroute the engine holds only the moves left), and how
many looks found a reroute.

    .venv/bin/python bench/reroute_look.py [SEEDS]     # default 2 seeds
"""
from __future__ import annotations

import itertools
import os
import sys
import time
from pathlib import Path
from typing import List, Optional

import numpy as np

from fleet_common.delays import parse_delay_model
from fleet_common.execution.reroute import Reroute, Rerouter
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs
from fleet_common.plan_loading import load_plan
from fleet_common.robot_size import TURTLEBOT2
from fleet_manager.rerouting import Rerouting, look

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"


class Measured(Rerouter):
    """The simulator's rerouter, deciding as the manager does: `due`, `ask` (the snapshot), `look`."""

    def __init__(self, grid) -> None:
        super().__init__(grid)
        self.rerouting = Rerouting(grid, "auto", itertools.count(1))
        self.due_ms: List[float] = []
        self.snapshot_ms: List[float] = []
        self.look_ms: List[float] = []

    def consider(self, engine, now: float) -> Optional[Reroute]:
        began = time.perf_counter()
        due = self.rerouting.due(engine, now)
        self.due_ms.append(1e3 * (time.perf_counter() - began))
        if not due:
            return None
        began = time.perf_counter()
        job = self.rerouting.ask(engine, now)
        self.snapshot_ms.append(1e3 * (time.perf_counter() - began))
        began = time.perf_counter()
        found = look(job)
        self.look_ms.append(1e3 * (time.perf_counter() - began))
        self.rerouting.finished(job.id, engine)
        self.looks += 1
        self.found += found is not None
        return found


def figures(name: str, values: List[float]) -> str:
    if not values:
        return "{}: none".format(name)
    a = np.asarray(values)
    return "{}: mean {:.2f} ms, max {:.2f} ms, first {:.2f} ms ({} times)".format(
        name, a.mean(), a.max(), a[0], a.size)


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    loaded = load_plan(SHARED / "instances" / "arena_300agents_1.txt", 300, "arena300",
                       [SHARED / "maps"] + default_map_dirs(), solver="pibt", seed=0)
    model = parse_delay_model("events=bernoulli:0.1:1-5")
    for seed in range(seeds):
        probe = Measured(loaded.grid)
        began = time.perf_counter()
        result = simulate(loaded.plan, "adg", model, seed=seed, size=TURTLEBOT2, reroute=probe,
                          grid=loaded.grid)
        print("\narena300 seed {}: plan of {} steps, {} reroutes, run simulated in {:.1f} s".format(
            seed, loaded.plan.makespan, len(result.reroutes), time.perf_counter() - began))
        print("  loop, every turn a look could be due: " + figures("due (held_up)", probe.due_ms))
        print("  loop, per look: " + figures("snapshot (deep copy)", probe.snapshot_ms))
        print("  worker, per look: " + figures("look (decide)", probe.look_ms))
        print("  looks that found a reroute: {} of {}".format(probe.found, probe.looks))
    print("\nload average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
