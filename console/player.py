"""Opening the player: in a window, or rendered once to a PNG (`--screenshot`).

`run_player` opens the window on the user's display and returns when it is
closed. `screenshot` builds the same window, shows time step `at`, writes the
canvas's pixels as PNG and closes it at once; without a display it renders on
a private Xvfb, so it works on servers and in CI, and no window is shown at all.
"""
from __future__ import annotations

import math
import os
import time
import tkinter as tk
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Optional, Tuple

from fleet_common.errors import FleetError

from .scene import Scene
from .sources import DEFAULT_SPEED
from .ui.map_view import HEADER_HEIGHT
from .view_options import ViewOptions
from .viewport import MARGIN
from .xvfb import Xvfb

#: Largest canvas chosen by default, and the cell size range it aims for.
MAX_CANVAS = (1100, 760)
MIN_HEADER_WIDTH = 560


def default_canvas_size(width: int, height: int, limit: Tuple[int, int] = MAX_CANVAS) -> Tuple[int, int]:
    """A canvas that shows the whole `width` x `height` map at a readable cell size, within `limit`."""
    cell = min((limit[0] - 2 * MARGIN) / width, (limit[1] - HEADER_HEIGHT - 2 * MARGIN) / height)
    cell = min(max(cell, 1.0), 48.0)
    if cell >= 4:
        cell = math.floor(cell)
    w = int(math.ceil(width * cell)) + 2 * MARGIN
    h = int(math.ceil(height * cell)) + 2 * MARGIN + HEADER_HEIGHT
    return max(w, MIN_HEADER_WIDTH), h


def _wait_until_viewable(root: tk.Tk, widget: tk.Misc, timeout: float = 5.0) -> None:
    """Let the window manager map the window and Tk paint it (no-op on a bare Xvfb)."""
    deadline = time.monotonic() + timeout
    root.update()
    while not widget.winfo_viewable():
        if time.monotonic() > deadline:
            raise FleetError("the window was not shown within {:g} s".format(timeout))
        time.sleep(0.01)
        root.update()
    root.update_idletasks()


def _tk(display: Optional[str] = None) -> tk.Tk:
    try:
        return tk.Tk(screenName=display, className="FleetControl")
    except tk.TclError as err:
        raise FleetError("cannot open a window ({}); set DISPLAY, or use --screenshot, which "
                         "renders without a display".format(err)) from None


def run_player(scene: Scene, options: ViewOptions, size: Optional[Tuple[int, int]] = None,
               speed: float = DEFAULT_SPEED, playing: bool = True) -> None:
    """Open the player window and return when the user closes it."""
    from .ui.app import PlayerApp

    root = _tk()
    size = size or default_canvas_size(scene.grid.width, scene.grid.height)
    PlayerApp(root, scene, options, canvas_size=size, playing=playing, speed=speed)
    root.mainloop()


@contextmanager
def _display(size: Tuple[int, int], exact: bool = False) -> Iterator[str]:
    """$DISPLAY if set, else a private Xvfb large enough for the window (`exact`: of that size)."""
    current = os.environ.get("DISPLAY")
    if current:
        yield current
        return
    screen = size if exact else (max(1280, size[0] + 400), max(1024, size[1] + 200))
    with Xvfb.start(*screen) as server:
        yield server.display


def screenshot(scene: Scene, out: Path, at: float, options: ViewOptions,
               size: Optional[Tuple[int, int]] = None) -> Tuple[int, int]:
    """Render time step `at` and write the canvas as PNG; returns the PNG's (width, height)."""
    from .ui.app import PlayerApp
    from .ui.capture import grab

    size = size or default_canvas_size(scene.grid.width, scene.grid.height)
    with _display(size) as display:
        root = _tk(display)
        try:
            root.geometry("+0+0")
            app = PlayerApp(root, scene, options, canvas_size=size, playing=False)
            root.update()
            canvas = app.canvas
            shown = (canvas.winfo_width(), canvas.winfo_height())
            if shown[0] < size[0] or shown[1] < size[1]:
                raise FleetError("the {}x{} screen is too small for a {}x{} canvas; give a smaller "
                                 "--size".format(root.winfo_screenwidth(), root.winfo_screenheight(), *size))
            # a small map's canvas grows to the height of the panel beside it: the map is drawn
            # to fit the canvas it got, and that is what the picture shows
            size = shown
            if app.clock is not None:
                app.clock.seek(at)
            app.refresh()
            _wait_until_viewable(root, canvas)
            grab(canvas, out)
            return size
        finally:
            root.destroy()
