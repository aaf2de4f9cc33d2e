"""The two ways to look at a plan: the lab's convention and mapf-IR's.

- `LAB` (default): the base grid, origin (0, 0) at the bottom-left cell, y up,
  as the lab's floor, the robots and the manager know it (thesis 3.2.2).
- `MAPF_IR`: the file's own coordinates with the origin at the top-left and y
  down, exactly what mapf-IR's visualizer draws for the same file (thesis
  2.2.4), cell ids (`y * width + x`) included.

Since mapf-IR files are flipped into the base frame when read, a mapf-IR file
shows the same picture in both views and only its coordinates change (axes,
cell ids, the cell under the mouse, conflict messages, positions); a file
written in the base frame (`orientation=base`) is mirrored top to bottom, as
mapf-IR's visualizer would draw it. A window opens in the view whose
coordinates are the file's own (`of_file`), so that what it says about a plan
reads as the file, `fleetctl validate` and the manager say it. Pure functions
of (view, file orientation).
"""
from __future__ import annotations

from fleet_common.formats.header import BASE, MAPF_IR as FILE_MAPF_IR
from typing import Tuple

from fleet_common.grid import Coord

LAB = "lab"
MAPF_IR = "mapf-ir"
VIEWS = (LAB, MAPF_IR)

#: What the toggle says about each view.
DESCRIPTIONS = {
    LAB: "lab convention: origin bottom-left, y up",
    MAPF_IR: "mapf-IR convention: origin top-left, y down",
}


def other(view: str) -> str:
    return MAPF_IR if view == LAB else LAB


def of_file(file_orientation: str) -> str:
    """The view whose coordinates are the file's own."""
    return MAPF_IR if file_orientation == FILE_MAPF_IR else LAB


def rows_grow_down(view: str, file_orientation: str) -> bool:
    """True when base y grows down the screen (the picture is mirrored)."""
    return view == MAPF_IR and file_orientation == BASE


def shown_cell(cell: Coord, height: int, view: str, file_orientation: str) -> Coord:
    """`cell` (base frame) in the coordinates the view shows to the user."""
    if view == MAPF_IR and file_orientation == FILE_MAPF_IR:
        return (cell[0], height - 1 - cell[1])
    return (int(cell[0]), int(cell[1]))


def shown_point(x: float, y: float, height: int, view: str, file_orientation: str) -> Tuple[float, float]:
    """A position (base frame, fractions of cells) in the coordinates the view shows."""
    if view == MAPF_IR and file_orientation == FILE_MAPF_IR:
        return (x, height - 1 - y)
    return (x, y)


def origin_at_top(view: str) -> bool:
    """Where the shown coordinates have their origin: the top-left corner in mapf-IR's view."""
    return view == MAPF_IR


def cell_id(cell: Coord, width: int, height: int, view: str, file_orientation: str) -> int:
    """The id of `cell` as the view numbers cells: `y * width + x` in shown coordinates."""
    x, y = shown_cell(cell, height, view, file_orientation)
    return y * width + x
