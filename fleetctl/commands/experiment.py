"""`fleetctl experiment SPEC.yaml`: a parameter sweep over the execution engine -> results table."""
from __future__ import annotations

import argparse
from pathlib import Path

from fleet_common.arg_types import integer

NAME = "experiment"
HELP = "run a sweep (plans x strategies x delay models x seeds) on simulated robots: a results table"
DESCRIPTION = (
    "Run every combination an experiment file lists (see evaluation/spec.py and EVALUATION.md) on "
    "the execution engine with simulated robots (and, with `chain: [engine, wire]`, also on virtual "
    "robots through the manager), and write one row per run to OUT/results.csv and "
    "OUT/results.parquet: executed makespan and sum of costs and their ratios to the plan's, waits "
    "(total, per robot, by blocker), collisions, robots at their goals, wall time. Runs on all "
    "local cores (--jobs), or on a Dask distributed cluster (--scheduler). Resumable: cells already "
    "in OUT/results.csv are not run again. Exit 0 when every run was free of collisions, 1 otherwise.")


#: More local workers than this is a typo, not a machine.
MAX_JOBS = 256


def _jobs(text: str) -> int:
    return integer(text, 1, MAX_JOBS, "a number of workers 1-{}".format(MAX_JOBS))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", type=Path, help="experiment file (YAML)")
    parser.add_argument("-o", "--out", type=Path, default=None, metavar="DIR",
                        help="results folder (default: SPEC's name with -results, here)")
    parser.add_argument("-j", "--jobs", type=_jobs, default=None, metavar="N",
                        help="local worker processes (default: every core; 1: in this process)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run on the Dask distributed scheduler at ADDRESS (tcp://HOST:PORT)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    import sys

    from evaluation.spec import read_experiment
    from evaluation.sweep import run_sweep
    from fleet_common.errors import FleetError

    if args.jobs is not None and args.jobs < 1:
        raise FleetError("--jobs must be at least 1")
    exp = read_experiment(args.spec)
    out = args.out or Path(args.spec.stem + "-results")
    try:
        result = run_sweep(exp, out, args.jobs, args.scheduler, None if args.quiet else sys.stderr)
    except OSError as err:
        if args.scheduler is not None and "connect" in str(err).lower():
            raise FleetError("cannot reach the Dask scheduler at {}: {}".format(args.scheduler, err)) from None
        raise
    collisions = sum(r["collisions"] for r in result.rows)
    print("{}: {} cells ({} run now, {} already done) in {:.1f} s on {} worker(s): {:,.0f} simulated "
          "robot-moves/s".format(exp.name, len(result.rows), result.ran, result.resumed, result.seconds,
                                 result.workers, result.moves_per_second))
    print("collisions: {} in {} runs".format(collisions, len(result.rows)))
    print("results: {} and {}".format(out / "results.csv", out / "results.parquet"))
    return 0 if collisions == 0 else 1
