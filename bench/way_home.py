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

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_manager_way_home import disabled_then_enabled  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=int)
    parser.add_argument("last", type=int)
    args = parser.parse_args()
    began = time.monotonic()
    failed, homes, margin = [], 0, float("inf")
    for seed in range(args.first, args.last):
        try:
            done, home, closest, safe = disabled_then_enabled(seed)
        except AssertionError as err:
            print("seed {}: {}".format(seed, str(err).splitlines()[0] if str(err) else "assertion"), flush=True)
            failed.append(seed)
            continue
        homes += home
        margin = min(margin, closest - safe)
        if not done or closest < safe - 0.01:
            failed.append(seed)
    print("{} runs in {:.0f} s: the way home taken in {}; {} did not hold {}; closest approach {:+.3f} cells "
          "from the safe distance".format(args.last - args.first, time.monotonic() - began, homes, len(failed),
                                          failed[:20], margin))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
