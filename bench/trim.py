"""Trimming a plan (`planning.trim`): what it saves and what it costs, on mapf-IR's plans.

For each plan: its moves, the moves trimmed away, the robots trimmed, and the time a whole trim
takes (two rounds over every robot, the best of `--repeat` runs, so a noisy machine's outliers
drop out), per robot looked at. The plans: the lab (CBS), mapf-IR's PIBT on its sample (100),
random-32-32-20 with 70 agents by LaCAM (the evaluation's), the 300-robot arena by PIBT (the
evaluation's) and brc202d with 1,500 agents by LaCAM (as issue 29's scale benchmarks plan it).

    .venv/bin/python bench/trim.py [--repeat 3] [--plans lab,pibt_sample,random70,arena300,brc1500]
                                   [--seconds S]   # a deadline: robots not reached by then are counted
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Dict, Tuple

from fleet_common.formats import default_map_dirs
from fleet_common.lab import lab_instance_path
from fleet_common.plan_loading import load_plan
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.trim import trim_moves

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
#: name -> (file, solver (None: a solution file), agents)
PLANS: Dict[str, Tuple[Path, object, int]] = {
    "lab": (lab_instance_path(), "cbs", 5),
    "pibt_sample": (SHARED / "solutions" / "pibt_sample.txt", None, 100),
    "random70": (SHARED / "instances" / "random-32-32-20_70agents_1.txt", "lacam", 70),
    "arena300": (SHARED / "instances" / "arena_300agents_1.txt", "pibt", 300),
    "brc1500": (SHARED / "instances" / "brc202d_1500agents_1.txt", "lacam", 1500),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--plans", default=",".join(PLANS))
    parser.add_argument("--seconds", type=float, default=None)
    args = parser.parse_args()
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    print("{:<12} {:>6} {:>9} {:>8} {:>14} {:>8} {:>10} {:>12}".format(
        "plan", "robots", "makespan", "moves", "trimmed away", "robots", "s a trim", "ms a robot"))
    for name in args.plans.split(","):
        path, solver, n = PLANS[name]
        loaded = load_plan(path, n, name, [SHARED / "maps"] + default_map_dirs(), solver=solver,  # type: ignore[arg-type]
                           time_limit=120.0, seed=0)
        best = float("inf")
        result = None
        for _ in range(max(args.repeat, 1)):
            began = time.perf_counter()
            result = trim_moves(loaded.plan, loaded.grid, deadline=Deadline(args.seconds))
            best = min(best, time.perf_counter() - began)
        assert result is not None and result.refused == ""
        saved = result.moves_before - result.moves_after
        print("{:<12} {:>6} {:>9} {:>8} {:>7} ({:>4.1f} %) {:>8} {:>10.3f} {:>12.2f}".format(
            name, n, loaded.plan.makespan, result.moves_before, saved, 100.0 * saved / max(result.moves_before, 1),
            len(result.robots), best, 1e3 * best / n) + (
                "  (time up: {} robots with moves to spare not reached)".format(result.unreached)
                if result.unreached else ""))
    print("load average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
