"""Garbage collection on Tk's thread only, while a console window is open.

Tkinter objects with finalizers (images, variables) call into Tcl when they are
freed, and Tcl takes calls only from the thread that runs its loop. A widget
tree that is replaced (a new scene, a new map) is cyclic garbage, and Python's
cycle collector runs in whichever thread happens to allocate when a threshold
is crossed: in the console, often the network thread decoding 20 States a
second or a job thread solving an instance. Freed there, a Tk image or variable
is refused ("main thread is not in main loop" on the operator's terminal) and
stays in Tcl for good. So while a window is open the automatic collector is
off, and the window collects on its own thread a few times a second, with the
thresholds Python itself would use.
"""
from __future__ import annotations

import gc
import tkinter as tk
from typing import List, Optional

__all__ = ["TkThreadCollector", "collect_due"]

PERIOD_MS = 50

_open: List["TkThreadCollector"] = []  # collectors running in this process
_was_enabled = True  # the collector's state before the first of them


def collect_due() -> Optional[int]:
    """Collect the oldest generation whose count is past its threshold, as the automatic
    collector would; the generation collected (None: nothing due)."""
    counts, thresholds = gc.get_count(), gc.get_threshold()
    for generation in (2, 1, 0):
        if thresholds[generation] and counts[generation] > thresholds[generation]:
            gc.collect(generation)
            return generation
    return None


class TkThreadCollector:
    """Turns automatic collection off for the life of `root`, and collects on its thread."""

    def __init__(self, root: tk.Misc, period_ms: int = PERIOD_MS) -> None:
        global _was_enabled
        self.root = root
        self.period_ms = period_ms
        if not _open:
            _was_enabled = gc.isenabled()
        _open.append(self)
        gc.disable()
        self._after: Optional[str] = self.root.after(period_ms, self._tick)
        root.bind("<Destroy>", self._destroyed, add="+")

    def _tick(self) -> None:
        collect_due()
        self._after = self.root.after(self.period_ms, self._tick)

    def _destroyed(self, event: "tk.Event[tk.Misc]") -> None:
        if event.widget is self.root:
            self.close()

    def close(self) -> None:
        """Stop; the automatic collector comes back when no window needs it off."""
        if self._after is not None:
            try:
                self.root.after_cancel(self._after)
            except tk.TclError:
                pass  # the interpreter is already gone
            self._after = None
        if self in _open:
            _open.remove(self)
            if not _open and _was_enabled:
                gc.enable()
                gc.collect()  # what piled up meanwhile, here on Tk's thread
