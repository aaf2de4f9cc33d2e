"""Benchmark: how fast and in how little memory a huge broken file is refused (issue 11).

Writes a 50 MB instance whose line 33 puts an agent off the map (tests/helpers.py's
`big_broken_instance`: 27 good agent lines, the bad one, 50 MB of comment lines; a reader
that checks cells after reading everything finds it last) and a 50 MB solution whose row at line 33
is broken, and runs `fleetctl info FILE` on each in a fresh process, --repeat times: wall
time (best and median) and the process's peak RSS (getrusage of the child). The lab
instance (a few lines) is the baseline: starting Python and importing. With `--compare COMMIT` it
runs the same with the fleet_common and fleetctl of that commit (extracted with
`git archive` into a temporary folder, put first on PYTHONPATH), in the same run.

    .venv/bin/python bench/hostile_files.py [--repeat 3] [--compare f921c10]
"""
from __future__ import annotations

import argparse
import io
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Optional, Tuple

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from helpers import big_broken_instance  # noqa: E402 (the test suite's own generator)
SIZE = 50_000_000
PROBE = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], capture_output=True, "
         "text=True); print(p.returncode); print(resource.getrusage(resource.RUSAGE_CHILDREN)"
         ".ru_maxrss); sys.stderr.write(p.stderr)")


def broken_solution(folder: Path) -> Path:
    path = folder / "big_solution.txt"
    with open(path, "w") as f:
        f.write("instance=big.txt\nagents=2\nmap_file=lab.map\nsolver=none\nsolved=1\nsoc=0\n"
                "makespan=0\ncomp_time=0\nstarts=(1,5),(11,8),\ngoals=(1,5),(11,8),\nsolution=\n")
        t = 0
        while f.tell() < SIZE:
            rows = []
            for _ in range(10_000):
                # line 33 is row t = 21: an entry with a heading where the others have none
                rows.append("{}:(1,5),(11,8,X_PLUS),\n".format(t) if t == 21 else
                            "{}:(1,5),(11,8),\n".format(t))
                t += 1
            f.write("".join(rows))
    return path


def extract(commit: str, into: Path) -> Path:
    """fleet_common and fleetctl of `commit`, importable from the returned folder."""
    data = subprocess.run(["git", "-C", str(REPO), "archive", commit,
                           "catkin_ws/src/fleet_common/src", "fleetctl"],
                          check=True, capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        tar.extractall(into)
    return into


def run_once(path: Path, pythonpath: Optional[str]) -> Tuple[float, int, int, str]:
    """(wall s, exit status, peak RSS in MB, first line of stderr) of `fleetctl info path`."""
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", PROBE, sys.executable, "-m", "fleetctl", "info",
                           str(path)], capture_output=True, text=True, env=env,
                          cwd=str(path.parent))  # not the checkout: `-m` looks in the cwd first
    wall = time.perf_counter() - start
    status, rss_kb = (int(v) for v in proc.stdout.split())
    return wall, status, rss_kb // 1024, (proc.stderr.splitlines() or [""])[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--compare", metavar="COMMIT", default=None,
                        help="also run the readers of this commit (e.g. f921c10, before issue 11)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        from fleet_common.lab import lab_instance_path

        files = [lab_instance_path(), big_broken_instance(folder / "big_instance.txt"),
                 broken_solution(folder)]
        versions: Dict[str, Optional[str]] = {"this branch": None}
        if args.compare:
            old = extract(args.compare, folder / "old")
            versions[args.compare] = os.pathsep.join(
                [str(old / "catkin_ws/src/fleet_common/src"), str(old)])
        print("load average {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(),
                                                                   os.cpu_count()))
        print("{:<18} {:<12} {:>6} {:>9} {:>11} {:>8}  message".format(
            "file", "readers", "exit", "best s", "median s", "RSS MB"))
        for path in files:
            for name, pythonpath in versions.items():
                runs: List[Tuple[float, int, int, str]] = [
                    run_once(path, pythonpath) for _ in range(args.repeat)]
                walls = [r[0] for r in runs]
                print("{:<18} {:<12} {:>6} {:>9.2f} {:>11.2f} {:>8}  {}".format(
                    path.name, name, runs[0][1], min(walls), statistics.median(walls),
                    max(r[2] for r in runs), runs[0][3][len(str(path)):][:90]))


if __name__ == "__main__":
    main()
