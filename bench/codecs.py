"""Benchmark: encoding and decoding the two protocols' busiest messages.

The console protocol's State of 300 robots (what a manager sends 20 times a second to each
console; every robot moving, a tenth waiting, as in bench/console.py) and the robot protocol's
PoseFeedback (3,000 a second reach a manager of 300 robots), plus a drive command and a
Status (the general decoding path of the robot protocol). Best of --repeat runs, per
message. With `--compare COMMIT` the same is measured with the fleet_common of that commit
(extracted with `git archive` into a temporary folder, first on PYTHONPATH of a child
process), alternately with this tree's, in one run: compare the ratios, not the absolute
times, on a shared machine.

    .venv/bin/python bench/codecs.py [--repeat 7] [--compare 4b3a68d]
"""
from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import timeit
from pathlib import Path
from typing import Callable, Dict, List, Tuple

REPO = Path(__file__).resolve().parents[1]
ROBOTS = 300


def cases() -> List[Tuple[str, Callable[[], object], int]]:
    """(name, work, calls per timing) with whatever fleet_common is first on the path."""
    from fleet_common.control import codec as control
    from fleet_common.control.messages import (MANAGER_MESSAGES, Activity, RobotState, RunInfo, State,
                                               Waiting)
    from fleet_common.wire import codec as wire
    from fleet_common.wire.messages import DriveToPosition, Pose, PoseFeedback, Status

    side = 49
    starts = [(i % side, (i // side) * 2) for i in range(ROBOTS)]
    run = RunInfo("running", "", "adg", 1, 12.5, 12.5, 1, 0, ROBOTS, None, 0, None)
    state = State(7, 5, run, tuple(
        RobotState(i + 1, "up", "", float(s[0]), s[1] + 0.35, 1.57, "robot", 0.05, False, (), None,
                   Activity("drive", 3, float(s[0]), s[1] + 1.0), 3, 10, 4,
                   Waiting((i + 2,), (s[0], s[1] + 1), "cell") if i % 10 == 0 and i + 1 < ROBOTS else None,
                   0.0) for i, s in enumerate(starts)))
    state_frame = control.encode(state)
    pose = PoseFeedback(12, 4711, Pose(3.25, 7.5, 1.5707), 42, ())
    pose_frame = wire.encode(pose)
    pose_general = b"{ " + pose_frame[1:]  # not the fast path's shape: the general decoder
    drive = DriveToPosition(7, 3.0, 4.0, 2.5)
    drive_frame = wire.encode(drive)
    status_frame = wire.encode(Status(9, Pose(1.0, 2.0, 0.5), None, ("bumper",)))
    assert control.decode(state_frame, MANAGER_MESSAGES, 1 << 28) == state
    assert wire.decode(pose_frame) == pose and wire.decode(pose_general) == pose
    return [
        ("State of {} robots, encode".format(ROBOTS), lambda: control.encode(state), 20),
        ("State of {} robots, decode".format(ROBOTS),
         lambda: control.decode(state_frame, MANAGER_MESSAGES, 1 << 28), 20),
        ("PoseFeedback, encode", lambda: wire.encode(pose), 20000),
        ("PoseFeedback, decode", lambda: wire.decode(pose_frame), 20000),
        ("PoseFeedback, decode (general path)", lambda: wire.decode(pose_general), 20000),
        ("DriveToPosition, encode", lambda: wire.encode(drive), 20000),
        ("DriveToPosition, decode", lambda: wire.decode(drive_frame), 20000),
        ("Status, decode", lambda: wire.decode(status_frame), 20000),
    ]


def measure(repeat: int) -> Dict[str, float]:
    """Seconds per call, best of `repeat`, for every case."""
    return {name: min(timeit.repeat(work, number=n, repeat=repeat)) / n for name, work, n in cases()}


def extract(commit: str, into: Path) -> Path:
    data = subprocess.run(["git", "-C", str(REPO), "archive", commit, "catkin_ws/src/fleet_common/src"],
                          check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    return into / "catkin_ws" / "src" / "fleet_common" / "src"


def child(path: Path, repeat: int) -> Dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(path))
    out = subprocess.run([sys.executable, __file__, "--json", "--repeat", str(repeat)], env=env,
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--compare", metavar="COMMIT", help="also measure this commit's fleet_common")
    parser.add_argument("--rounds", type=int, default=3, help="alternations with --compare")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.repeat)))
        return
    print("load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    if not args.compare:
        for name, seconds in measure(args.repeat).items():
            print("{:<38} {:>10.1f} us".format(name, seconds * 1e6))
        return
    ours_path = REPO / "catkin_ws" / "src" / "fleet_common" / "src"
    with tempfile.TemporaryDirectory(prefix="bench-codecs-") as scratch:
        theirs_path = extract(args.compare, Path(scratch))
        ours: Dict[str, float] = {}
        theirs: Dict[str, float] = {}
        for _ in range(args.rounds):  # alternately, so that a busy spell hits both
            for into, path in ((theirs, theirs_path), (ours, ours_path)):
                for name, seconds in child(path, args.repeat).items():
                    into[name] = min(into.get(name, seconds), seconds)
    print("{:<38} {:>12} {:>12} {:>8}".format("", "this tree", args.compare, "ratio"))
    for name in ours:
        print("{:<38} {:>9.1f} us {:>9.1f} us {:>7.2f}x".format(name, ours[name] * 1e6, theirs[name] * 1e6,
                                                              ours[name] / theirs[name]))
    print("load average {:.2f} {:.2f} {:.2f} at the end".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
