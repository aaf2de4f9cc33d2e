"""MovingAI `.map` grid files, read the way mapf-IR reads them.

A map is header lines up to a line `map` (`height N` and `width N` required,
anything else such as `type octile` kept verbatim), then exactly `height` rows
of exactly `width` characters, top row first. Under mapf-IR's rule `T` and `@`
block a cell and every other character is free; the strict MovingAI rule also
blocks `W` and `O`. Maps have no coordinates, so nothing flips here: the grid
is built bottom row first, as the base frame wants. Header lines, rows, line
endings (CRLF is accepted and kept) and the final newline are remembered, so
writing an unchanged map reproduces its bytes. Lines are checked as they are
read (formats/lines.py), so a bad row stops the reading there; sizes have at
most 9 digits and the grid is built only once every row has passed.
"""
from __future__ import annotations

import os
import re
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..errors import MapFormatError
from ..grid import MAPF_IR_BLOCKED, MOVINGAI_BLOCKED, Grid
from ..limits import MAX_CELL_DIGITS, excerpt
from .header import join_lines, write_text
from .lines import Lines, open_lines, text_lines

_SIZE = re.compile(r"(height|width)\s(\d+)", re.ASCII)
_SIZE_WORD = re.compile(r"(height|width)\b")


class MapFile:
    """A parsed `.map` file: its grid plus what is needed to write it back."""

    __slots__ = ("grid", "header_lines", "rows", "newline", "final_newline", "path")

    def __init__(
        self,
        grid: Grid,
        header_lines: List[str],
        rows: List[str],
        newline: str = "\n",
        final_newline: bool = True,
        path: Optional[str] = None,
    ) -> None:
        self.grid = grid
        self.header_lines = header_lines
        self.rows = rows
        self.newline = newline
        self.final_newline = final_newline
        self.path = path

    def __repr__(self) -> str:
        return "MapFile({!r}, {}x{})".format(self.path, self.grid.width, self.grid.height)


def _bad_char_column(row: str) -> int:
    for i, ch in enumerate(row):
        if not (" " <= ch <= "~"):
            return i + 1
    return 0


def _describe(ch: str) -> str:
    if ch == "\t":
        return "a tab"
    if ch == "\r":
        return "a carriage return (mixed line endings?)"
    if ord(ch) < 32 or ord(ch) == 127:
        return "control character {!r}".format(ch)
    return "non-ASCII character {!r}".format(ch)


def parse_map(text: str, path: Optional[str] = None, strict: bool = False) -> MapFile:
    """Parse map text; `strict` applies the MovingAI rule (W and O block too)."""
    return _parse(text_lines(text, path, MapFormatError), path, strict)


def read_map(path: str, strict: bool = False) -> MapFile:
    with open_lines(str(path), MapFormatError) as lines:
        return _parse(lines, str(path), strict)


def _parse(lines: Lines, path: Optional[str], strict: bool) -> MapFile:
    numbered = iter(lines)
    header_lines: List[str] = []
    sizes = {}  # "height"/"width" -> (value, line number)
    for no, line in numbered:
        header_lines.append(line)
        if line == "map":
            break
        _size_line(line, no, sizes, path)
    else:
        if not any(ln.strip() for ln in header_lines):
            raise MapFormatError(
                "empty file; expected 'height N', 'width N' and 'map' lines, then the grid rows",
                path, 1)
        raise MapFormatError(
            "'map' line missing: expected a line 'map' between the header and the grid rows",
            path, len(header_lines))
    map_no = len(header_lines)
    for key in ("height", "width"):
        if key not in sizes:
            raise MapFormatError("'{} N' missing before the 'map' line".format(key), path, map_no)
    height, width = sizes["height"][0], sizes["width"][0]
    rows: List[str] = []
    for no, row in numbered:
        if len(rows) == height:
            raise MapFormatError("too many rows: expected {} after 'map' (height {}), found "
                                 "more".format(height, height), path, no)
        _check_row(row, width, path, no)
        rows.append(row)
    if len(rows) < height:
        raise MapFormatError(
            "too few rows: {} after 'map', expected {} (height {})".format(len(rows), height, height),
            path, map_no + len(rows))
    blocked = MOVINGAI_BLOCKED if strict else MAPF_IR_BLOCKED
    cells = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8).reshape(height, width)
    free = ~np.isin(cells, np.frombuffer("".join(sorted(blocked)).encode("ascii"), dtype=np.uint8))
    name = os.path.basename(path) if path else ""
    # rows are top to bottom; the base frame's row 0 is the bottom one
    grid = Grid(free[::-1].copy(), name=name)
    return MapFile(grid, header_lines, rows, lines.newline, lines.final_newline, path)


def _size_line(line: str, no: int, sizes: Dict[str, Tuple[int, int]], path: Optional[str]) -> None:
    """Note a `height N` / `width N` header line in `sizes`; other lines are kept as they are."""
    m = _SIZE.fullmatch(line)
    word = _SIZE_WORD.match(line)
    if m is None and word is not None:
        raise MapFormatError("expected '{} N' with N a positive integer, got {}".format(
            word.group(1), excerpt(line)), path, no)
    if m is None:
        return
    key = m.group(1)
    if len(m.group(2)) > MAX_CELL_DIGITS:
        raise MapFormatError("'{}' has more than {} digits".format(key, MAX_CELL_DIGITS), path, no)
    value = int(m.group(2))
    if key in sizes:
        raise MapFormatError("'{}' given twice (first on line {})".format(key, sizes[key][1]),
                             path, no)
    if value <= 0:
        raise MapFormatError("'{}' must be a positive integer, got {}".format(key, value), path, no)
    sizes[key] = (value, no)


def _check_row(row: str, width: int, path: Optional[str], no: int) -> None:
    if len(row) == width and row.isascii() and row.isprintable():
        return
    col = _bad_char_column(row)
    if col:
        raise MapFormatError("{} in a grid row; expected map characters such as '.', '@', "
                             "'T'".format(_describe(row[col - 1])), path, no, col)
    if len(row) < width:
        raise MapFormatError("row too short: {} cells, expected {} (width {})".format(
            len(row), width, width), path, no, len(row) + 1)
    raise MapFormatError("row too long: {:,} cells, expected {} (width {})".format(
        len(row), width, width), path, no, width + 1)


def format_map(m: MapFile) -> str:
    return join_lines(list(m.header_lines) + list(m.rows), m.newline, m.final_newline)


def write_map(m: MapFile, path: str) -> None:
    write_text(str(path), format_map(m))


def map_from_grid(grid: Grid) -> MapFile:
    """A fresh map file for `grid`: '.' free, '@' blocked, mapf-IR's usual header."""
    chars = np.where(grid.free[::-1], ord("."), ord("@")).astype(np.uint8)
    rows = [r.tobytes().decode("ascii") for r in chars]
    header = ["type octile", "height {}".format(grid.height), "width {}".format(grid.width), "map"]
    return MapFile(grid, header, rows)
