"""Whole processes against whole processes: `fleetctl solve` beside mapf-IR's `app`, as users run them.

Used by `bench/solvers.py` (its first table).

Each case runs both programs on the same instance file, alternately, `repeats`
times; a figure is the best wall time from start to exit (and the peak memory
of that process), so both pay for start-up, reading, distance tables, the
search and writing the result. The ratio is ours over theirs in the same run, by wall time and (in brackets) by
CPU time, which other programs on the machine disturb less.
Beside it, labelled "in-process", the same solver called inside this process
(`solve()`, a freshly read grid each time): what the Python API costs without
interpreter start-up and file handling.

mapf-IR is found by $MAPF_IR_APP, or built from a checkout of Kei18/mapf-IR
(with its grid-pathfinding submodule) given by --mapf-ir-src: only its `app`
target, Release, into <checkout>/build-fleetcontrol, nothing written elsewhere.
"""
from __future__ import annotations

import os
import random
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

from fleet_common.formats.instance import make_instance, read_instance, write_instance
from fleet_common.formats.solution import read_solution
from fleet_common.planning import solve
from fleet_common.planning.components import component_labels
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.mapf_ir import APP_ENV, find_map_dir, resolve_app

FLEETCTL = str(Path(sys.executable).with_name("fleetctl"))
GNU_TIME = "/usr/bin/time"
#: The dense case: this many agents on random-32-32-20's 819 free cells (mapf-IR's PIBT fails there).
DENSE_AGENTS = 400
#: Time limit of the anytime LaCAM (LaCAM*) row.
ANYTIME_S = 10.0
#: Builds only mapf-IR's `app` (its own root CMakeLists also wants googletest for its tests).
_WRAPPER = """cmake_minimum_required(VERSION 3.16)
project(mapf-ir-app CXX)
set(CMAKE_CXX_FLAGS "${{CMAKE_CXX_FLAGS}} -include cstring")  # older sources omit <cstring>
add_subdirectory({src}/mapf mapf)
add_executable(app {src}/app.cpp)
target_compile_features(app PUBLIC cxx_std_17)
target_link_libraries(app lib-mapf)
"""


def build_mapf_ir(src: Path) -> Path:
    """mapf-IR's `app`, built (once) from the checkout `src` into src/build-fleetcontrol."""
    build = src / "build-fleetcontrol"
    app = build / "app"
    if app.is_file():
        return app
    submodule = src / "third_party" / "grid-pathfinding" / "graph" / "CMakeLists.txt"
    if not (src / "mapf" / "CMakeLists.txt").is_file() or not submodule.is_file():
        raise SystemExit("{} is not a mapf-IR checkout with its grid-pathfinding submodule".format(src))
    wrapper = build / "wrapper"
    wrapper.mkdir(parents=True, exist_ok=True)
    (wrapper / "CMakeLists.txt").write_text(_WRAPPER.format(src=src.resolve()))
    subprocess.run(["cmake", "-S", str(wrapper), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release"], check=True,
                   stdout=subprocess.DEVNULL)
    subprocess.run(["make", "-C", str(build), "-j", str(os.cpu_count() or 1), "app"], check=True,
                   stdout=subprocess.DEVNULL)
    return app


@dataclass
class Run:
    """One program's figures on one case: best wall time, its peak RSS, and what it printed or wrote."""

    ms: float = float("inf")
    cpu_s: float = float("inf")  # user + system seconds of the run with the best wall time
    rss_mb: float = 0.0
    status: str = "-"
    soc: Optional[int] = None
    note: str = ""
    times: List[float] = field(default_factory=list)


def timed(argv: Sequence[str], cwd: Optional[str] = None,
          limit_s: float = 600.0) -> Tuple[float, float, float, int, str]:
    """(wall ms, CPU s, peak RSS MB, exit status, output) of one whole process.

    The peak RSS comes from GNU time (`/usr/bin/time -f %M`), which forks the
    program from its own small process: a child forked from this (large)
    Python process would report this process's size as its peak. Without GNU
    time they are NaN. CPU time (user + system) suffers less than wall time
    when other programs share the machine.
    """
    rss_file = tempfile.NamedTemporaryFile(prefix="fleetcontrol-rss-", delete=False)
    rss_file.close()
    wrap = [GNU_TIME, "-f", "%U %S %M", "-o", rss_file.name] if os.access(GNU_TIME, os.X_OK) else []
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(wrap + list(argv), cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              timeout=limit_s)
        code, out = proc.returncode, proc.stdout.decode("utf-8", "replace")
    except subprocess.TimeoutExpired:
        code, out = -9, "killed after {:.0f} s".format(limit_s)
    ms = (time.perf_counter() - t0) * 1000.0
    text = Path(rss_file.name).read_text().split()
    os.unlink(rss_file.name)
    rss = float(text[-1]) / 1024.0 if text and text[-1].isdigit() else float("nan")
    cpu = float(text[-3]) + float(text[-2]) if len(text) >= 3 else float("nan")
    if wrap and text and text[0] == "Command":  # "Command terminated by signal N" / "... exit status N"
        words = " ".join(text[:-3]).split()
        if "signal" in words:
            code = -int(words[words.index("signal") + 1])
    return ms, cpu, rss, code, out


def record(run: Run, ms: float, cpu: float, rss: float, code: int, out: str, result: Path, maps: Path) -> None:
    run.times.append(ms)
    if ms < run.ms:
        run.ms, run.rss_mb = ms, rss
    run.cpu_s = min(run.cpu_s, cpu)
    if code < 0:
        run.status, run.note = "crashed", "signal {}".format(-code)
        return
    try:
        sol = read_solution(str(result), map_dirs=[maps]) if result.is_file() else None
    except Exception as err:  # noqa: BLE001 - a benchmark reports what it got
        sol, run.note = None, "unreadable output: {}".format(err)
    if sol is not None and sol.solved:
        run.status, run.soc = "solved", sol.plan.soc if sol.plan is not None else None
    elif sol is not None:
        run.status = "failed (solved=0)"
    else:
        run.status = "exit {}".format(code)
        lines = [ln for ln in out.strip().splitlines() if ln.strip()]
        run.note = run.note or (lines[-1][:60] if lines else "")


@dataclass
class Case:
    label: str
    instance: Path
    ours: str  # fleetctl solve -s ...
    theirs: Tuple[str, ...]  # mapf-IR solver names
    anytime_s: float = 0.0  # > 0: ours is `-s lacam --anytime` with this time limit, run once

    @property
    def extra(self) -> Tuple[str, ...]:
        return ("--anytime", "--time-limit", "{:g}".format(self.anytime_s)) if self.anytime_s else ()


def dense_instance(data: Path, folder: Path, agents: int, seed: int) -> Path:
    """`agents` random starts and goals on random-32-32-20, all in its largest component."""
    base = read_instance(data / "instances" / "random-32-32-20_30agents_1.txt", [data / "maps"])
    grid = base.grid
    labels = component_labels(grid)
    cells = [c for c in grid.free_cells() if labels[grid.index(c)] >= 0]
    big = max(set(labels[grid.index(c)] for c in cells), key=lambda k: sum(labels[grid.index(c)] == k for c in cells))
    cells = [c for c in cells if labels[grid.index(c)] == big]
    rng = random.Random(seed)
    starts, goals = rng.sample(cells, agents), rng.sample(cells, agents)
    path = folder / "random-32-32-20_{}agents_dense.txt".format(agents)
    write_instance(make_instance(grid, "random-32-32-20.map", starts, goals, seed=seed, max_timestep=1000,
                                 max_comp_time=30000), str(path))
    return path


def first_agents(data: Path, folder: Path, name: str, agents: int) -> Path:
    inst = read_instance(data / "instances" / (name + ".txt"), [data / "maps"])
    path = folder / "{}_first{}.txt".format(name, agents)
    write_instance(make_instance(inst.grid, inst.map_file, inst.starts[:agents], inst.goals[:agents], seed=inst.seed or 0,
                                 max_timestep=inst.max_timestep or 5000, max_comp_time=inst.max_comp_time or 60000),
                   str(path))
    return path


def in_process(case: Case, data: Path, repeats: int) -> str:
    best = float("inf")
    result = None
    for _ in range(repeats):
        inst = read_instance(case.instance, [data / "maps"])
        opts = {"anytime": True} if case.anytime_s else {}
        limit = case.anytime_s or (inst.max_comp_time / 1000.0 if inst.max_comp_time else 60.0)
        t0 = time.perf_counter()
        result = solve(case.ours, inst.grid, inst.starts, inst.goals, seed=inst.seed or 0,
                       deadline=Deadline(limit), max_timestep=inst.max_timestep, **opts)
        best = min(best, (time.perf_counter() - t0) * 1000.0)
    assert result is not None
    soc = ", soc {}".format(result.plan.soc) if result.plan is not None else ""
    history = result.stats.get("anytime")
    if history:  # LaCAM*: the sum of costs at each improvement
        print("{:>34}  in-process LaCAM*, soc over time: {}".format("", ", ".join(
            "{} at {:.1f} s".format(soc_, ms / 1000) for ms, soc_ in history)))
    return "{:.0f} ms ({}{})".format(best, result.status, soc)


def find_app(src: Optional[Path]) -> Optional[Path]:
    """mapf-IR's app: $MAPF_IR_APP, else built from the checkout `src`, else None."""
    if os.environ.get(APP_ENV):
        return resolve_app(None)
    if src is not None:
        return build_mapf_ir(src)
    return None


def run(app: Path, data: Path, repeats: int, only: Sequence[str] = ()) -> None:
    """Print the side-by-side table (see the module docstring)."""
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # a crashing mapf-IR leaves no core file
    map_dir = find_map_dir(app)
    work = Path(tempfile.mkdtemp(prefix="fleetcontrol-bench-"))
    inst_dir = data / "instances"
    cases = [
        Case("arena 300, PIBT", inst_dir / "arena_300agents_1.txt", "pibt", ("PIBT",)),
        Case("brc202d 1500, PIBT", inst_dir / "brc202d_1500agents_1.txt", "pibt", ("PIBT",)),
        Case("random-32-32-20 first 25, CBS", first_agents(data, work, "random-32-32-20_30agents_1", 25), "cbs",
             ("CBS",)),
        Case("random-32-32-20 30, CBS", inst_dir / "random-32-32-20_30agents_1.txt", "cbs", ("CBS",)),
    ]
    dense = dense_instance(data, work, DENSE_AGENTS, 0)
    cases += [
        Case("dense random-32-32-20 {}, LaCAM".format(DENSE_AGENTS), dense, "lacam", ("PIBT", "PIBT_COMPLETE")),
        Case("dense random-32-32-20 {}, LaCAM*".format(DENSE_AGENTS), dense, "lacam", (), anytime_s=ANYTIME_S),
    ]
    cases = [c for c in cases if not only or any(o in c.label for o in only)]
    for case in cases:  # mapf-IR opens map_file= in its compiled-in map folder
        map_file = read_instance(case.instance, [data / "maps"]).map_file
        if not (map_dir / map_file).is_file():
            raise SystemExit("{} is not in mapf-IR's map folder {}".format(map_file, map_dir))
    print("machine: {} | nproc {} | Python {} | {}".format(_cpu(), os.cpu_count(), sys.version.split()[0],
                                                         time.strftime("%Y-%m-%d %H:%M")))
    print("mapf-IR: {}; ours: {}".format(app, FLEETCTL))
    print("load average before: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    print()
    head = ("case", "program", "status", "best wall", "best CPU", "peak RSS", "soc", "ours/theirs",
            "in-process (ours)")
    rows = [head]
    for case in cases:
        ours = Run()
        theirs = {name: Run() for name in case.theirs}
        out = str(work / "out.txt")
        for _ in range(1 if case.anytime_s else repeats):
            for name, run in theirs.items():
                Path(out).unlink(missing_ok=True)
                record(run, *timed([str(app), "-i", str(case.instance.resolve()), "-o", out, "-s", name],
                                   cwd=str(map_dir)), Path(out), data / "maps")
            Path(out).unlink(missing_ok=True)
            record(ours, *timed([FLEETCTL, "solve", str(case.instance), "-s", case.ours, "-o", out,
                                 "--map-dir", str(data / "maps"), *case.extra]), Path(out), data / "maps")
        solved = [r for r in theirs.values() if r.status == "solved"]
        reference = min(solved, key=lambda r: r.ms) if solved else None
        for name, run in theirs.items():
            rows.append((case.label, "mapf-IR " + name, run.status + (" ({})".format(run.note) if run.note else ""),
                         "{:.3f} s".format(run.ms / 1000), "{:.3f} s".format(run.cpu_s),
                         "{:.0f} MB".format(run.rss_mb), str(run.soc or "-"), "", ""))
        ratio = "-"
        if reference is not None and ours.status == "solved":
            ratio = "{:.2f}x ({:.2f}x)".format(ours.ms / reference.ms, ours.cpu_s / max(reference.cpu_s, 0.01))
        lb = _lower_bound(case.instance, data)
        rows.append((case.label, "fleetctl " + case.ours + "".join(" " + e for e in case.extra),
                     ours.status + (" ({})".format(ours.note) if ours.note and ours.status != "solved" else ""),
                     "{:.3f} s".format(ours.ms / 1000), "{:.3f} s".format(ours.cpu_s), "{:.0f} MB".format(ours.rss_mb),
                     str(ours.soc or "-"), ratio,
                     in_process(case, data, 1 if case.anytime_s else repeats)))
        _print(rows)
        print("{:>34}  lower bound of the sum of costs: {}".format("", lb))
        rows = []
        sys.stdout.flush()
    print()
    print("load average after: {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    startup = [timed([FLEETCTL, "--help"])[0] for _ in range(20)]
    bare = [timed([sys.executable, "-c", "pass"])[0] for _ in range(20)]
    print("fleetctl --help: best {:.1f} ms, median {:.1f} ms over 20 runs (python -c pass: best {:.1f} ms, "
          "median {:.1f} ms)".format(min(startup), sorted(startup)[10], min(bare), sorted(bare)[10]))
    shutil.rmtree(str(work), ignore_errors=True)


_WIDTHS = (34, 30, 20, 10, 9, 9, 8, 16, 20)


def _lower_bound(instance: Path, data: Path) -> int:
    from fleet_common.planning.dist_table import lower_bounds

    inst = read_instance(instance, [data / "maps"])
    return lower_bounds(inst.grid, inst.starts, inst.goals)[0]


def _print(rows: Sequence[Sequence[str]]) -> None:
    for r in rows:
        print("  ".join(c.ljust(w) if i < 3 else c.rjust(w) for i, (c, w) in enumerate(zip(r, _WIDTHS))).rstrip())


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "?"
