"""ConflictLayer: a red frame on each conflict's cell while its time window is on.

Markers are created once (hidden) and only shown or hidden as the time moves;
the entry picked in the list is drawn thicker so it stands out among others
of the same step.
"""
from __future__ import annotations

import tkinter as tk
from typing import List, Optional, Sequence

import numpy as np

from ..conflicts import ConflictEntry
from ..fleet_state import FleetState
from ..view_options import ViewOptions
from ..viewport import Viewport

COLOUR = "#ff1a1a"


class ConflictLayer:
    def __init__(self, canvas: tk.Canvas, entries: Sequence[ConflictEntry]) -> None:
        self.canvas = canvas
        self.entries = [e for e in entries if e.cell is not None and e.jump_time is not None]
        self.items: List[int] = [canvas.create_rectangle(0, 0, 0, 0, outline=COLOUR, state=tk.HIDDEN,
                                                          tags=("conflict",)) for _ in self.entries]
        self._lo = np.array([e.window[0] for e in self.entries], dtype=np.float64)
        self._hi = np.array([e.window[1] for e in self.entries], dtype=np.float64)
        self._on = np.zeros(len(self.entries), dtype=bool)
        self._picked: Optional[ConflictEntry] = None
        self._width = 2

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        half = max(view.cell * 0.5, 4.0)
        self._width = max(2, round(view.cell * 0.09))
        for e, item in zip(self.entries, self.items):
            x, y = view.to_canvas(*e.cell)
            self.canvas.coords(item, x - half, y - half, x + half, y + half)
            self.canvas.itemconfigure(item, width=self._width * (2 if e is self._picked else 1))
        self.canvas.tag_raise("conflict")
        self.canvas.tag_raise("overlay")

    def pick(self, entry: Optional[ConflictEntry]) -> None:
        self._picked = entry
        for e, item in zip(self.entries, self.items):
            self.canvas.itemconfigure(item, width=self._width * (2 if e is entry else 1))

    def update(self, state: FleetState) -> None:
        if not self.items:
            return
        on = (self._lo <= state.time + 1e-9) & (state.time - 1e-9 <= self._hi)
        for k in np.nonzero(on != self._on)[0].tolist():
            self.canvas.itemconfigure(self.items[k], state=tk.NORMAL if on[k] else tk.HIDDEN)
        self._on = on

    def shown(self) -> List[ConflictEntry]:
        """The entries whose marker is on the canvas now."""
        return [e for e, on in zip(self.entries, self._on.tolist()) if on]
