"""Robots enabled again where a replan left them, given a way home while the run goes on: many seeds.

Each seed (tests/test_manager_way_home.py `disabled_then_enabled`): the lab's
five robots or eight between random cells (LaCAM), a TurtleBot 2's size or a
cell's, ADG, re-ordering or the time step, poses on time or 0.2 s late; a
random robot disabled after a random number of moves, a replan for the others,
then the robot enabled a random while later. Prints how often the way home was
taken (else a replan took the robot home, or it was enabled after the end),
the runs where a robot did not get home or two true centres came closer than
the safe distance, and the closest approach over all, in cells of 0.7 m.

    .venv/bin/python bench/way_home.py FIRST LAST
"""
from __future__ import annotations

import sys

from seeded_runs import main
from test_manager_way_home import disabled_then_enabled

def one(seed: int):
    done, home, closest, safe = disabled_then_enabled(seed)
    return done and closest >= safe - 0.01, (home, closest - safe)


def closing(count: int, seconds: float, failed, figures) -> str:
    return "{} runs in {:.0f} s: the way home taken in {}; {} did not hold {}; closest approach {:+.3f} cells " \
        "from the safe distance".format(count, seconds, sum(home for home, _ in figures), len(failed), failed[:20],
                                        min((margin for _, margin in figures), default=float("inf")))


if __name__ == "__main__":
    sys.exit(main(__doc__.splitlines()[0], one, closing))
