"""The ADG under delays by robot size: how far a smaller robot could still take it (issue 25).

Issue 25 asks the ADG's executed makespan under LoRR delays (p = 0.1 of 1-5
moves) to drop by a quarter against robots as large as a cell. The robots'
size changes only how closely a robot may follow another; the ADG's order of
robots at every cell stays the plan's. So robots of next to no size (1 mm
across, no margin: a follower may start into a cell the instant its leader
starts out of it) give the least makespan any size model can give under the
ADG. This prints, on the evaluation's two dense plans and paired seeds (each
size meets the same delays), the executed over the planned makespan for
robots as large as a cell, the lab's TurtleBot 2 and 1 mm robots, the change
against the cell-sized robots, the quarter asked for, and the lower bound
(every robot alone with its own delays).

    .venv/bin/python bench/size_floor.py [SEEDS [FIRST]] [--plans random70,arena300]   # 30 seeds from 0
"""
from __future__ import annotations

import argparse
import os
from typing import Dict, List

import numpy as np

from fleet_common.delays import parse_delay_model
from fleet_common.execution.simulate import simulate
from fleet_common.formats import default_map_dirs
from fleet_common.plan_loading import load_plan
from fleet_common.robot_size import TURTLEBOT2, RobotSize, cell_sized
from reroute import PLANS, SHARED, interval  # bench/reroute.py: the same plans and intervals

SIZES = {"cell-sized": cell_sized(), "TurtleBot 2": TURTLEBOT2, "1 mm": RobotSize(0.001, 0.0, TURTLEBOT2.cell)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seeds", type=int, nargs="?", default=30)
    parser.add_argument("first", type=int, nargs="?", default=0)
    parser.add_argument("--plans", default=",".join(PLANS))
    args = parser.parse_args()
    model = parse_delay_model("events=bernoulli:0.1:1-5")
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    for name in args.plans.split(","):
        file, solver, n = PLANS[name]
        loaded = load_plan(SHARED / "instances" / file, n, name, [SHARED / "maps"] + default_map_dirs(),
                           solver=solver, seed=0)
        plan, grid = loaded.plan, loaded.grid
        ratio: Dict[str, List[float]] = {s: [] for s in SIZES}
        bound: List[float] = []
        for seed in range(args.first, args.first + args.seeds):
            for label, size in SIZES.items():
                result = simulate(plan, "adg", model, seed=seed, size=size, grid=grid)
                ratio[label].append(result.metrics.makespan / plan.makespan)
            bound.append(result.lower_bound / plan.makespan)
        cell = np.asarray(ratio["cell-sized"])
        print("\n{}: {} robots, planned by {}, makespan {}; ADG, {} paired seeds from {}, p = 0.1".format(
            name, n, solver, plan.makespan, args.seeds, args.first))
        print("  {:<14} {:>18} {:>22}".format("robots", "executed/planned", "paired vs cell-sized"))
        for label, values in ratio.items():
            change = 100 * (np.asarray(values) / cell - 1)
            print("  {:<14} {:>18} {:>21}%".format(label, interval(values), interval(list(change))))
        print("  a quarter below the cell-sized robots: {:.3f}; lower bound (every robot alone): {}".format(
            0.75 * cell.mean(), interval(bound)))
    print("\nload average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
