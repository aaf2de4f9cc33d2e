"""Benchmark: the built-in solvers against mapf-IR's, then on their own, on shipped mapf-IR instances.

First (with mapf-IR found by $MAPF_IR_APP or built by --mapf-ir-src CHECKOUT):
whole processes against whole processes, `fleetctl solve` beside mapf-IR's
`app` on PIBT, CBS and a dense instance, with the ratios and the in-process
figure beside (`side_by_side`). Then, in this process, one table row per
solver and instance: status, best wall time of the
repeats, soc, makespan and the plan's rotations (3 or more agents each
entering the cell the next one leaves: robots cannot execute them; the
built-in solvers plan without them, mapf-IR's allow them). pibt, lacam and pp run on every instance, cbs
(optimal, for small instances) only on the 30-agent one with a short limit. With $MAPF_IR_APP set, mapf-IR's PIBT (and
each solver named with --baseline) runs on the same instances in the same run,
and the last column is our time over mapf-IR PIBT's wall time (its process,
from start to exit, best of the repeats). Last, replanning: 300 agents on
arena, 3 of them disabled halfway through a PIBT plan.

    .venv/bin/python bench/solvers.py [--repeats 3] [--baseline ECBS ...] [--mapf-ir-src DIR]
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

from fleet_common.formats.instance import Instance, read_instance
from fleet_common.planning import solve
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.mapf_ir import APP_ENV, MapfIrSolver
from fleet_common.planning.result import SolveResult
from fleet_common.validate import ROTATION, validate_plan

import side_by_side

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
ARENA = "arena_300agents_1"
INSTANCES = [ARENA, "random-32-32-20_30agents_1", "random-32-32-20_70agents_1",
             "random-32-32-20_110agents_1", "lak307d_300agents_well-formed_1"]
#: Which built-in solvers run where; cbs gets its own, shorter limit.
PLAN: Dict[str, Tuple[str, ...]] = {
    ARENA: ("pibt", "lacam", "pp"),
    "random-32-32-20_30agents_1": ("pibt", "lacam", "pp", "cbs"),
    "random-32-32-20_70agents_1": ("pibt", "lacam", "pp"),
    "random-32-32-20_110agents_1": ("pibt", "lacam", "pp"),
    "lak307d_300agents_well-formed_1": ("pibt", "lacam", "pp"),
}
CBS_LIMIT_S = 10.0
DISABLED = (0, 100, 200)

Row = Tuple[str, int, str, str, Optional[float], Optional[int], Optional[int], Optional[int], str]


def load(name: str) -> Instance:
    return read_instance(DATA / "instances" / (name + ".txt"), [DATA / "maps"])


def best_of(repeats: int, run) -> Tuple[SolveResult, float]:  # type: ignore[no-untyped-def]
    """The last result and the best wall time in ms over `repeats` runs."""
    best = float("inf")
    result = None
    for _ in range(repeats):
        result, ms = run()
        best = min(best, ms)
    return result, best  # type: ignore[return-value]


def ours(name: str, solver: str, limit: float, seed: int):  # type: ignore[no-untyped-def]
    def run() -> Tuple[SolveResult, float]:
        inst = load(name)  # a fresh grid each time: no distance table cached from a previous run
        t0 = time.perf_counter()
        result = solve(solver, inst.grid, inst.starts, inst.goals, deadline=Deadline(limit), seed=seed)
        return result, (time.perf_counter() - t0) * 1000
    return run


def theirs(adapter: MapfIrSolver, name: str, solver: str, limit: float, seed: int):  # type: ignore[no-untyped-def]
    inst = load(name)

    def run() -> Tuple[SolveResult, float]:
        result = adapter.solve(inst.grid, inst.starts, inst.goals, solver, deadline=Deadline(limit),
                               seed=seed, max_timestep=inst.max_timestep)
        return result, float(result.stats.get("process_ms", result.comp_time_ms))
    return run


def row(name: str, agents: int, label: str, result: SolveResult, ms: float, ratio: str) -> Row:
    plan = result.plan
    rotations = validate_plan(plan, load(name).grid).count(ROTATION) if plan else None
    return (name, agents, label, result.status, ms, plan.soc if plan else None,
            plan.makespan if plan else None, rotations, ratio)


def print_table(rows: Sequence[Row]) -> None:
    head = ("instance", "agents", "solver", "status", "best ms", "soc", "makespan", "rotations",
            "/ mapf-IR PIBT")
    text = [head] + [(r[0], str(r[1]), r[2], r[3], "-" if r[4] is None else "{:.1f}".format(r[4]),
                      "-" if r[5] is None else str(r[5]), "-" if r[6] is None else str(r[6]),
                      "-" if r[7] is None else str(r[7]), r[8])
                     for r in rows]
    widths = [max(len(t[i]) for t in text) for i in range(len(head))]
    for k, t in enumerate(text):
        print("  ".join(c.ljust(w) if i < 3 else c.rjust(w) for i, (c, w) in enumerate(zip(t, widths))))
        if k == 0:
            print("  ".join("-" * w for w in widths))


def replanning(seed: int, repeats: int) -> str:
    """Replan arena's 300 agents halfway through a PIBT plan with 3 of them out.

    "warm": on the grid the first plan was made on (its distance tables cached,
    as in the manager); "cold": on a freshly read grid.
    """
    from fleet_common.planning.replan import replan

    inst = load(ARENA)
    first = solve("pibt", inst.grid, inst.starts, inst.goals, deadline=Deadline(30), seed=seed)
    if first.plan is None:
        return "replanning: no initial PIBT plan on {} ({})".format(ARENA, first.message)
    t = first.plan.makespan // 2
    current = first.plan.config(t)
    times = {}
    result = replan(inst.grid, current, inst.goals, out=set(DISABLED), deadline=Deadline(30), seed=seed)
    for kind in ("warm", "cold"):
        best = float("inf")
        for _ in range(repeats):
            grid = inst.grid if kind == "warm" else load(ARENA).grid
            t0 = time.perf_counter()
            result = replan(grid, current, inst.goals, out=set(DISABLED), deadline=Deadline(30), seed=seed)
            best = min(best, (time.perf_counter() - t0) * 1000)
        times[kind] = best
    what = "no new plan ({})".format(result.message) if result.plan is None else \
        "new plan soc={} makespan={}, {} rotations".format(
            result.plan.soc, result.plan.makespan, validate_plan(result.plan, inst.grid).count(ROTATION))
    return ("replanning {} agents on {} at t={} of {}, agents {} out: best {:.1f} ms warm, {:.1f} ms "
            "cold; {}; {} cannot reach their goals; {}").format(
        len(current), ARENA, t, first.plan.makespan, ", ".join(map(str, DISABLED)), times["warm"],
        times["cold"], what, len(result.unreachable), result.message)


def machine() -> str:
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return "{} | nproc {} | Python {} | {}".format(cpu, os.cpu_count(), platform.python_version(),
                                                  time.strftime("%Y-%m-%d"))


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs per solver and instance; best time kept")
    ap.add_argument("--time-limit", type=float, default=30.0, help="seconds per run (cbs: {:.0f})".format(CBS_LIMIT_S))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--baseline", action="append", default=[], metavar="NAME",
                    help="also run mapf-IR's solver NAME (repeatable; needs ${})".format(APP_ENV))
    ap.add_argument("--mapf-ir-map-dir", type=Path, help="mapf-IR's compiled-in map folder")
    ap.add_argument("--only", action="append", default=[], metavar="INSTANCE", help="run only these instances")
    ap.add_argument("--mapf-ir-src", type=Path, metavar="DIR",
                    help="a Kei18/mapf-IR checkout (with grid-pathfinding) to build `app` from when ${} is unset".format(
                        APP_ENV))
    ap.add_argument("--skip", action="append", default=[], choices=("side-by-side", "in-process", "replanning"),
                    help="leave out a part")
    args = ap.parse_args(argv)
    app = side_by_side.find_app(args.mapf_ir_src)
    if "side-by-side" not in args.skip:
        if app is None:
            print("side by side: not run (set {} or give --mapf-ir-src)".format(APP_ENV))
        else:
            side_by_side.run(app, DATA, args.repeats)
        print()
    if "in-process" in args.skip:
        if "replanning" not in args.skip:
            print(replanning(args.seed, args.repeats))
        return 0
    if app is not None:
        os.environ[APP_ENV] = str(app)

    print(machine())
    adapter = None
    if os.environ.get(APP_ENV):
        adapter = MapfIrSolver(None, map_dir=args.mapf_ir_map_dir)
        print("mapf-IR: {} (maps from {})".format(adapter.app, adapter.map_dir))
    else:
        print("mapf-IR: not run (set {} to compare)".format(APP_ENV))
    print()
    rows: List[Row] = []
    for name in args.only or INSTANCES:
        agents = load(name).num_agents
        reference = None
        if adapter is not None:
            for solver in ["PIBT"] + [b for b in args.baseline if b != "PIBT"]:
                result, ms = best_of(args.repeats, theirs(adapter, name, solver, args.time_limit, args.seed))
                rows.append(row(name, agents, "mapf-IR " + solver, result, ms, ""))
                if solver == "PIBT" and result.solved:
                    reference = ms
        for solver in PLAN[name]:
            limit = CBS_LIMIT_S if solver == "cbs" else args.time_limit
            result, ms = best_of(args.repeats if solver != "cbs" else 1, ours(name, solver, limit, args.seed))
            ratio = "" if reference is None else "{:.3g}x".format(ms / reference)
            rows.append(row(name, agents, solver, result, ms, ratio))
        sys.stdout.flush()
    print_table(rows)
    if "replanning" not in args.skip:
        print()
        print(replanning(args.seed, args.repeats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
