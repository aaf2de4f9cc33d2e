"""Tk colours without a display: names and `#rgb` forms, and their RGB values.

The console draws each robot in the colour `robot_definitions.txt` gives it, so
that file may only hold colours Tk accepts. Tk resolves names through the X
server, which needs a display; instead `tk_colours.txt` (generated once from
Tk by `scripts/gen_tk_colours.py`) lists every name with its RGB. Names match
case-insensitively and without spaces ("Alice Blue" == "aliceblue"), as in Tk.
"""
from __future__ import annotations

import functools
import re
from pathlib import Path
from typing import Dict, Optional, Tuple

RGB = Tuple[int, int, int]

COLOURS_FILE = Path(__file__).with_name("tk_colours.txt")

# Tk's hex forms: the same number of hex digits (1 to 4) for each of r, g, b.
_HEX = re.compile(r"#(?:[0-9A-Fa-f]{3}){1,4}\Z")

#: What a colour may be, for error messages.
COLOUR_FORMS = "a Tk colour name (e.g. red, DarkOrange) or #rgb, #rrggbb, #rrrgggbbb"


@functools.lru_cache(maxsize=None)
def tk_colour_table() -> Dict[str, RGB]:
    """Every Tk colour name (lower case, no spaces) -> (r, g, b), 0-255."""
    table: Dict[str, RGB] = {}
    text = COLOURS_FILE.read_text(encoding="utf-8")
    for number, line in enumerate(text.splitlines(), 1):
        if not line or line.startswith("#"):
            continue
        fields = line.split()
        if len(fields) != 4:
            raise RuntimeError("{}:{}: expected 'name r g b'".format(COLOURS_FILE, number))
        table[fields[0]] = (int(fields[1]), int(fields[2]), int(fields[3]))
    return table


def _hex_to_rgb(colour: str) -> RGB:
    digits = colour[1:]
    n = len(digits) // 3
    parts = [int(digits[i * n:(i + 1) * n], 16) for i in range(3)]
    if n == 1:  # Tk repeats a single digit: #f80 is #ff8800
        return (parts[0] * 17, parts[1] * 17, parts[2] * 17)
    shift = 4 * (n - 2)  # longer forms: keep the most significant byte
    return (parts[0] >> shift, parts[1] >> shift, parts[2] >> shift)


def parse_colour(colour: str) -> Optional[RGB]:
    """(r, g, b) 0-255 for a colour Tk accepts, None for anything else."""
    if _HEX.match(colour):
        return _hex_to_rgb(colour)
    if colour != colour.strip() or "  " in colour:
        return None
    return tk_colour_table().get(colour.replace(" ", "").lower())


def is_tk_colour(colour: str) -> bool:
    return parse_colour(colour) is not None


def colour_to_rgb(colour: str) -> RGB:
    """(r, g, b), each 0-255, of a Tk colour name or hex form; ValueError otherwise."""
    rgb = parse_colour(colour)
    if rgb is None:
        raise ValueError("unknown colour {!r}: expected {}".format(colour, COLOUR_FORMS))
    return rgb
