"""Slow work off the Tk thread: reading a big file, solving an instance.

`Jobs.start(work, done)` runs `work()` in a daemon thread and puts its result
(or the exception it raised) on a queue; the window's `after()` loop calls
`drain()` on the Tk thread, which hands each result to its `done(result,
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
        self._results: "queue.Queue[Tuple[Done, Any, Optional[BaseException]]]" = queue.Queue()
        self._running: Optional[str] = None

    @property
    def running(self) -> Optional[str]:
        """What the running job does (its `what`), None when idle."""
        return self._running

    def start(self, what: str, work: Callable[[], Any], done: Done) -> bool:
        """Run `work` in a thread; False (and nothing started) while another job runs."""
        if self._running is not None:
            return False
        self._running = what

        def run() -> None:
            try:
                result, error = work(), None
            except BaseException as err:  # handed to `done` on the Tk thread, which reports it
                result, error = None, err
            self._results.put((done, result, error))

        threading.Thread(target=run, name="console-job", daemon=True).start()
        return True

    def drain(self, limit: int = 4) -> int:
        """On the Tk thread: call `done` for up to `limit` finished jobs; how many were handled."""
        handled = 0
        while handled < limit:
            try:
                done, result, error = self._results.get_nowait()
            except queue.Empty:
                break
            self._running = None
            handled += 1
            done(result, error)
        return handled
