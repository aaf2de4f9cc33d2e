"""Saving what a widget shows as a PNG: the pixels on the X screen, read back.

Tk cannot read back what it drew; the X server can. Pillow's `ImageGrab`
reads the widget's rectangle of the screen (through XCB), so the PNG is
exactly what the canvas shows, fonts and all. The widget must be fully on the
screen and not covered: `--screenshot` renders on its own Xvfb (or places the
window at the top-left of the display it is given) for that reason.
"""
from __future__ import annotations

import tkinter as tk
from pathlib import Path
from typing import Union

from fleet_common.errors import FleetError


def grab(widget: tk.Misc, path: Union[str, Path]) -> None:
    """Write `widget`'s on-screen pixels to `path` as PNG."""
    from PIL import ImageGrab

    widget.update_idletasks()
    widget.update()
    x, y = widget.winfo_rootx(), widget.winfo_rooty()
    w, h = widget.winfo_width(), widget.winfo_height()
    sw, sh = widget.winfo_screenwidth(), widget.winfo_screenheight()
    if not widget.winfo_viewable() or x < 0 or y < 0 or x + w > sw or y + h > sh:
        raise FleetError("cannot save the view as PNG: the canvas ({}x{} at {},{}) is not wholly on "
                         "the {}x{} screen; make the window smaller or use --screenshot".format(
                             w, h, x, y, sw, sh))
    try:
        image = ImageGrab.grab(bbox=(x, y, x + w, y + h), xdisplay=widget.winfo_screen())
    except OSError as err:
        raise FleetError("cannot read the screen to save a PNG: {}".format(err)) from err
    image.convert("RGB").save(str(path), "PNG", optimize=True)
