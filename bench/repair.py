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
3. With --mapf-ir (mapf-IR's `app` from $MAPF_IR_APP, or built by
   --mapf-ir-src CHECKOUT as bench/side_by_side.py does): mapf-IR's own PIBT
   output for brc202d_1500agents_1 (and ost000a_3000agents_1 with --large),
   repaired by the whole `fleetctl repair` process (wall time and peak RSS by
   GNU time), the result checked by `fleetctl validate --strict-rotations`
   and run by `fleetctl simulate` (default delays); then the same repair in
   this process, split into its parts (windows, LaCAM, the validator).

    .venv/bin/python bench/repair.py [--repeat 3] [--random 300] [--mapf-ir [--large]]
"""
from __future__ import annotations

import argparse
import collections
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, Dict, List

import numpy as np

from fleet_common.formats import read_instance
from fleet_common.formats.solution import read_solution
from fleet_common.planning import repair as repair_module
from fleet_common.planning import repair_one
from fleet_common.planning import solve
from fleet_common.planning.mapf_ir import find_map_dir, resolve_app
from fleet_common.planning.repair import repair_rotations
from fleet_common.validate import validate_plan

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from side_by_side import FLEETCTL, build_mapf_ir, timed  # noqa: E402
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


def mapf_ir_outputs(app: Path, names: List[str], repeat: int) -> None:
    """Part 3: mapf-IR's PIBT outputs repaired, checked and run, whole processes."""
    maps = SHARED / "maps"
    with tempfile.TemporaryDirectory(prefix="fleetcontrol-repair-") as work:
        for name in names:
            plan = Path(work) / ("pibt_" + name + ".txt")
            fixed = Path(work) / ("repaired_" + name + ".txt")
            subprocess.run([str(app), "-i", str(SHARED / "instances" / (name + ".txt")), "-s", "PIBT", "-o",
                            str(plan)], cwd=str(find_map_dir(app)), check=True, stdout=subprocess.DEVNULL)
            print(name + ": mapf-IR PIBT output: " + _first(subprocess.run(
                [FLEETCTL, "validate", str(plan), "--map-dir", str(maps)], stdout=subprocess.PIPE,
                universal_newlines=True).stdout).split(": ", 1)[-1])
            runs = [timed([FLEETCTL, "repair", str(plan), "-o", str(fixed), "--map-dir", str(maps)])
                    for _ in range(repeat)]
            ms, cpu, rss, code, out = min(runs)
            print("  fleetctl repair: best {:.2f} s wall ({:.2f} s CPU), peak RSS {:.0f} MB, exit {}; "
                  "all: {}".format(ms / 1000, cpu, rss, code, ", ".join("{:.2f} s".format(r[0] / 1000)
                                                                         for r in runs)))
            print("  " + _first(out).split(": ", 1)[-1])
            for argv in (["validate", "--strict-rotations"], ["simulate"]):
                ms, cpu, rss, code, out = timed([FLEETCTL] + argv + [str(fixed), "--map-dir", str(maps)])
                wanted = "valid|INVALID" if argv[0] == "validate" else "collisions|reached"
                lines = [ln.split(": ", 1)[-1] if argv[0] == "validate" else ln
                         for ln in out.splitlines() if re.search(wanted, ln)]
                print("  fleetctl {}: exit {}, {:.1f} s, {:.0f} MB: {}".format(
                    " ".join(argv), code, ms / 1000, rss, "; ".join(lines)))
            _in_process(plan, maps)


def _in_process(path: Path, maps: Path) -> None:
    """The repair in this process, split into its parts."""
    sol = read_solution(str(path), map_dirs=[maps])
    spent: Dict[str, float] = collections.Counter()
    count: Dict[str, int] = collections.Counter()
    saved = {}

    def timing(module: object, name: str, label: str) -> None:
        inner: Callable = getattr(module, name)
        saved[(module, name)] = inner

        def timed_call(*a: object, **k: object) -> object:
            began = time.perf_counter()
            try:
                return inner(*a, **k)
            finally:
                spent[label] += time.perf_counter() - began
                count[label] += 1
        setattr(module, name, timed_call)

    timing(repair_one, "replan_window", "windows")
    timing(repair_one, "replan", "LaCAM from a rotation's step")
    timing(repair_module, "validate_plan", "validator")
    try:
        began = time.perf_counter()
        result = repair_rotations(sol.plan, sol.grid, deadline=None)
        total = time.perf_counter() - began
    finally:
        for (module, name), inner in saved.items():
            setattr(module, name, inner)
    parts = ", ".join("{} {:.2f} s ({}x)".format(k, v, count[k]) for k, v in spent.items())
    print("  in-process repair_rotations {:.2f} s: {}; the rest {:.2f} s; {} agents touched, soc {:+d}, "
          "makespan {:+d}".format(total, parts, total - sum(spent.values()), len(result.agents),
                                  result.extra_soc, result.extra_makespan))


def _first(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip()]
    return lines[0] if lines else ""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--random", type=int, default=300, help="random plans in part 2 (0: skip)")
    parser.add_argument("--skip-shipped", action="store_true", help="skip part 1")
    parser.add_argument("--mapf-ir", action="store_true", help="part 3: mapf-IR's own PIBT outputs")
    parser.add_argument("--mapf-ir-src", type=Path, default=None, metavar="CHECKOUT",
                        help="build mapf-IR's app from this checkout (else $MAPF_IR_APP)")
    parser.add_argument("--large", action="store_true", help="part 3 also on ost000a_3000agents_1")
    args = parser.parse_args()
    print("load average {:.1f} {:.1f} {:.1f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    if not args.skip_shipped:
        shipped(args.repeat)
    if args.random:
        small_random(args.random)
    if args.mapf_ir:
        app = build_mapf_ir(args.mapf_ir_src) if args.mapf_ir_src else resolve_app()
        names = ["brc202d_1500agents_1"] + (["ost000a_3000agents_1"] if args.large else [])
        mapf_ir_outputs(app, names, args.repeat)
    print("load average {:.1f} {:.1f} {:.1f} at the end".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
