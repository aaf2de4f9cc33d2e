"""Benchmark: the timing of one simulated TurtleBot under ROS, as the manager sees it.

What tests/test_ros_sim_robot.py checks without a clock, this measures: roscore and
sim_robot.launch (the agv_runner node on the simulated base) with the manager's own link
(`tests/sim_robot.py`), then

- pose feedback: messages a second the robot sends (its seq numbers over the receiving
  clock) and the largest gap between two, over --seconds;
- a drive of two cells asked to arrive in 8 s (driveToPosition's `time`): how long it took;
- the same drive back as fast as allowed (`time` 0);
- a bumper press during a drive: press -> `Failed` at the manager, and press -> the base at
  rest (simulator's ground truth; 1 mm over 0.25 s).

As root it runs itself in a fresh network namespace with only a loopback interface
(roscore's rosout listens on every interface; see tests/ros_procs.py), else on 127.0.0.1.

    .venv/bin/python bench/sim_robot.py [--seconds 10]
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from sim_robot import START, running_sim_robot  # noqa: E402

INSIDE = "FLEETCONTROL_BENCH_NETNS"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="pose feedback measured this long")
    args = parser.parse_args()
    if os.environ.get(INSIDE) != "1" and os.geteuid() == 0 and shutil.which("unshare") and shutil.which("ip"):
        script = 'ip link set lo up && exec "$0" "$@"'
        sys.exit(subprocess.run(["unshare", "--net", "--", "sh", "-c", script, sys.executable, *sys.argv],
                                env=dict(os.environ, **{INSIDE: "1"})).returncode)
    print("load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))
    with tempfile.TemporaryDirectory(prefix="bench-sim-robot-") as home, running_sim_robot(Path(home)) as robot:
        manager, observer = robot.manager, robot.observer
        feedback = manager.feedback_since(args.seconds)
        seqs = [m.seq for _, m in feedback]
        times = [t for t, _ in feedback]
        rate = (seqs[-1] - seqs[0]) / (times[-1] - times[0])
        gap = max(b - a for a, b in zip(times, times[1:]))
        print("pose feedback: {:.1f} a second over {:.0f} s ({} received), largest gap {:.0f} ms".format(
            rate, times[-1] - times[0], len(seqs), gap * 1000))
        x, y = START
        replies, took = manager.run(lambda link: link.drive_to_position(x + 2.0, y, 8.0))
        print("drive of 2 cells asked to arrive in 8 s: {} in {:.2f} s ({:+.2f} s)".format(
            replies[-1].TYPE, took, took - 8.0))
        robot.settle()
        replies, took = manager.run(lambda link: link.drive_to_position(x, y, 0.0))
        print("the same drive back as fast as allowed: {} in {:.2f} s".format(replies[-1].TYPE, took))
        robot.settle()
        before = observer.latest_truth()
        manager.send(lambda link: link.drive_to_position(x + 2.0, y, 0.0))
        manager.receive(10.0)
        manager.wait_for(lambda: observer.latest_truth().distance_to(before) > 0.3, 20.0, "the drive under way")
        pressed = time.monotonic()
        observer.press_bumper(2)
        failed = manager.receive(5.0)
        told = time.monotonic() - pressed
        manager.wait_for(observer.at_rest, 5.0, "the base at rest")
        rest = time.monotonic() - pressed - 0.25  # at rest since the start of that window
        print("bumper pressed mid-drive: {} at the manager after {:.0f} ms; base at rest after "
              "{:.0f} ms".format(failed.TYPE, told * 1000, rest * 1000))
        observer.press_bumper(0)
    print("load average {:.2f} {:.2f} {:.2f} at the end".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
