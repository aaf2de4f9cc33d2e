"""Benchmark: what a State's `allowed` costs the manager (the run actions it would carry out now).

The manager's run core in memory (`tests/memory_fleet.py`: in-memory robots, a fake clock) on
arena_300agents_1 (a LaCAM plan), the robots standing on their goals, the run waiting: the
worst case, where Start needs every robot's pose against its start, and Go to starts and
Reset every robot's cell. Prints the time of one `operator.allowed` (and of its refusals each
worked out on its own, as before they shared what they look at), of one State with it
worked out again, and of one State when the core reuses it (it works it out again when
something decisive changes, else at most every `core.ALLOWED_EVERY` seconds).

    .venv/bin/python bench/run_actions.py [--robots 300] [--repeat 200]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from fleet_common.plan_loading import load_plan  # noqa: E402
from fleet_common.wire import Pose  # noqa: E402
from fleet_manager import operator  # noqa: E402
from fleet_manager.core import ALLOWED_EVERY  # noqa: E402
from memory_fleet import MemoryFleet, lab_fleet  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "mapf-ir"


def timed(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        began = time.perf_counter()
        fn()
        times.append((time.perf_counter() - began) * 1000.0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=300)
    parser.add_argument("--repeat", type=int, default=200)
    args = parser.parse_args()
    loaded = load_plan(DATA / "instances" / "arena_300agents_1.txt", args.robots, "bench",
                       [DATA / "maps"], solver="lacam")
    poses = {i + 1: Pose(float(g[0]), float(g[1]), 0.0) for i, g in enumerate(loaded.goals)}
    fleet = MemoryFleet(loaded, lab_fleet(args.robots), poses=poses)
    fleet.link_up()
    core, run, now = fleet.core, fleet.core.run, fleet.now
    allowed = timed(lambda: operator.allowed(run, now), args.repeat)
    from fleet_common.control import RUN_ACTIONS
    alone = timed(lambda: [operator.why_not(run, a, now) for a in RUN_ACTIONS], args.repeat)
    waits = core.waits()

    def fresh() -> None:
        core._allowed = None
        core.state(now, waits)

    print("{} robots on their goals, the run waiting; allowed = {}".format(args.robots, operator.allowed(run, now)))
    print("  operator.allowed:                      median {:6.2f} ms".format(allowed))
    print("  each refusal on its own (nothing shared): median {:6.2f} ms".format(alone))
    print("  a State, allowed worked out again:     median {:6.2f} ms".format(timed(fresh, args.repeat)))
    print("  a State, allowed reused (< {:g} s old): median {:6.2f} ms".format(
        ALLOWED_EVERY, timed(lambda: core.state(now, waits), args.repeat)))


if __name__ == "__main__":
    main()
