"""What bench/way_home.py and bench/way_resumes.py share: seeds FIRST..LAST-1 of a seeded run from
the tests, each judged, the ones that did not hold printed and counted (exit 1 if any)."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any, Callable, List, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the tests' seeded runs

#: one seed's run: (it held, its figures for the closing line), or AssertionError
Run = Callable[[int], Tuple[bool, Any]]


def main(description: str, run: Run, closing: Callable[[int, float, List[int], List[Any]], str]) -> int:
    """Run seeds from the command line (`FIRST LAST`); `closing(count, seconds, failed, figures)` is
    the last line printed."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("first", type=int)
    parser.add_argument("last", type=int)
    args = parser.parse_args()
    began = time.monotonic()
    failed: List[int] = []
    figures: List[Any] = []
    for seed in range(args.first, args.last):
        try:
            held, figure = run(seed)
        except AssertionError as err:
            print("seed {}: {}".format(seed, str(err).splitlines()[0] if str(err) else "assertion"), flush=True)
            failed.append(seed)
            continue
        figures.append(figure)
        if not held:
            failed.append(seed)
    print(closing(args.last - args.first, time.monotonic() - began, failed, figures))
    return 1 if failed else 0
