"""MovingAI `.map` grid files, read the way mapf-IR reads them.

A map is header lines up to a line `map` (`height N` and `width N` required,
anything else such as `type octile` kept verbatim), then exactly `height` rows
of exactly `width` characters, top row first. Under mapf-IR's rule `T` and `@`
block a cell and every other character is free; the strict MovingAI rule also
blocks `W` and `O`. Maps have no coordinates, so nothing flips here: the grid
is built bottom row first, as the base frame wants. Header lines, rows, line
endings (CRLF is accepted and kept, and so is a mix of LF and CRLF, as mapf-IR
reads it) and the final newline are remembered, so writing an unchanged map
reproduces its bytes.
"""
from __future__ import annotations

import os
import re
from typing import List, Optional

import numpy as np

from ..errors import MapFormatError
from ..grid import MAPF_IR_BLOCKED, MOVINGAI_BLOCKED, Grid
from .header import join_lines, read_text, split_lines, write_text

_SIZE = re.compile(r"(height|width)\s(\d+)")
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
        return "a carriage return inside a row"
    if ord(ch) < 32 or ord(ch) == 127:
        return "control character {!r}".format(ch)
    return "non-ASCII character {!r}".format(ch)


def parse_map(text: str, path: Optional[str] = None, strict: bool = False) -> MapFile:
    """Parse map text; `strict` applies the MovingAI rule (W and O block too)."""
    lines, newline, final_newline = split_lines(text)
    if not lines or all(not ln.strip() for ln in lines):
        raise MapFormatError(
            "empty file; expected 'height N', 'width N' and 'map' lines, then the grid rows",
            path, 1,
        )
    sizes = {}  # "height"/"width" -> (value, line number)
    map_index = -1
    for i, line in enumerate(lines):
        if line == "map":
            map_index = i
            break
        m = _SIZE.fullmatch(line)
        word = _SIZE_WORD.match(line)
        if m is None and word is not None:
            raise MapFormatError(
                "expected '{} N' with N a positive integer, got '{}'".format(word.group(1), line),
                path, i + 1,
            )
        if m is not None:
            key, value = m.group(1), int(m.group(2))
            if key in sizes:
                raise MapFormatError(
                    "'{}' given twice (first on line {})".format(key, sizes[key][1]), path, i + 1
                )
            if value <= 0:
                raise MapFormatError(
                    "'{}' must be a positive integer, got {}".format(key, value), path, i + 1
                )
            sizes[key] = (value, i + 1)
    if map_index < 0:
        raise MapFormatError(
            "'map' line missing: expected a line 'map' between the header and the grid rows",
            path, len(lines),
        )
    for key in ("height", "width"):
        if key not in sizes:
            raise MapFormatError(
                "'{} N' missing before the 'map' line".format(key), path, map_index + 1
            )
    height, width = sizes["height"][0], sizes["width"][0]
    rows = lines[map_index + 1:]
    first_row_line = map_index + 2
    for r, row in enumerate(rows[:height]):
        if len(row) == width and row.isascii() and row.isprintable():
            continue
        col = _bad_char_column(row)
        if col:
            raise MapFormatError(
                "{} in a grid row; expected map characters such as '.', '@', 'T'".format(
                    _describe(row[col - 1])), path, first_row_line + r, col,
            )
        if len(row) < width:
            raise MapFormatError(
                "row too short: {} cells, expected {} (width {})".format(len(row), width, width),
                path, first_row_line + r, len(row) + 1,
            )
        raise MapFormatError(
            "row too long: {} cells, expected {} (width {})".format(len(row), width, width),
            path, first_row_line + r, width + 1,
        )
    if len(rows) < height:
        raise MapFormatError(
            "too few rows: {} after 'map', expected {} (height {})".format(len(rows), height, height),
            path, len(lines),
        )
    if len(rows) > height:
        raise MapFormatError(
            "too many rows: expected {} after 'map' (height {}), found {}".format(
                height, height, len(rows)), path, first_row_line + height,
        )
    blocked = MOVINGAI_BLOCKED if strict else MAPF_IR_BLOCKED
    cells = np.frombuffer("".join(rows).encode("ascii"), dtype=np.uint8).reshape(height, width)
    free = ~np.isin(cells, np.frombuffer("".join(sorted(blocked)).encode("ascii"), dtype=np.uint8))
    name = os.path.basename(path) if path else ""
    # rows are top to bottom; the base frame's row 0 is the bottom one
    grid = Grid(free[::-1].copy(), name=name)
    return MapFile(grid, lines[: map_index + 1], rows, newline, final_newline, path)


def read_map(path: str, strict: bool = False) -> MapFile:
    return parse_map(read_text(str(path)), str(path), strict)


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
