"""Benchmark: update + start on 5 and on 20 loopback robots, in parallel and one by one.

Each "robot" is a real sshd on its own loopback address (127.0.0.2, .3, ...;
deploy.loopback), logged into with a key, pinned host keys; the code comes
from a local bare git repository. After one `init`, each round pushes a new
commit, then times `robots:update all` followed by `robots:start all` (one
stub process per robot, with the default start check of 1 s), each a fan-out
as the command line runs it (deploy.fanout.run_all), and stops the robots
untimed. `--jobs 0` is all at once, `--jobs 1` one by one. Prints the best
and median of the rounds and the ratio.

    .venv/bin/python bench/deploy.py [--robots 5 20] [--rounds 3]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Tuple

# This file is bench/deploy.py: run as a script, its folder comes first on sys.path and
# `import deploy` would find this file instead of the deploy package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

from deploy.config import parse_config  # noqa: E402
from deploy.fanout import run_all  # noqa: E402
from deploy.loopback import LoopbackLab  # noqa: E402
from deploy.remote import steps  # noqa: E402
from deploy.ssh import run_steps  # noqa: E402
from deploy.targets import Target, robot_targets  # noqa: E402
from fleet_common.robots import parse_robot_definitions  # noqa: E402

CONFIG = """\
repository: {origin}
login_key: {key}
known_hosts: {known}
robots:
  port: {port}
  build: 'true'
  processes:
    runner: exec sleep 600
"""


def git(folder: Path, *args: str) -> None:
    env = dict(os.environ, GIT_AUTHOR_NAME="b", GIT_AUTHOR_EMAIL="b@lab",
               GIT_COMMITTER_NAME="b", GIT_COMMITTER_EMAIL="b@lab")
    subprocess.run(["git", *args], cwd=folder, env=env, check=True, capture_output=True)


def fan_out(action: str, targets: List[Target], config: object, jobs: int) -> float:
    start = time.perf_counter()
    outcomes = run_all(targets, lambda t, log: run_steps(
        t, config, steps(action, t, config), False, log), action, None, jobs)  # type: ignore
    seconds = time.perf_counter() - start
    failed = [o for o in outcomes if not o.ok]
    if failed:
        raise SystemExit("{} failed on {}: {}".format(action, failed[0].target.name,
                                                        failed[0].detail))
    return seconds


def measure(count: int, rounds: int, tmp: Path) -> Dict[int, List[Tuple[float, float]]]:
    lab = LoopbackLab(tmp / "lab{}".format(count), count)
    source = tmp / "src{}".format(count)
    source.mkdir()
    git(source, "init", "-q", "-b", "main")
    (source / "README").write_text("0\n")
    git(source, "add", "README")
    git(source, "commit", "-qm", "0")
    origin = tmp / "origin{}.git".format(count)
    git(tmp, "clone", "-q", "--bare", str(source), str(origin))
    git(source, "remote", "add", "origin", str(origin))
    config = parse_config(CONFIG.format(origin=origin, key=lab.client_key, known=lab.known_hosts,
                                        port=lab.port), str(tmp / "deploy.yaml"))
    robots = parse_robot_definitions("".join("{} {} {} {} r{} red\n".format(
        i + 1, h.address, 20000 + i, lab.user, i + 1) for i, h in enumerate(lab.hosts)))
    targets = robot_targets(config, robots)
    times: Dict[int, List[Tuple[float, float]]] = {0: [], 1: []}
    try:
        lab.start()
        lab.pin_host_keys()
        fan_out("init", targets, config, 0)
        for n in range(rounds):
            for jobs in (0, 1):
                (source / "README").write_text("{} {}\n".format(n, jobs))
                git(source, "commit", "-qam", "round {} jobs {}".format(n, jobs))
                git(source, "push", "-q", "origin", "main")
                update = fan_out("update", targets, config, jobs)
                start = fan_out("start", targets, config, jobs)
                times[jobs].append((update, start))
                fan_out("stop", targets, config, 0)
    finally:
        lab.close()
    return times


def report(count: int, times: Dict[int, List[Tuple[float, float]]]) -> None:
    totals = {jobs: [u + s for u, s in runs] for jobs, runs in times.items()}
    for jobs, label in ((0, "parallel"), (1, "one by one")):
        runs = times[jobs]
        print("{:3d} robots  {:<10}  update best {:6.2f} s  start best {:6.2f} s  update+start "
              "best {:6.2f} s, median {:6.2f} s".format(
                  count, label, min(u for u, _ in runs), min(s for _, s in runs),
                  min(totals[jobs]), statistics.median(totals[jobs])))
    print("{:3d} robots  one by one / parallel (medians): {:.1f}x".format(
        count, statistics.median(totals[1]) / statistics.median(totals[0])))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[5, 20])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    with tempfile.TemporaryDirectory(prefix="bench-deploy-") as tmp:
        for count in args.robots:
            report(count, measure(count, args.rounds, Path(tmp)))
    print("load average after:  {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
