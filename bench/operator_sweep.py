"""Rerouting beside the operator's hand, over more seeds than the tests run: refusals, safety, errors.

tests/test_execution_reroute.py runs 96 runs in which robots fail, are disabled and enabled
again and the strategy is switched mid-run, with a rule eager to reroute. It ran 36 until
2026-11-26: those seeds found nothing wrong, while a sweep over more found two unsafe runs and
an invalid plan (bench/README.md, "The robots predicted last"). This runs the same runs (`random_runs`'s
problems, `operator_case`, `operator_actions`; the strategy by plan and seed as the test
chooses it) for seeds FIRST..LAST-1 of every plan and prints each run that had a hand-over
refused, a pair of robots closer than the safe distance (true centres, in continuous time), a
robot not home, or an error, then the totals, and exits non-zero if there was any. 40 seeds
(960 runs) take 106 s with the held scope, 60 s with scope all, on the bench's machine.

    .venv/bin/python bench/operator_sweep.py [FIRST [LAST]] [--scope held|all]   # default 0 40 held
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the tests' random runs

from fleet_common.errors import FleetError  # noqa: E402
from fleet_common.execution.motion import Feedback  # noqa: E402
from fleet_common.execution.reroute import RerouteRule  # noqa: E402
from fleet_common.execution.simulate import simulate  # noqa: E402
from random_runs import PLAN_SEEDS, operator_actions, operator_case  # noqa: E402
from test_execution_reroute import EAGER, STRATEGIES  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=int, nargs="?", default=0)
    parser.add_argument("last", type=int, nargs="?", default=40)
    parser.add_argument("--scope", choices=("held", "all"), default="held")
    args = parser.parse_args()
    rule = EAGER if args.scope == "held" else RerouteRule(scope="all")
    print("rule: {}".format(rule))
    began = time.perf_counter()
    runs = rerouted = reroutes = last = refused = unsafe = unfinished = errors = 0
    for plan_seed in PLAN_SEEDS:
        for seed in range(args.first, args.last):
            plan, grid, rng, size, model = operator_case(plan_seed, seed, 28)
            controls = operator_actions(plan, rng, plan.makespan)
            strategy = STRATEGIES[(plan_seed + seed) % 3]
            runs += 1
            try:
                result = simulate(plan, strategy, model, seed=seed, size=size, reroute=rule, grid=grid,
                                  controls=controls, feedback=Feedback(0.05, float(rng.uniform(0.0, 0.3))))
            except FleetError as err:
                errors += 1
                print("plan {} seed {} ({}): error: {}".format(plan_seed, seed, strategy, err))
                continue
            rerouted += bool(result.reroutes)
            reroutes += len(result.reroutes)
            last += sum(r.last for _, r in result.reroutes)
            refused += result.refused
            close = result.safety.violations if result.safety is not None else ()
            unsafe += bool(close or result.collisions)
            unfinished += not result.finished
            if result.refused or close or result.collisions or not result.finished:
                worst = min(close, key=lambda v: v.distance) if close else None
                print("plan {} seed {} ({}): {} refused, {} too close{}, {}".format(
                    plan_seed, seed, strategy, result.refused, len(close),
                    "" if worst is None else " (robots {} at {:.2f} s, {:.3f} cells)".format(
                        worst.agents, worst.time, worst.distance),
                    "home" if result.finished else "not home"))
    print("{} runs in {:.0f} s: {} rerouted ({} reroutes, {} of the robots predicted last); {} refused, "
          "{} unsafe, {} not home, {} errors".format(runs, time.perf_counter() - began, rerouted, reroutes, last,
                                                    refused, unsafe, unfinished, errors))
    return 1 if refused or unsafe or unfinished or errors else 0


if __name__ == "__main__":
    sys.exit(main())
