"""A manager killed on the way to the starts, and another taking the way over: many seeds.

Each seed (tests/test_manager_resume.py `way_cut_by_a_dying_manager`): the lab
plan on five in-memory robots of a TurtleBot 2's size, stopped after a random
number of moves (or done), Reset (the robots drive back to their starts, a run
of its own), the manager killed at a random moment of that way, poses on time
or 0.2 s late, and a new manager taking over from the records, as `fleetctl
manager PLAN --resume` does. It holds when the robots end on their starts, the
plan then waits for Start and, started, takes every robot home, and no two
true centres came closer than the safe distance. Prints the seeds that did not
hold, and the closest approach over all.

    .venv/bin/python bench/way_resumes.py FIRST LAST
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fleet_common.robot_size import TURTLEBOT2  # noqa: E402
from test_manager_resume import way_cut_by_a_dying_manager  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=int)
    parser.add_argument("last", type=int)
    args = parser.parse_args()
    began = time.monotonic()
    failed, closest = [], float("inf")
    for seed in range(args.first, args.last):
        try:
            home, nearest = way_cut_by_a_dying_manager(seed)
        except AssertionError as err:
            home, nearest = False, float("inf")
            print("seed {}: {}".format(seed, str(err).splitlines()[0] if str(err) else "assertion"), flush=True)
        closest = min(closest, nearest)
        if not home or nearest < TURTLEBOT2.safe_cells - 0.01:
            failed.append(seed)
    print("{} seeds in {:.0f} s: {} did not hold {}; closest approach {:.3f} cells ({:.3f} m; safe distance "
          "{:.3f} m)".format(args.last - args.first, time.monotonic() - began, len(failed), failed[:20], closest,
                             closest * TURTLEBOT2.cell, TURTLEBOT2.safe))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
