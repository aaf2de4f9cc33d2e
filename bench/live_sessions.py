"""Random operator sessions through the real chain (processes, sockets, wall clock), many seeds.

Each session (tests/live_sessions.py) runs the lab plan on `fleetctl virtual-fleet` and
`fleetctl manager` on 127.0.0.1 with random presses from a scripted console, restarts of the
manager and power cuts of the fleet or of one robot among them, then the clean-up; it is judged by the fleet's ground truth and the
manager's summary. Prints each session that found something, with what the operator did, and
the count; exits non-zero if any did. A session takes 20-60 s; its folder is kept only if it
found something (under --keep, default a temporary folder).

    .venv/bin/python bench/live_sessions.py [FIRST LAST] [--vicon] [-v] [--keep DIR]
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the tests' sessions

from live_sessions import LiveSession, live_session  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=int, nargs="?", default=0)
    parser.add_argument("last", type=int, nargs="?", default=20)
    parser.add_argument("--vicon", action="store_true",
                        help="Vicon's stream too (fleetctl vicon simulate): random sources, switches, occlusions")
    parser.add_argument("-v", "--verbose", action="store_true", help="print what every session did, not only those that found something")
    parser.add_argument("--keep", type=Path, default=None, metavar="DIR",
                        help="keep the folders of sessions that found something in DIR")
    args = parser.parse_args()
    keep = args.keep or Path(tempfile.mkdtemp(prefix="live-sessions-"))
    began = time.perf_counter()
    bad = 0
    for seed in range(args.first, args.last):
        folder = keep / "seed-{}".format(seed)
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        try:
            found = live_session(seed, folder, args.vicon)
        except Exception as err:  # the harness itself could not go on: say so, go on
            found = LiveSession(seed, problems=["raised {}: {}".format(type(err).__name__, err)])
        if found.problems or args.verbose:
            bad += bool(found.problems)
            print("seed {}: {} (folder {})".format(seed, "; ".join(found.problems) or "nothing found", folder))
            for t, action, given, ok, reason in found.log:
                print("    {:6.1f} s  {} {} -> {}{}".format(t, action, given or "", "done" if ok else "refused",
                                                           ": " + reason if reason else ""))
        if not found.problems:
            shutil.rmtree(folder, ignore_errors=True)
        sys.stdout.flush()
    print("{} sessions in {:.0f} s: {} found something".format(args.last - args.first,
                                                               time.perf_counter() - began, bad))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
