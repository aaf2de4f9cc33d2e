"""The one-shot commands' start and end (`fleetctl.one_shot`): faster, and otherwise the same.

Each test runs a real `fleetctl` process (the program's own entry, `cli.entry`) and checks
what a user or a script would notice if the shortcut went wrong: output cut short, an
atexit callback or another thread's work lost, a numpy part missing when used.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from fleet_common.formats.solution import read_solution

from fleetctl.commands import COMMANDS, ONE_SHOT
from fleetctl.one_shot import LAZY_NUMPY


def _python(code: str, *args: object) -> subprocess.CompletedProcess:
    # stdout block-buffered as users have it (this machine sets PYTHONUNBUFFERED): then output a
    # missing flush leaves in the buffer is seen missing
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                          timeout=120, env=env)


def _arena(shared_data: Path) -> list:
    return [shared_data / "instances" / "arena_300agents_1.txt", "-s", "pibt", "--map-dir", shared_data / "maps"]


def test_one_shot_commands_are_commands() -> None:
    assert ONE_SHOT <= {name for name, _, _ in COMMANDS}


def test_a_one_shot_command_runs_numpys_unused_parts_only_when_used(shared_data: Path, tmp_path: Path) -> None:
    code = """
import json, sys
from fleetctl.cli import main
status = main(["solve", *sys.argv[1:]])
executed = [m for m in {lazy!r} if m + "." + {inner!r}[m] in sys.modules]
import numpy as np
drawn = int(np.random.default_rng(3).integers(1000))
masked = int(np.ma.masked_invalid([1.0, float("nan"), 2.0]).count())
roots = np.polynomial.polynomial.polyroots([-2.0, 1.0]).tolist()
print(json.dumps(dict(status=status, executed=executed, drawn=drawn, masked=masked, roots=roots,
                      finders=[type(f).__name__ for f in sys.meta_path])))
""".format(lazy=LAZY_NUMPY, inner={"numpy.random": "mtrand", "numpy.ma": "core", "numpy.polynomial": "polynomial",
                                   "numpy.fft": "_pocketfft"})
    out = tmp_path / "arena.txt"
    proc = _python(code, *_arena(shared_data), "-o", out)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout.splitlines()[-1])
    assert got["status"] == 0 and read_solution(str(out), [shared_data / "maps"]).solved
    assert got["executed"] == []  # not one of them ran during the solve
    # and each works at its first use as it does imported with numpy (here, in pytest)
    assert got["drawn"] == int(np.random.default_rng(3).integers(1000))
    assert got["masked"] == 2 and got["roots"] == [2.0]
    assert "_LazyFinder" not in got["finders"]  # nothing of the shortcut stays installed


def test_the_quick_end_delivers_all_output_and_runs_atexit_callbacks(shared_data: Path, tmp_path: Path) -> None:
    """A whole solution on stdout through a pipe (about 50 KB: more than one buffer), then the
    callbacks a normal exit runs, then nothing of the script after `entry()`."""
    code = """
import atexit, sys
atexit.register(print, "atexit ran")
sys.argv = ["fleetctl", "solve", *sys.argv[1:]]
from fleetctl.cli import entry
entry()
print("after the end")
"""
    proc = _python(code, *_arena(shared_data), "-o", "-")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.endswith("atexit ran\n") and "after the end" not in proc.stdout
    file = tmp_path / "arena.txt"
    file.write_text(proc.stdout[:-len("atexit ran\n")])
    sol = read_solution(str(file), [shared_data / "maps"])
    assert sol.solved and sol.agents == 300 and sol.plan.makespan == 81 and len(proc.stdout) > 40_000
    assert proc.stderr.startswith("solved=1, solver=pibt")


def test_the_quick_end_keeps_the_exit_status(shared_data: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.txt"
    bad.write_text("map_file=nowhere.map\n")
    stuck = _python("import sys; sys.argv = ['fleetctl', 'solve', *sys.argv[1:]]\n"
                    "from fleetctl.cli import entry\nentry()", *_arena(shared_data), "--max-timestep", "3",
                    "-o", tmp_path / "stuck.txt")
    unreadable = _python("import sys; sys.argv = ['fleetctl', 'validate', sys.argv[1]]\n"
                         "from fleetctl.cli import entry\nentry()", bad)
    assert (stuck.returncode, unreadable.returncode) == (3, 2), stuck.stderr + unreadable.stderr
    assert "bad.txt" in unreadable.stderr and len(unreadable.stderr.splitlines()) == 1


def test_with_another_thread_alive_the_process_ends_normally(shared_data: Path, tmp_path: Path) -> None:
    """A normal exit waits for the other (non-daemon) threads: a library's writer thread must
    finish its file, so the quick end is not taken then."""
    code = """
import pathlib, sys, threading, time
late_file = pathlib.Path(sys.argv[1])
def late():
    time.sleep(0.5)
    late_file.write_text("written")
threading.Thread(target=late).start()
sys.argv = ["fleetctl", "info", sys.argv[2]]
from fleetctl.cli import entry
sys.exit(entry())
"""
    written = tmp_path / "late.txt"
    proc = _python(code, written, shared_data / "maps" / "arena.map")
    assert proc.returncode == 0, proc.stderr
    assert "49" in proc.stdout  # info printed the map's size
    assert written.read_text() == "written"


def test_a_reader_gone_before_the_last_output_gives_141_and_no_message(shared_data: Path) -> None:
    """`fleetctl info FILE | head -0`: the output still in the buffer at the end finds no reader.
    As when that happens earlier (cli), status 141 and nothing on stderr (Python's own exit says
    `Exception ignored ... BrokenPipeError` and exits 120)."""
    read, write = os.pipe()
    os.close(read)  # a reader that is gone before the first byte
    try:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
        proc = subprocess.run([sys.executable, "-m", "fleetctl", "info", shared_data / "maps" / "arena.map"],
                              stdout=write, stderr=subprocess.PIPE, text=True, timeout=60, env=env)
    finally:
        os.close(write)
    assert (proc.returncode, proc.stderr) == (141, "")
