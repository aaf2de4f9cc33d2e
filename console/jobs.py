"""Slow work off the Tk thread: reading a big file, solving an instance.

`Jobs.start(what, work, done)` runs `work()` in a daemon thread and puts its
result (or the exception it raised) on a queue; the window's `after()` loop
calls `drain()` on the Tk thread, which hands the result to `done(result,
error)` there. So a worker never touches a widget (thonny's rule), and the
window keeps drawing and answering keys while the work runs. One job at a
time: `start` refuses a second while one runs, so a user pressing Solve twice
does not start two solvers.
"""
from __future__ import annotations

import queue
import threading
from typing import Any, Callable, Optional, Tuple

Done = Callable[[Any, Optional[BaseException]], None]


class Jobs:
    """At most one background job, and the queue its result comes back on."""

    def __init__(self) -> None:
        self._results: "queue.Queue[Tuple[Any, Optional[BaseException]]]" = queue.Queue()
        self._running: Optional[str] = None
        self._done: Optional[Done] = None

    @property
    def running(self) -> Optional[str]:
        """What the running job does (its `what`), None when idle."""
        return self._running

    def start(self, what: str, work: Callable[[], Any], done: Done) -> bool:
        """Run `work` in a thread; False (and nothing started) while another job runs.

        `work` must not hold widgets (or the window): whatever the thread holds
        last is freed on it, and Tk objects freed off the Tk thread crash Tcl.
        `done` stays here, on the Tk side.
        """
        if self._running is not None:
            return False
        self._running, self._done = what, done
        results = self._results

        def run() -> None:
            try:
                result, error = work(), None
            except BaseException as err:  # handed to `done` on the Tk thread, which reports it
                result, error = None, err
            results.put((result, error))

        threading.Thread(target=run, name="console-job", daemon=True).start()
        return True

    def drain(self) -> bool:
        """On the Tk thread: hand a finished job's result to its `done`; whether there was one."""
        try:
            result, error = self._results.get_nowait()
        except queue.Empty:
            return False
        done, self._done, self._running = self._done, None, None
        if done is not None:
            done(result, error)
        return True
