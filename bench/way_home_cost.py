"""What one try at a way home costs the manager's loop (`reroute.way_home`), by fleet size.

A robot a replan left away from its goal, enabled again, is given a way home in the manager's
loop: at once, and again every plan step while none is free (`RunCore._ways_home_tick`). This
times the planning and prediction a try makes, on the evaluation's two plans (random-32-32-20
with 70 agents by LaCAM, the 300-robot arena by PIBT) run by the simulator with robots of the
lab's size under LoRR delays (p = 0.1, 1-5 moves): once a plan step, for three robots still on
their way (not in a move), a way from where each stands to its goal around the others, as if the
plan had left it there. Nothing is handed over: the run goes on as planned.

    .venv/bin/python bench/way_home_cost.py [SEEDS]
"""
from __future__ import annotations

import statistics
import sys
import time
from typing import List, Optional

from fleet_common.delays import parse_delay_model
from fleet_common.execution import Engine
from fleet_common.execution.reroute import Reroute, Rerouter, way_home
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs
from fleet_common.plan_loading import load_plan
from fleet_common.robot_size import TURTLEBOT2

from reroute import PLANS, SHARED


class Timer(Rerouter):
    """A rerouter that never reroutes: each plan step it times ways home for three robots."""

    def __init__(self, grid, goals) -> None:
        super().__init__(grid, timed=False)
        self.goals = goals
        self.ms: List[float] = []
        self.found = 0

    def consider(self, engine: Engine, now: float) -> Optional[Reroute]:
        steps = engine.run.clock.steps(now)
        if steps < self._next:
            return None
        self._next = steps + 1
        run = engine.run
        on_way = [a for a in range(run.num_agents) if not run.finished_agent(a)
                  and run.dispatched[a] == run.completed[a] and run.out[a] is None]
        for a in on_way[:: max(1, len(on_way) // 3)][:3]:
            began = time.perf_counter()
            found = way_home(engine, self.maps, now, {a: tuple(self.goals[a])})
            self.ms.append((time.perf_counter() - began) * 1e3)
            self.found += found is not None
        return None


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    model = parse_delay_model("events=bernoulli:0.1:1-5")
    for name, (file, solver, n) in PLANS.items():
        loaded = load_plan(SHARED / "instances" / file, n, name, [SHARED / "maps"] + default_map_dirs(),
                           solver=solver, seed=0)
        ms: List[float] = []
        found = 0
        for seed in range(seeds):
            timer = Timer(loaded.grid, loaded.goals)
            simulate(loaded.plan, "adg", model, seed, size=TURTLEBOT2, reroute=timer, grid=loaded.grid)
            ms += timer.ms
            found += timer.found
        ms.sort()
        print("{}: {} robots, {} tries over {} seeds, a way found in {}: ms a try mean {:.1f} median {:.1f} "
              "p99 {:.1f} max {:.1f}".format(name, n, len(ms), seeds, found, statistics.mean(ms),
                                             statistics.median(ms), ms[int(0.99 * (len(ms) - 1))], ms[-1]))


if __name__ == "__main__":
    main()
