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

import sys

from seeded_runs import main
from fleet_common.robot_size import TURTLEBOT2
from test_manager_resume import way_cut_by_a_dying_manager


def one(seed: int):
    home, nearest = way_cut_by_a_dying_manager(seed)
    return home and nearest >= TURTLEBOT2.safe_cells - 0.01, nearest


def closing(count: int, seconds: float, failed, nearest) -> str:
    closest = min(nearest, default=float("inf"))
    return "{} seeds in {:.0f} s: {} did not hold {}; closest approach {:.3f} cells ({:.3f} m; safe distance " \
        "{:.3f} m)".format(count, seconds, len(failed), failed[:20], closest, closest * TURTLEBOT2.cell,
                           TURTLEBOT2.safe)


if __name__ == "__main__":
    sys.exit(main(__doc__.splitlines()[0], one, closing))
