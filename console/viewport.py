"""Viewport: base-grid cells to canvas pixels and back, with zoom and pan.

The map occupies a rectangle of `cell` pixels per cell whose top-left corner
is at canvas pixel (ox, oy). Cell (x, y)'s centre is at
`(ox + (x + 0.5) * cell, oy + (row + 0.5) * cell)` where `row` counts from the
top: `height - 1 - y` when y grows up the screen (the lab view), `y` when it
grows down. A canvas pixel (px, py) covers the point (px + 0.5, py + 0.5).
`fit` centres the whole map in the area between the header band (`top`), a
band at the bottom and one on the right (`bottom`, `right`: the presentation
view's ticker and legend); zooming keeps the point under the mouse still. Pure arithmetic, vectorised for many agents.
"""
from __future__ import annotations

import math
from typing import Tuple

import numpy as np

from fleet_common.grid import Coord

#: Free pixels around the map when it is fitted (room for the axes).
MARGIN = 24
MIN_CELL = 0.5
MAX_CELL = 400.0


class Viewport:
    """Maps base cells of a `width` x `height` grid onto a `canvas_w` x `canvas_h` canvas."""

    def __init__(self, width: int, height: int, canvas_w: int, canvas_h: int, top: int = 0,
                 down: bool = False, bottom: int = 0, right: int = 0) -> None:
        self.width = width
        self.height = height
        self.canvas_w = canvas_w
        self.canvas_h = canvas_h
        self.top = top
        self.bottom = bottom
        self.right = right
        self.down = down
        self.cell = 1.0
        self.ox = 0.0
        self.oy = 0.0
        self.fit()

    def resize(self, canvas_w: int, canvas_h: int) -> None:
        self.canvas_w, self.canvas_h = canvas_w, canvas_h
        self.fit()

    def fit(self) -> None:
        """The whole map, as large as fits, centred below the header band."""
        aw = max(self.canvas_w - self.right - 2 * MARGIN, 1)
        ah = max(self.canvas_h - self.top - self.bottom - 2 * MARGIN, 1)
        cell = min(aw / max(self.width, 1), ah / max(self.height, 1))
        if cell >= 4:
            cell = math.floor(cell)  # whole pixels: even grid lines
        self.cell = min(max(cell, MIN_CELL), MAX_CELL)
        self.ox = math.floor((self.canvas_w - self.right - self.width * self.cell) / 2)
        self.oy = math.floor(self.top + (self.canvas_h - self.top - self.bottom - self.height * self.cell) / 2)

    def _row(self, y: float) -> float:
        return y if self.down else self.height - 1 - y

    def to_canvas(self, x: float, y: float) -> Tuple[float, float]:
        """Canvas position of the centre of (fractional) cell (x, y)."""
        return (self.ox + (x + 0.5) * self.cell, self.oy + (self._row(y) + 0.5) * self.cell)

    def to_canvas_array(self, cells: np.ndarray) -> np.ndarray:
        """(N, 2) cell coordinates -> (N, 2) canvas centres."""
        cells = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
        out = np.empty_like(cells)
        out[:, 0] = self.ox + (cells[:, 0] + 0.5) * self.cell
        rows = cells[:, 1] if self.down else self.height - 1 - cells[:, 1]
        out[:, 1] = self.oy + (rows + 0.5) * self.cell
        return out

    def to_cell(self, px: float, py: float) -> Coord:
        """The cell under canvas point (px, py); may lie outside the map."""
        x = math.floor((px - self.ox) / self.cell)
        row = math.floor((py - self.oy) / self.cell)
        return (x, row if self.down else self.height - 1 - row)

    def map_box(self) -> Tuple[float, float, float, float]:
        """(x0, y0, x1, y1): the map's rectangle on the canvas."""
        return (self.ox, self.oy, self.ox + self.width * self.cell, self.oy + self.height * self.cell)

    def zoom(self, factor: float, px: float, py: float) -> None:
        """Scale by `factor`, keeping canvas point (px, py) over the same map point."""
        cell = min(max(self.cell * factor, MIN_CELL), MAX_CELL)
        factor = cell / self.cell
        self.ox = px - (px - self.ox) * factor
        self.oy = py - (py - self.oy) * factor
        self.cell = cell

    def pan(self, dx: float, dy: float) -> None:
        self.ox += dx
        self.oy += dy

    def set_down(self, down: bool) -> None:
        """Mirror top to bottom inside the same rectangle (the view stays where it was)."""
        self.down = down

    def centre_on(self, x: float, y: float) -> None:
        """Pan so that cell (x, y) is in the middle of the area below the header."""
        cx, cy = self.to_canvas(x, y)
        self.pan((self.canvas_w - self.right) / 2 - cx, (self.top + self.canvas_h - self.bottom) / 2 - cy)

    def shows(self, x: float, y: float) -> bool:
        cx, cy = self.to_canvas(x, y)
        return 0 <= cx < self.canvas_w - self.right and self.top <= cy < self.canvas_h - self.bottom
