"""Benchmark: encoding and decoding the two protocols' busiest messages.

The console protocol's State of 300 robots (what a manager sends 20 times a second to each
console; every robot moving, a tenth waiting, as in bench/console.py) and the robot protocol's
PoseFeedback (3,000 a second reach a manager of 300 robots), plus a drive command and a
Status (the general decoding path of the robot protocol). CPU time per call, best of
--repeat timings. With `--compare COMMIT` the fleet_common of that commit is extracted with
`git archive`, renamed `fleet_common_then` and imported beside this tree's, and the two are
timed alternately, one short timing each, --rounds x --repeat times, in one process: on a
shared machine a busy spell then hits both, and the ratio of the best times is what to read.

    .venv/bin/python bench/codecs.py [--repeat 7] [--compare 4b3a68d]
"""
from __future__ import annotations

import argparse
import importlib
import io
import os
import re
import subprocess
import sys
import tarfile
import tempfile
import time
import timeit
from pathlib import Path
from typing import Callable, List, Tuple

REPO = Path(__file__).resolve().parents[1]
ROBOTS = 300
Case = Tuple[str, Callable[[], object], int]


def cases(package: str = "fleet_common") -> List[Case]:
    """(name, work, calls per timing) with `package` (this tree's fleet_common, or another's)."""
    control = importlib.import_module(package + ".control.codec")
    cm = importlib.import_module(package + ".control.messages")
    wire = importlib.import_module(package + ".wire.codec")
    wm = importlib.import_module(package + ".wire.messages")

    side = 49
    starts = [(i % side, (i // side) * 2) for i in range(ROBOTS)]
    run = cm.RunInfo("running", "", "adg", 1, 12.5, 12.5, 1, 0, ROBOTS, None, 0, None)
    state = cm.State(7, 5, run, tuple(
        cm.RobotState(i + 1, "up", "", float(s[0]), s[1] + 0.35, 1.57, "robot", 0.05, False, (), None,
                      cm.Activity("drive", 3, float(s[0]), s[1] + 1.0), 3, 10, 4,
                      cm.Waiting((i + 2,), (s[0], s[1] + 1), "cell") if i % 10 == 0 and i + 1 < ROBOTS
                      else None, 0.0) for i, s in enumerate(starts)))
    state_frame = control.encode(state)
    pose = wm.PoseFeedback(12, 4711, wm.Pose(3.25, 7.5, 1.5707), 42, ())
    pose_frame = wire.encode(pose)
    pose_general = b"{ " + pose_frame[1:]  # not the fast path's shape: the general decoder
    drive = wm.DriveToPosition(7, 3.0, 4.0, 2.5)
    drive_frame = wire.encode(drive)
    status_frame = wire.encode(wm.Status(9, wm.Pose(1.0, 2.0, 0.5), None, ("bumper",)))
    accept = cm.MANAGER_MESSAGES
    assert control.decode(state_frame, accept, 1 << 28) == state
    assert wire.decode(pose_frame) == pose and wire.decode(pose_general) == pose
    return [
        ("State of {} robots, encode".format(ROBOTS), lambda: control.encode(state), 5),
        ("State of {} robots, decode".format(ROBOTS), lambda: control.decode(state_frame, accept, 1 << 28), 5),
        ("PoseFeedback, encode", lambda: wire.encode(pose), 2000),
        ("PoseFeedback, decode", lambda: wire.decode(pose_frame), 2000),
        ("PoseFeedback, decode (general path)", lambda: wire.decode(pose_general), 2000),
        ("DriveToPosition, encode", lambda: wire.encode(drive), 2000),
        ("DriveToPosition, decode", lambda: wire.decode(drive_frame), 2000),
        ("Status, decode", lambda: wire.decode(status_frame), 2000),
    ]


def best(work: Callable[[], object], n: int, repeat: int) -> float:
    """CPU seconds per call, best of `repeat` (CPU time: other processes on a shared machine
    slow a run less than they stretch its wall time)."""
    return min(timeit.repeat(work, number=n, repeat=repeat, timer=time.process_time)) / n


def extract(commit: str, into: Path) -> str:
    """fleet_common of `commit`, importable as `fleet_common_then` (its absolute imports of
    itself renamed; it imports nothing else of ours)."""
    data = subprocess.run(["git", "-C", str(REPO), "archive", commit, "catkin_ws/src/fleet_common/src"],
                          check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    src = into / "catkin_ws" / "src" / "fleet_common" / "src"
    (src / "fleet_common").rename(src / "fleet_common_then")
    for path in (src / "fleet_common_then").rglob("*.py"):
        path.write_text(re.sub(r"\bfleet_common\b", "fleet_common_then", path.read_text()))
    sys.path.insert(0, str(src))
    return "fleet_common_then"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--compare", metavar="COMMIT", help="also time this commit's fleet_common")
    parser.add_argument("--rounds", type=int, default=10, help="with --compare: alternations, x --repeat")
    args = parser.parse_args()
    print("load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    ours = cases()
    if not args.compare:
        for name, work, n in ours:
            print("{:<38} {:>10.1f} us".format(name, best(work, n, args.repeat) * 1e6))
        return
    with tempfile.TemporaryDirectory(prefix="bench-codecs-") as scratch:
        theirs = cases(extract(args.compare, Path(scratch)))
        print("{:<38} {:>12} {:>12} {:>8}".format("CPU per call", "this tree", args.compare, "ratio"))
        for (name, work, n), (_, then, _) in zip(ours, theirs):
            a, b = float("inf"), float("inf")
            for _ in range(args.rounds * args.repeat):  # alternately, so that a busy spell hits both
                a = min(a, best(work, n, 1))
                b = min(b, best(then, n, 1))
            print("{:<38} {:>9.1f} us {:>9.1f} us {:>7.2f}x".format(name, a * 1e6, b * 1e6, a / b))
    print("load average {:.2f} {:.2f} {:.2f} at the end".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
