"""How often a reroute is dropped at the hand-over because robots moved while the look ran (issue 28).

The manager looks for a reroute on a snapshot in a worker thread and hands it
over in its loop; if a robot the reroute gives a new path made progress in
between, the hand-over drops it ("reroute dropped: ..."). Scope "all" may give
many robots new paths, so more can move meanwhile. This runs the lab plan (5
robots, the lab's map) through the manager's core in memory
(tests/memory_fleet.py: the core, the robots' command executors and virtual
kinematics, a fake clock) with robot 3 halting 12 s in its second move, auto
mode, each scope, and each look taking LAG seconds of fleet time before its
result reaches the loop (the robots move on meanwhile). Prints per scope and
lag: looks, reroutes handed over, reroutes dropped, every robot home, and the
closest pair of true centres (cells).

    .venv/bin/python bench/reroute_drops.py [--lags 0,0.25,0.5,1,2]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Tuple

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the in-memory fleet, as the tests use it

from fleet_common.lab import lab_instance_path  # noqa: E402
from fleet_common.plan_loading import load_plan  # noqa: E402
from fleet_manager.settings import ManagerSettings  # noqa: E402
from memory_fleet import MemoryFleet, lab_fleet  # noqa: E402

STALLED, MOVE, STALL = 3, 2, 12.0  # robot id, its move, seconds


def closest(f: MemoryFleet) -> float:
    poses = [r.navigator.true_pose() for r in f.robots.values()]
    return min(math.hypot(a.x - b.x, a.y - b.y) for i, a in enumerate(poses) for b in poses[i + 1:])


def run(scope: str, lag: float) -> Tuple[int, int, int, bool, float]:
    lab = load_plan(lab_instance_path(), 5, "the lab fleet", [])
    f = MemoryFleet(lab, lab_fleet(), ManagerSettings(step_time=2.0, reroute="auto", reroute_timed=False,
                                                      reroute_scope=scope), speed=0.5, turn_speed=1.5)
    f.robots[STALLED].navigator.stalls = {MOVE: STALL}
    f.hold_looks = True
    ops = f.console()
    f.link_up()
    assert f.ask(ops, "start").ok
    asked = None
    near = math.inf
    end = f.now + 300.0
    while f.phase != "done" and f.now < end:
        f.advance(0.05)
        near = min(near, closest(f))
        if f.looks and asked is None:
            asked = f.now
        if f.looks and asked is not None and f.now - asked >= lag - 1e-9:
            f.finish_looks()
            asked = None
    return (f.core.run.rerouting.looks, len(f.kinds("reroute")), len(f.kinds("reroute_dropped")),
            f.phase == "done" and f.at_goals(), near / 0.7)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lags", default="0,0.25,0.5,1,2")
    args = parser.parse_args()
    print("lab plan, robot {} halts {:g} s in its move {}; a look's result reaches the loop LAG s later".format(
        STALLED, STALL, MOVE))
    print("  {:<6} {:>6} {:>6} {:>9} {:>8} {:>6} {:>14}".format("scope", "lag s", "looks", "handed", "dropped",
                                                            "home", "closest cells"))
    for scope in ("held", "all"):
        for lag in (float(x) for x in args.lags.split(",")):
            looks, handed, dropped, home, near = run(scope, lag)
            print("  {:<6} {:>6.2f} {:>6} {:>9} {:>8} {:>6} {:>14.3f}".format(scope, lag, looks, handed, dropped,
                                                                        str(home), near))


if __name__ == "__main__":
    main()
