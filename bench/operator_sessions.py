"""Random operator sessions over the in-memory manager, many seeds: does the run tell the truth?

Each session (tests/operator_sessions.py) runs the lab plan on five virtual robots with random
bumper presses and random operator presses (pause, start, step, halt, disable, enable, strategy,
replan and its answer), then the clean-up lab staff would do; it checks that the run ends, that
"done" means every robot is at its goal, that the summary counts exactly those, and that no two
robots came too close; a session that raises counts as one that found something. Prints each such
session, with what the operator did, and the count; exits non-zero if any did.

    .venv/bin/python bench/operator_sessions.py [FIRST LAST] [--wide] [--dying] [--vicon] [--carrying] [--big] [--faults]  # seeds FIRST..LAST-1, default 0 200

`--wide` varies the run as well (`session`'s `wide`): robots as large as a cell, any strategy from
the start, rerouting every robot, poses that reach the manager late. `--dying` (with `--wide`):
after a reset the manager dies on the way back to the starts in 7 of 10 cases, and another takes
the way over. `--vicon`: the manager reads a simulated Vicon stream, the run starts on either
position source, the operator switches sources at random and robots are occluded from Vicon.
`--carrying`: lab staff now and then pick up a robot standing still (most often one that is out)
and put it down elsewhere, well away from the others, on a cell or between two, or back.
`--big`: ten to sixteen robots on a random map 8-12 cells on a side instead of the lab's five.
`--faults`: the robots meet a delay model (late starts, slow drives, stalls anywhere in a move), and
now and then one robot loses its power alone and comes back a new process.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the tests' sessions

from operator_sessions import Session, session  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=int, nargs="?", default=0)
    parser.add_argument("last", type=int, nargs="?", default=200)
    parser.add_argument("--wide", action="store_true", help="vary the run too: size, strategy, scope, pose lag")
    parser.add_argument("--dying", action="store_true",
                        help="with --wide: the manager often dies on the way back to the starts after a reset")
    parser.add_argument("--vicon", action="store_true",
                        help="Vicon's stream too: random position sources, switches and occlusions")
    parser.add_argument("--big", action="store_true", help="ten to sixteen robots on a random map")
    parser.add_argument("--carrying", action="store_true",
                        help="lab staff now and then carry a robot standing still elsewhere, or back")
    parser.add_argument("--faults", action="store_true",
                        help="delays and stalls in the robots' moves; one robot's power cut now and then")
    args = parser.parse_args()
    began = time.perf_counter()
    bad = 0
    for seed in range(args.first, args.last):
        try:
            found = session(seed, args.wide, args.dying, args.vicon, args.carrying, args.big, args.faults)
        except Exception as err:  # the manager's worker turns such an error into "replanning failed"
            found = Session(seed, problems=["raised {}: {}".format(type(err).__name__, err)])
        if found.problems:
            bad += 1
            print("seed {}: {}".format(seed, "; ".join(found.problems)))
            for t, action, given, ok, reason in found.log:
                print("    {:6.1f} s  {} {} -> {}{}".format(t, action, given or "", "done" if ok else "refused",
                                                           ": " + reason if reason else ""))
    print("{} sessions in {:.0f} s: {} found something".format(args.last - args.first,
                                                               time.perf_counter() - began, bad))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
