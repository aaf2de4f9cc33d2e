"""Overlay layers: the header band, the axes at the origin, and the cell ids.

All carry the canvas tag "overlay" (header, axes) so that other layers can
keep them on top with one `tag_raise("overlay")`.
"""
from __future__ import annotations

import tkinter as tk
from typing import Dict, List, Optional, Sequence

from fleet_common.grid import Coord

import numpy as np

from .. import orientation
from ..fleet_state import FleetState
from ..view_options import ViewOptions
from ..viewport import Viewport
from .map_view import HEADER_HEIGHT

FONT = ("DejaVu Sans", -12)
SEPARATOR = "  \u00b7  "
SMALL_FONT = ("DejaVu Sans", -10)
#: Cell ids are drawn when a cell is at least this many pixels wide, at most this many.
MIN_ID_CELL = 26.0
MAX_IDS = 4000


class HeaderBand:
    """Two lines at the top of the canvas: the solver's figures, then time and play state."""

    def __init__(self, canvas: tk.Canvas, info: Sequence[str]) -> None:
        self.canvas = canvas
        self.band = canvas.create_rectangle(0, 0, 0, HEADER_HEIGHT, fill="#f7f7f4", outline="#c8c8c0",
                                            tags=("overlay",))
        self.line1 = canvas.create_text(8, 12, anchor=tk.W, font=FONT, fill="#202020",
                                        text=SEPARATOR.join(info), tags=("overlay",))
        self.line2 = canvas.create_text(8, 30, anchor=tk.W, font=FONT, fill="#404040",
                                        tags=("overlay",))
        self._status = ""
        self._time = 0.0
        self._makespan = 0
        self._start = 0.0

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.canvas.coords(self.band, -1, -1, view.canvas_w + 1, HEADER_HEIGHT)
        for size in (12, 11, 10):  # the largest font that fits the canvas's width
            font = ("DejaVu Sans", -size)
            self.canvas.itemconfigure(self.line1, font=font)
            self.canvas.itemconfigure(self.line2, font=font)
            box = self.canvas.bbox(self.line1)
            if box is None or box[2] <= view.canvas_w - 4:
                break

    def set_info(self, info: Sequence[str]) -> None:
        """Line 1 (the live console's plan changes while the window stays)."""
        self.canvas.itemconfigure(self.line1, text=SEPARATOR.join(info))

    def set_status(self, status: str, makespan: int, start: float = 0.0) -> None:
        """The right part of line 2 (play state, speed, orientation); `start`: the steps a live run
        took before its current plan's step 0 (`RunInfo.plan_start`), so that the time shown is
        the run's and goes on across a change of plan, up to the current plan's end in the run."""
        self._status, self._makespan, self._start = status, makespan, start
        self._draw()

    def update(self, state: FleetState) -> None:
        self._time = state.time  # the plan's own time: the layers draw the plan at it
        self._draw()

    def _draw(self) -> None:
        if self._start:
            clock = "t = {:.2f} / {:.1f}".format(self._start + self._time, self._start + self._makespan)
        else:
            clock = "t = {:.2f} / {}".format(self._time, self._makespan)
        self.canvas.itemconfigure(self.line2, text=clock + SEPARATOR + self._status)

    def text(self) -> str:
        return "{}\n{}".format(self.canvas.itemcget(self.line1, "text"), self.canvas.itemcget(self.line2, "text"))


class AxesLayer:
    """Arrows x and y from the corner where the shown coordinates have their origin."""

    def __init__(self, canvas: tk.Canvas, file_orientation: str) -> None:
        self.canvas = canvas
        self.file_orientation = file_orientation
        kw = dict(fill="#505050", arrow=tk.LAST, width=2, tags=("overlay", "axes"))
        self.x_arrow = canvas.create_line(0, 0, 0, 0, **kw)
        self.y_arrow = canvas.create_line(0, 0, 0, 0, **kw)
        label = dict(font=SMALL_FONT, fill="#303030", tags=("overlay", "axes"))
        self.x_label = canvas.create_text(0, 0, text="x", **label)
        self.y_label = canvas.create_text(0, 0, text="y", **label)
        self.origin = canvas.create_text(0, 0, text="0", **label)

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        x0, y0, x1, y1 = view.map_box()
        length = min(60.0, max(20.0, (x1 - x0) / 3))
        c = self.canvas
        if orientation.origin_at_top(options.orientation):
            cy, sign = y0 - 6, 1  # along the top edge, y pointing down
        else:
            cy, sign = y1 + 6, -1
        cx = x0 - 6
        c.coords(self.x_arrow, cx, cy, cx + length, cy)
        c.coords(self.y_arrow, cx, cy, cx, cy + sign * length)
        c.coords(self.x_label, cx + length + 8, cy)
        c.coords(self.y_label, cx, cy + sign * (length + 8))
        c.coords(self.origin, cx - 8, cy - sign * 8)

    def update(self, state: FleetState) -> None:
        pass


class CellIdLayer:
    """Cell ids (`y * width + x`, in the shown coordinates) when zoomed in far enough, or on the
    lab map the floor-marker node ids the robots and the demo speak (`ViewOptions.node_ids`)."""

    def __init__(self, canvas: tk.Canvas, free: np.ndarray, file_orientation: str,
                 node_ids: Optional[Dict[Coord, int]] = None) -> None:
        self.canvas = canvas
        self.free = free
        self.file_orientation = file_orientation
        self.node_ids = node_ids or {}
        self.items: List[int] = []

    def relayout(self, view: Viewport, options: ViewOptions) -> None:
        self.canvas.delete("cellid")
        self.items = []
        nodes = options.node_ids and bool(self.node_ids)
        if not (options.ids or nodes) or view.cell < MIN_ID_CELL:
            return
        h, w = self.free.shape
        x_lo, y_a = view.to_cell(0, view.top)
        x_hi, y_b = view.to_cell(view.canvas_w, view.canvas_h)
        xs = range(max(x_lo, 0), min(x_hi, w - 1) + 1)
        ys = range(max(min(y_a, y_b), 0), min(max(y_a, y_b), h - 1) + 1)
        size = max(8, int(view.cell * 0.22))
        half = view.cell / 2 - 2
        for y in ys:
            for x in xs:
                if not self.free[y, x] or len(self.items) >= MAX_IDS:
                    continue
                if nodes:
                    label, colour = self.node_ids.get((x, y)), "#5a6a9a"
                else:
                    label, colour = orientation.cell_id((x, y), w, h, options.orientation,
                                                        self.file_orientation), "#8a8a80"
                cx, cy = view.to_canvas(x, y)
                self.items.append(self.canvas.create_text(
                    cx - half, cy - half, anchor=tk.NW, text=str(label), font=("DejaVu Sans", -size),
                    fill=colour, tags=("cellid",)))
        if self.items:
            self.canvas.tag_raise("cellid", "background")

    def update(self, state: FleetState) -> None:
        pass
