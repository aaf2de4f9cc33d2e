"""Start and end of the one-shot commands (`commands.ONE_SHOT`: solve, validate, info, ...).

These read files, write files and end, and users and scripts run them many times
in a row. Around their work the interpreter does as much again: `fleetctl solve`
on arena_300agents_1 plans in 40 ms inside a process of about 200 ms (issue 17,
bench/README.md). Two parts of that serve no one here:

- `import numpy` (1.24) executes `numpy.random`, `numpy.ma`, `numpy.polynomial`
  and `numpy.fft`, which none of these commands uses at start (about 20 ms).
  While the command runs they are made lazy: each is executed on its first use
  (importlib's LazyLoader), so code that uses one still gets it.
- After the command has returned, the interpreter frees every object of numpy's
  and ours one by one and collects garbage (25-35 ms), for memory the process
  is about to give back whole. `exit_now` runs what a normal exit runs for others
  (the atexit callbacks), flushes stdout and stderr, and ends the process there.

Each applies only where it cannot change what the command does: the lazy
modules only in a process that has not imported numpy yet (tests that call
`cli.main` in pytest have), and only while the command runs;
the quick end only from the `fleetctl` program (`cli.entry`), never from
`cli.main`, and only when no other thread is alive. The commands' files are all
written through `with` blocks (closed before they return), which is why a
command is listed in ONE_SHOT only after its code was read for that.
"""
from __future__ import annotations

import atexit
import importlib.machinery
import importlib.util
import os
import sys
from contextlib import contextmanager
from types import ModuleType
from typing import Iterator, NoReturn, Optional, Sequence

#: numpy's submodules that `import numpy` executes and the one-shot commands do not use at start.
LAZY_NUMPY = ("numpy.random", "numpy.ma", "numpy.polynomial", "numpy.fft")


class _LazyFinder:
    """Finds the modules `names` as the path finder does, with a loader that defers executing them.

    A meta path finder by its `find_spec` alone: subclassing importlib.abc's would import
    importlib.resources and tempfile, 10 ms of the very start-up this saves."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names = frozenset(names)

    def find_spec(self, fullname: str, path: Optional[Sequence[str]],
                  target: Optional[ModuleType] = None) -> Optional[importlib.machinery.ModuleSpec]:
        if fullname not in self.names:
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return None  # not found, or not a loader LazyLoader can wrap: the import goes on as usual
        spec.loader = importlib.util.LazyLoader(spec.loader)
        return spec


@contextmanager
def numpy_parts_on_first_use() -> Iterator[None]:
    """Within the block, `import numpy` leaves `LAZY_NUMPY` unexecuted until first used."""
    if "numpy" in sys.modules:
        yield  # too late: they were executed with numpy
        return
    finder = _LazyFinder(LAZY_NUMPY)
    sys.meta_path.insert(0, finder)
    try:
        yield
    finally:
        sys.meta_path.remove(finder)


def alone() -> bool:
    """Whether no thread but this one is alive (a normal exit would wait for the others)."""
    threading = sys.modules.get("threading")
    return threading is None or threading.active_count() <= 1


def exit_now(status: int) -> NoReturn:
    """End the process with `status` as a normal exit would, minus the interpreter's teardown."""
    # the callbacks a normal exit runs (logging's flush, weakref finalizers); atexit has no public
    # way to run them; this one runs them as the interpreter's own exit does
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except BrokenPipeError:
            # the reader went away (`fleetctl info x | head`) before the last of the output: the
            # status `cli` gives when that happens earlier, and nothing printed about it
            status = status or 141
        except (OSError, ValueError):
            pass  # the stream was closed or failed: nothing left to deliver it to
    os._exit(status)
