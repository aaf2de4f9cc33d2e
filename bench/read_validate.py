"""Benchmark: read and validate a 1,500-agent x 1,000-step mapf-IR solution.

The solution is made with our own writer (agents shuttle along their own
columns of a 1,500 x 12 map, every agent moving every step, so the validator
sees the full workload and no conflict), written to a temporary folder, then
read and validated several times. Prints the best and median wall times.
Then the validator alone on the worst case for its following and rotation
checks: agents in groups of four turning round 2x2 squares, every move a
following move and every group a rotation in every step (mapf-IR allows it;
the report lists the first 1,000 of each kind and counts them all).

    .venv/bin/python bench/read_validate.py [--agents 1500] [--steps 1000] [--repeat 5]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from fleet_common.formats.mapfile import map_from_grid, write_map
from fleet_common.formats.solution import make_solution, read_solution, write_solution
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.validate import FOLLOWING, ROTATION, validate_plan


def shuttle_plan(agents: int, steps: int, height: int = 12) -> Plan:
    t = np.arange(steps + 1)[:, None]
    phase = (t + np.arange(agents)[None, :]) % (2 * (height - 1))
    y = np.where(phase < height, phase, 2 * (height - 1) - phase)
    pos = np.empty((steps + 1, agents, 2), dtype=np.int32)
    pos[:, :, 0] = np.arange(agents)[None, :]
    pos[:, :, 1] = y
    return Plan(pos)


def squares_plan(agents: int, steps: int) -> Plan:
    """Groups of 4 agents on 2x2 squares (3 cells apart), each agent taking the next corner every step."""
    corners = np.array([(0, 0), (1, 0), (1, 1), (0, 1)], dtype=np.int32)
    t = np.arange(steps + 1)[:, None]
    pos = corners[(np.arange(agents)[None, :] % 4 + t) % 4]
    pos[:, :, 0] += (np.arange(agents) // 4 * 3)[None, :].astype(np.int32)
    return Plan(pos)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=1500)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    height = 12
    grid = Grid(np.ones((height, args.agents), dtype=bool), name="bench.map")
    plan = shuttle_plan(args.agents, args.steps, height)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_map(map_from_grid(grid), folder / "bench.map")
        sol = make_solution(grid, "bench.map", plan, plan.starts, plan.goals, solver="bench",
                            solved=True, comp_time=0)
        out = folder / "bench_solution.txt"
        t0 = time.perf_counter()
        write_solution(sol, out)
        write_s = time.perf_counter() - t0
        size_mb = out.stat().st_size / 1e6

        reads, validates, totals = [], [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            got = read_solution(out)
            t1 = time.perf_counter()
            report = validate_plan(got.plan, got.grid, starts=got.starts, goals=got.goals,
                                   soc=got.soc, makespan=got.makespan)
            t2 = time.perf_counter()
            if not report.ok:
                raise SystemExit("benchmark plan unexpectedly invalid: {}".format(report.errors[0]))
            reads.append(t1 - t0)
            validates.append(t2 - t1)
            totals.append(t2 - t0)

    print("solution: {} agents x {} steps, {:.1f} MB; write {:.2f} s".format(
        args.agents, args.steps, size_mb, write_s))
    for label, xs in (("read", reads), ("validate", validates), ("read+validate", totals)):
        print("{:>14}: best {:.3f} s, median {:.3f} s over {} runs".format(
            label, min(xs), statistics.median(xs), len(xs)))

    turning = squares_plan(args.agents, args.steps)
    squares = Grid(np.ones((2, -(-args.agents // 4) * 3), dtype=bool))
    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        report = validate_plan(turning, squares)
        times.append(time.perf_counter() - t0)
    print("turning squares: {} agents x {} steps, {:,} following moves, {:,} rotations".format(
        args.agents, args.steps, report.count(FOLLOWING), report.count(ROTATION)))
    print("{:>14}: best {:.3f} s, median {:.3f} s over {} runs".format(
        "validate", min(times), statistics.median(times), len(times)))


if __name__ == "__main__":
    main()
