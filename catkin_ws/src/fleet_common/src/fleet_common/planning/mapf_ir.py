"""mapf-IR as a plug-in solver: run an unmodified mapf-IR `app` binary on our problem.

mapf-IR's command line is `app -i INSTANCE -o OUTPUT -s SOLVER [-T ms] [solver
options]`. It opens the instance's `map_file=` as a map folder fixed when it
was compiled plus that name, by string concatenation, so an absolute path does
not work. That folder is the `map/` beside its build folder; we take
`<app's folder>/../map`, or the folder whose path is compiled into the binary,
or the one the caller names.

We refer to our map by a *relative path from that folder* to a map file we
write into a temporary work folder. Copying it into mapf-IR's folder instead
would write into the user's checkout (possibly read-only, possibly shared by
runs in parallel) and leave files behind when we are killed; a relative path
writes nothing there. mapf-IR runs with that folder as its working directory,
so the same path also works for a build without a compiled-in folder (it then
opens maps relative to the working directory).

The output is read with the foundation reader and the plan validated. When
mapf-IR fails (exit status, signal, no output file, a plan that fails
validation) a `MapfIrFailed` says so with the tail of its output; an
unreadable output file is the reader's `SolutionFormatError` naming that file
and line. Either way the work folder is kept for inspection.
"""
from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path
from typing import List, Optional, Sequence, Union

from ..errors import FleetError, FormatError
from ..grid import Coord, Grid
from ..plan import Plan
from ..formats.instance import DEFAULT_MAX_TIMESTEP, make_instance, write_instance
from ..formats.mapfile import map_from_grid, write_map
from ..formats.solution import Solution, read_solution
from ..validate import validate_plan
from .deadline import Deadline, as_deadline
from .problem import check_problem
from .result import NO_SOLUTION, SOLVED, TIMEOUT, SolveResult

#: Environment variable naming the mapf-IR `app` binary when `--mapf-ir` is not given.
APP_ENV = "MAPF_IR_APP"
#: Time limit when the caller gives no deadline (mapf-IR's own default is 60 s).
DEFAULT_TIMEOUT_S = 60.0
#: Extra time before mapf-IR is killed: it writes its output after its own limit.
GRACE_S = 5.0
TAIL_LINES = 15


class MapfIrError(FleetError):
    """mapf-IR cannot be used as set up: no binary, not executable, no map folder."""


class MapfIrFailed(MapfIrError):
    """mapf-IR ran and failed: exit status, signal, no output, a plan that fails validation."""


def resolve_app(app: Optional[Path] = None) -> Path:
    """The mapf-IR binary: `app`, else $MAPF_IR_APP; checked to exist and be executable."""
    if app is None:
        env = os.environ.get(APP_ENV)
        if not env:
            raise MapfIrError("no mapf-IR binary given: pass --mapf-ir PATH or set {}".format(APP_ENV))
        app = Path(env)
    app = Path(app)
    if not app.exists():
        raise MapfIrError("mapf-IR binary {} does not exist".format(app))
    if not app.is_file():
        raise MapfIrError("mapf-IR binary {} is not a file (give the built `app`)".format(app))
    if not os.access(str(app), os.X_OK):
        raise MapfIrError("mapf-IR binary {} is not executable (chmod +x?)".format(app))
    return app


def find_map_dir(app: Path) -> Path:
    """mapf-IR's compiled-in map folder: `<app's folder>/../map`, else a folder named in the binary."""
    real = Path(os.path.realpath(str(app)))
    beside = real.parent.parent / "map"
    if beside.is_dir():
        return beside
    for candidate in _compiled_in_dirs(real):
        if candidate.is_dir():
            return candidate
    raise MapfIrError(
        "cannot find mapf-IR's map folder: {} does not exist and the binary names no existing "
        "'.../map/' folder; pass --mapf-ir-map-dir D (the folder mapf-IR was compiled to read "
        "maps from)".format(beside))


def _compiled_in_dirs(app: Path) -> List[Path]:
    # _MAPDIR_ is a string literal: an absolute, NUL-terminated path ending in "/map/"
    try:
        with open(str(app), "rb") as f:
            data = f.read(64 << 20)
    except OSError:
        return []
    found = re.findall(rb"(/[\x21-\x7e]{0,4000}?/map/)\x00", data)
    return [Path(os.fsdecode(s)) for s in dict.fromkeys(found)]


class MapfIrSolver:
    """Runs mapf-IR's `app` (None: $MAPF_IR_APP); one instance serves many solves."""

    def __init__(self, app: Optional[Path] = None, map_dir: Optional[Path] = None,
                 timeout_s: float = DEFAULT_TIMEOUT_S, grace_s: float = GRACE_S) -> None:
        self.app = resolve_app(app)
        if map_dir is not None and not Path(map_dir).is_dir():
            raise MapfIrError("mapf-IR map folder {} is not a folder".format(map_dir))
        self.map_dir = Path(map_dir) if map_dir is not None else find_map_dir(self.app)
        self.timeout_s = timeout_s
        self.grace_s = grace_s

    def solve(self, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
              solver: str = "PIBT", options: Sequence[str] = (),
              deadline: Union[None, float, Deadline] = None,
              seed: int = 0, max_timestep: Optional[int] = None, keep_files: bool = False) -> SolveResult:
        """Plan with mapf-IR's `solver`; `options` go to it unchanged (e.g. ["-w", "1.2"])."""
        check_problem(grid, starts, goals)
        if not starts:  # mapf-IR halts on agents=0; the empty plan is the answer
            return SolveResult(Plan.from_paths([]), solver, SOLVED, 0.0, "no agents: mapf-IR not run")
        remaining = as_deadline(deadline).remaining()
        limit_s = self.timeout_s if remaining is None else remaining
        limit_ms = max(1, int(limit_s * 1000))
        work = Path(tempfile.mkdtemp(prefix="fleetcontrol-mapf-ir-"))
        keep = keep_files
        try:
            result = self._run(work, grid, starts, goals, solver, list(options), limit_ms, seed,
                               max_timestep or DEFAULT_MAX_TIMESTEP)
        except (MapfIrError, FormatError) as err:
            keep = True  # for the user to look at what mapf-IR was given and wrote
            _keep_note(err, work)
            raise
        finally:
            if not keep:
                shutil.rmtree(str(work), ignore_errors=True)
        if keep_files:
            result.stats["work_dir"] = str(work)
        return result

    def _run(self, work: Path, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
             solver: str, options: List[str], limit_ms: int, seed: int, max_timestep: int) -> SolveResult:
        map_path = work / "{}.map".format(_safe_name(grid.name) or "fleetcontrol")
        write_map(map_from_grid(grid), str(map_path))
        map_file = os.path.relpath(os.path.realpath(str(map_path)), os.path.realpath(str(self.map_dir)))
        instance, output = work / "instance.txt", work / "output.txt"
        write_instance(make_instance(grid, map_file, starts, goals, seed=seed, max_timestep=max_timestep,
                                     max_comp_time=limit_ms), str(instance))
        argv = [str(self.app), "-i", str(instance), "-o", str(output), "-s", solver]
        if not any(o in ("-T", "--time-limit") or o.startswith("--time-limit=") for o in options):
            argv += ["-T", str(limit_ms)]
        argv += options
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(argv, cwd=str(self.map_dir), stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, timeout=limit_ms / 1000.0 + self.grace_s)
        except subprocess.TimeoutExpired:
            return SolveResult(None, solver, TIMEOUT, (time.perf_counter() - t0) * 1000,
                               "mapf-IR did not finish within {:g} s (its limit plus {:g} s); "
                               "killed".format(limit_ms / 1000.0, self.grace_s))
        except OSError as err:
            raise MapfIrError("cannot run mapf-IR binary {}: {}".format(self.app, err.strerror or err))
        wall_ms = (time.perf_counter() - t0) * 1000
        out = proc.stdout.decode("utf-8", "replace")
        err_text = proc.stderr.decode("utf-8", "replace")
        tail = _tail(out, err_text)
        if proc.returncode != 0:
            raise MapfIrFailed("{} {}{}".format(_exit_text(proc.returncode), _command(argv), tail)
                              + self._map_hint(out))
        if "unknown solver name" in out:
            raise MapfIrFailed("mapf-IR does not know solver '{}' (it would have run PIBT instead); "
                              "see `{} -h` for its solver names{}".format(solver, self.app, tail))
        if not output.is_file():
            raise MapfIrFailed("mapf-IR exited with status 0 but wrote no output file {} {}{}".format(
                output, _command(argv), tail))
        sol = read_solution(str(output), grid=grid)
        return self._result(sol, grid, starts, goals, solver, limit_ms, wall_ms, out)

    def _result(self, sol: Solution, grid: Grid, starts: Sequence[Coord], goals: Sequence[Coord],
                solver: str, limit_ms: int, wall_ms: float, stdout: str) -> SolveResult:
        name = sol.solver or solver
        comp_ms = float(sol.comp_time if sol.comp_time is not None else wall_ms)
        stats = {"process_ms": wall_ms, "mapf_ir_solver": name, "mapf_ir_comp_time_ms": sol.comp_time,
                 "lb_soc": sol.lb_soc, "lb_makespan": sol.lb_makespan,
                 "iter_lines": [e.value for e in sol.header.entries if e.key == "iter"],
                 "stdout": stdout}
        if [tuple(c) for c in sol.starts] != [tuple(c) for c in starts] or \
                [tuple(c) for c in sol.goals] != [tuple(c) for c in goals]:
            raise MapfIrFailed("mapf-IR's output {} lists other starts or goals than the instance "
                              "it was given".format(sol.path))
        if not sol.solved or sol.plan is None:
            status = TIMEOUT if comp_ms >= 0.99 * limit_ms else NO_SOLUTION
            why = "ran out of its {} ms".format(limit_ms) if status == TIMEOUT else "found no plan"
            return SolveResult(None, name, status, comp_ms, "mapf-IR's {} {} (solved=0)".format(name, why),
                               stats)
        report = validate_plan(sol.plan, grid, starts, goals)
        if not report.ok:
            raise MapfIrFailed("mapf-IR's {} returned a plan that fails validation ({}): {}".format(
                name, sol.path, report.errors[0]))
        return SolveResult(sol.plan, name, SOLVED, comp_ms, "", stats)

    def _map_hint(self, stdout: str) -> str:
        if re.search(r"error@\w*: file .* is not found", stdout) and "error@Problem" not in stdout:
            return ("\nmapf-IR opens maps relative to the map folder it was compiled with; "
                    "FleetControl assumed {} (pass --mapf-ir-map-dir D if that is wrong)".format(self.map_dir))
        return ""


def _keep_note(err: FleetError, work: Path) -> None:
    if isinstance(err, FormatError):  # stays one line: FILE:LINE: message
        err.message += " (mapf-IR's files are kept in {})".format(work)
    else:
        err.args = ("{}\n(mapf-IR's files are kept in {})".format(err, work),)


def _safe_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", Path(name).stem) if name else ""


def _exit_text(code: int) -> str:
    if code < 0:
        try:
            sig = signal.Signals(-code).name
        except ValueError:
            sig = str(-code)
        return "mapf-IR was killed by signal {} running".format(sig)
    return "mapf-IR exited with status {} running".format(code)


def _command(argv: Sequence[str]) -> str:
    return "`{}`".format(" ".join(argv))


def _tail(stdout: str, stderr: str) -> str:
    parts = []
    for label, text in (("stdout", stdout), ("stderr", stderr)):
        lines = [ln for ln in text.splitlines() if ln.strip()]
        if lines:
            shown = lines[-TAIL_LINES:]
            more = "" if len(lines) <= TAIL_LINES else " (last {} of {} lines)".format(TAIL_LINES, len(lines))
            parts.append("\n--- its {}{}:\n  ".format(label, more) + "\n  ".join(shown))
    return "".join(parts) or "\n(it printed nothing)"
