"""The map as one picture: free cells, obstacles and grid lines, as PPM bytes.

A brc202d map has 255,000 cells; one canvas rectangle each would make every
redraw crawl. Instead the visible part of the map is rendered here, one pixel
at a time with numpy (each canvas pixel looks up the cell under its centre),
and shown as a single image item. It is redone only when the view changes
(zoom, pan, resize, orientation, grid lines), never while agents move.
"""
from __future__ import annotations

import numpy as np

from .viewport import Viewport

FREE = (238, 238, 232)
BLOCKED = (60, 60, 66)
OUTSIDE = (255, 255, 255)
GRID_LINE = (200, 200, 194)
#: Grid lines are drawn only when cells are at least this many pixels wide.
MIN_GRID_CELL = 5.0


def render(free: np.ndarray, view: Viewport, grid_lines: bool = True) -> np.ndarray:
    """(canvas_h, canvas_w, 3) uint8 pixels of the map as `view` shows it."""
    h, w = free.shape
    px = np.arange(view.canvas_w, dtype=np.float64) + 0.5
    py = np.arange(view.canvas_h, dtype=np.float64) + 0.5
    col = np.floor((px - view.ox) / view.cell).astype(np.int64)
    row = np.floor((py - view.oy) / view.cell).astype(np.int64)
    in_x = (col >= 0) & (col < w)
    in_y = (row >= 0) & (row < h)
    base_y = row if view.down else h - 1 - row
    cells = free[np.clip(base_y, 0, h - 1)][:, np.clip(col, 0, w - 1)]  # (canvas_h, canvas_w)
    palette = np.array([OUTSIDE, BLOCKED, FREE, GRID_LINE], dtype=np.uint8)
    kind = np.where(cells, 2, 1)
    if grid_lines and view.cell >= MIN_GRID_CELL:
        # the first pixel column/row of each cell is the line between it and its neighbour
        line_x = np.concatenate(([True], col[1:] != col[:-1]))
        line_y = np.concatenate(([True], row[1:] != row[:-1]))
        on_line = line_y[:, None] | line_x[None, :]
        kind = np.where(on_line & cells, 3, kind)
    kind = np.where(in_y[:, None] & in_x[None, :], kind, 0)
    return palette[kind]


def to_ppm(pixels: np.ndarray) -> bytes:
    """Binary PPM (P6) bytes, which Tk's photo image reads without any extension."""
    h, w, _ = pixels.shape
    return b"P6\n%d %d\n255\n" % (w, h) + np.ascontiguousarray(pixels, dtype=np.uint8).tobytes()
