"""Banner: one large line across the middle of the map when the console cannot trust it.

"manager lost" in red while the manager is away (the map then shows the last
picture it sent, greyed), "connecting to ..." before the first answer;
hidden while connected.
"""
from __future__ import annotations

import tkinter as tk

from ..fleet_state import FleetState
from ..view_options import ViewOptions
from ..viewport import Viewport

LOST_COLOUR = "#c8101a"
WAIT_COLOUR = "#6a6a62"


class Banner:
    def __init__(self, canvas: tk.Canvas) -> None:
        self.canvas = canvas
        self.box = canvas.create_rectangle(0, 0, 0, 0, fill="#ffffff", outline="#c8c8c0", width=2,
                                           state=tk.HIDDEN, tags=("overlay", "banner"))
        self.label = canvas.create_text(0, 0, text="", font=("DejaVu Sans", -20, "bold"), justify=tk.CENTER,
                                        state=tk.HIDDEN, tags=("overlay", "banner"))
        self.text = ""

    def set(self, text: str, lost: bool = False) -> None:
        """Show `text` (red when the manager is lost); "" hides the banner."""
        self.text = text
        self.canvas.itemconfigure(self.label, text=text, fill=LOST_COLOUR if lost else WAIT_COLOUR)
        state = tk.NORMAL if text else tk.HIDDEN
        self.canvas.itemconfigure("banner", state=state)
        self._place()

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.canvas.itemconfigure(self.label, width=max(200, view.canvas_w - 60))
        self._place()

    def _place(self) -> None:
        c = self.canvas
        w, h = c.winfo_width(), c.winfo_height()
        if w <= 1:
            w, h = int(c.cget("width")), int(c.cget("height"))
        c.coords(self.label, w / 2, h / 2)
        box = c.bbox(self.label)
        if box is not None:
            c.coords(self.box, box[0] - 14, box[1] - 10, box[2] + 14, box[3] + 10)
        c.tag_raise("banner")

    def update(self, state: FleetState) -> None:
        pass
