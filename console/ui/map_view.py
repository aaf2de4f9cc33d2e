"""MapView: the canvas, its viewport and the map picture; mouse zoom, pan and clicks.

The map is one image item (see `console.background`), redrawn only when the
view changes. Listeners registered with `on_view_change` are told after every
zoom, pan, resize or mirror, so that the layers place their items again.
A left click that does not move is a click (`on_click`), one that moves pans.
"""
from __future__ import annotations

import tkinter as tk
from typing import Callable, List, Optional, Tuple

import numpy as np

from .. import background
from ..viewport import Viewport

#: Height of the header band at the top of the canvas (see `HeaderBand`).
HEADER_HEIGHT = 42
ZOOM_STEP = 1.25
PAN_STEP = 60
_DRAG_THRESHOLD = 4

Listener = Callable[[], None]


class MapView(tk.Frame):
    """A frame holding the canvas the whole scene is drawn on."""

    def __init__(self, master: tk.Misc, free: np.ndarray, width: int, height: int,
                 down: bool = False) -> None:
        super().__init__(master)
        self.free = free
        self.canvas = tk.Canvas(self, width=width, height=height, background="#ffffff",
                                highlightthickness=0, borderwidth=0, takefocus=1)
        self.canvas.pack(fill=tk.BOTH, expand=True)
        grid_h, grid_w = free.shape
        self.view = Viewport(grid_w, grid_h, width, height, top=HEADER_HEIGHT, down=down)
        self.grid_lines = True
        self._photo: Optional[tk.PhotoImage] = None
        self._image = self.canvas.create_image(0, 0, anchor=tk.NW, tags=("background",))
        self._listeners: List[Listener] = []
        self._press: Optional[Tuple[int, int]] = None
        self._dragging = False
        self.on_click: Callable[[float, float], None] = lambda x, y: None
        self.on_hover: Callable[[float, float], None] = lambda x, y: None
        self.canvas.bind("<Configure>", self._configured)
        self.canvas.bind("<ButtonPress-1>", self._pressed)
        self.canvas.bind("<B1-Motion>", self._dragged)
        self.canvas.bind("<ButtonRelease-1>", self._released)
        for button in ("2", "3"):
            self.canvas.bind("<ButtonPress-%s>" % button, self._pressed_pan)
            self.canvas.bind("<B%s-Motion>" % button, self._dragged)
        self.canvas.bind("<Motion>", lambda e: self.on_hover(e.x, e.y))
        self.canvas.bind("<Button-4>", lambda e: self.zoom(ZOOM_STEP, e.x, e.y))
        self.canvas.bind("<Button-5>", lambda e: self.zoom(1 / ZOOM_STEP, e.x, e.y))
        self.canvas.bind("<MouseWheel>", lambda e: self.zoom(
            ZOOM_STEP if e.delta > 0 else 1 / ZOOM_STEP, e.x, e.y))
        self.redraw_map()

    def destroy(self) -> None:
        # The map picture goes now, on Tk's thread: left to the cycle collector, it would be
        # freed by whichever thread collects next (the network thread), which Tk refuses.
        self._photo = None
        super().destroy()

    def on_view_change(self, listener: Listener) -> None:
        self._listeners.append(listener)

    def changed(self) -> None:
        """Redraw the map picture and tell every listener the view changed."""
        self.redraw_map()
        for listener in self._listeners:
            listener()

    def redraw_map(self) -> None:
        pixels = background.render(self.free, self.view, self.grid_lines)
        self._photo = tk.PhotoImage(master=self.canvas, data=background.to_ppm(pixels), format="PPM")
        self.canvas.itemconfigure(self._image, image=self._photo)

    # -- view changes ------------------------------------------------------------------

    def zoom(self, factor: float, px: Optional[float] = None, py: Optional[float] = None) -> None:
        if px is None or py is None:
            px, py = self.view.canvas_w / 2, (self.view.top + self.view.canvas_h) / 2
        self.view.zoom(factor, px, py)
        self.changed()

    def pan(self, dx: float, dy: float) -> None:
        self.view.pan(dx, dy)
        self.changed()

    def fit(self) -> None:
        self.view.fit()
        self.changed()

    def set_mirrored(self, down: bool) -> None:
        if down != self.view.down:
            self.view.set_down(down)
            self.changed()

    def set_bands(self, top: int, bottom: int, right: int = 0) -> None:
        """Room for bands over the top, bottom and right of the canvas (the map fits between)."""
        if (top, bottom, right) != (self.view.top, self.view.bottom, self.view.right):
            self.view.top, self.view.bottom, self.view.right = top, bottom, right
            self.view.fit()
            self.changed()

    def set_grid_lines(self, on: bool) -> None:
        self.grid_lines = on
        self.redraw_map()

    def _configured(self, event: "tk.Event[tk.Canvas]") -> None:
        if (event.width, event.height) != (self.view.canvas_w, self.view.canvas_h):
            self.view.resize(event.width, event.height)
            self.changed()

    # -- mouse -------------------------------------------------------------------------

    def _pressed(self, event: "tk.Event[tk.Canvas]") -> None:
        self.canvas.focus_set()
        self._press = (event.x, event.y)
        self._dragging = False

    def _pressed_pan(self, event: "tk.Event[tk.Canvas]") -> None:
        self._press = (event.x, event.y)
        self._dragging = True

    def _dragged(self, event: "tk.Event[tk.Canvas]") -> None:
        if self._press is None:
            return
        dx, dy = event.x - self._press[0], event.y - self._press[1]
        if not self._dragging and abs(dx) + abs(dy) < _DRAG_THRESHOLD:
            return
        self._dragging = True
        self._press = (event.x, event.y)
        self.pan(dx, dy)

    def _released(self, event: "tk.Event[tk.Canvas]") -> None:
        if self._press is not None and not self._dragging:
            self.on_click(event.x, event.y)
        self._press = None
        self._dragging = False
