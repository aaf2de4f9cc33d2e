"""Sweep throughput: simulated robot-moves per second, one process against the local pool.

The same sweep (the 300-robot arena planned by PIBT and mapf-IR's 100-agent
pibt_sample.txt; adg and step; delay events with p = 0.1 of 1-5 moves; 12
seeds: 96 runs) is run twice in one go, first with `--jobs 1` (this process),
then on the process pool with every core, each into a fresh folder (the plans
are solved once, before the timing). Prints cells, moves, seconds and moves
per second of each, their ratio, and the load average before and after.

    .venv/bin/python bench/sweep.py
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

from evaluation.spec import Experiment, read_experiment
from evaluation.sweep import run_sweep

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "mapf-ir"
SPEC = """\
name: throughput
plans:
  - instance: {shared}/instances/arena_300agents_1.txt
    solver: pibt
  - solution: {shared}/solutions/pibt_sample.txt
strategies: [adg, step]
delays: ["events=bernoulli:0.1:1-5"]
seeds: 12
"""


def main() -> None:
    folder = Path(tempfile.mkdtemp(prefix="bench-sweep-"))
    try:
        spec = folder / "throughput.yaml"
        spec.write_text(SPEC.format(shared=SHARED))
        exp = read_experiment(spec)
        plans = folder / "plans"
        run_sweep(Experiment(exp.name, spec, exp.plans, exp.cells[:1]), plans, jobs=1,
                  progress=None)  # solve the plans once, untimed
        print("load average before: {:.2f} {:.2f} {:.2f}; {} cores".format(*os.getloadavg(), os.cpu_count()))
        rates = {}
        for label, jobs in (("single process", 1), ("local pool", None)):
            out = folder / label.replace(" ", "-")
            shutil.copytree(plans / "plans", out / "plans")
            result = run_sweep(exp, out, jobs=jobs, progress=None)
            rates[label] = result.moves_per_second
            print("{:<15} {} cells, {:,} moves in {:.2f} s on {} worker(s): {:,.0f} robot-moves/s".format(
                label, result.ran, result.moves, result.seconds, result.workers, result.moves_per_second))
        print("local pool / single process: {:.2f}x".format(rates["local pool"] / rates["single process"]))
        print("load average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
