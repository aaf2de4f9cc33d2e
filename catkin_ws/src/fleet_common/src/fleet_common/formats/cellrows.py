"""The cell lists of solution files, `(x,y),(x,y),` with optional headings, fast.

A row of a 1,500-agent file is some 15,000 characters and a file has a
thousand of them, so rows are never parsed entry by entry in Python: each is
checked by one compiled full match, then all rows become integers in one
numpy call. Only a row that fails its match is walked entry by entry, to name
the column and what was expected there. `RowReader` takes the rows one at a
time as the file is read, so a bad row stops the reading there.
"""
from __future__ import annotations

import re
from typing import Dict, List, Optional, Tuple

import numpy as np

from ..errors import SolutionFormatError
from ..plan import Orientation

_HEADING = r"[XY]_(?:PLUS|MINUS)"
# up to 9 digits keeps every coordinate, flipped or not, inside int32
_ENTRY = r"\(\d{1,9},\d{1,9}\),"
_ENTRY_HEADING = r"\(\d{1,9},\d{1,9}," + _HEADING + r"\),"
_ONE = re.compile(r"\((\d{1,9}),(\d{1,9})(?:,(" + _HEADING + r"))?\),", re.ASCII)
_NAMES = [o.name for o in sorted(Orientation)]
_CODES = {name: i for i, name in enumerate(_NAMES)}
_NAME_ARRAY = np.array(_NAMES, dtype=object)
FLIP_CODE = np.array([Orientation(i).flipped_y().value for i in range(len(_NAMES))], np.int8)
_row_patterns: Dict[Tuple[int, bool], "re.Pattern[str]"] = {}


def row_pattern(n: int, headings: bool) -> "re.Pattern[str]":
    key = (n, headings)
    if key not in _row_patterns:
        entry = _ENTRY_HEADING if headings else _ENTRY
        _row_patterns[key] = re.compile("(?:{}){{{}}}".format(entry, n), re.ASCII)
    return _row_patterns[key]


def entries_error(body: str, n: int, headings: Optional[bool], path: Optional[str],
                   no: int, offset: int) -> SolutionFormatError:
    """Walk a row that failed its full match: say where and what was expected."""
    pos = count = 0
    shape = "'(x,y,X_PLUS),'" if headings else "'(x,y),'"
    while pos < len(body):
        m = _ONE.match(body, pos)
        col = offset + pos + 1
        if m is None:
            rest = body[pos:pos + 12]
            long_number = re.match(r"\(\d*,?\d{10}", body[pos:pos + 24], re.ASCII)
            what = ("coordinate with more than 9 digits" if long_number else
                    "expected an entry {}, got {!r}".format(shape, rest))
            return SolutionFormatError(what, path, no, col)
        if headings is None and m.group(3):
            return SolutionFormatError("starts=/goals= entries carry no heading; expected "
                                       "'(x,y),'", path, no, col)
        if headings is not None and bool(m.group(3)) != headings:
            what = ("entry without a heading; the first solution row has headings on every "
                    "entry, so every row must" if headings else
                    "entry with a heading; the first solution row has none, so no row may")
            return SolutionFormatError(what, path, no, col)
        count += 1
        if count > n:
            return SolutionFormatError("more than {} entries (agents={})".format(n, n),
                                       path, no, col)
        pos = m.end()
    return SolutionFormatError("{} entries, expected {} (agents={})".format(count, n, n),
                               path, no, offset + len(body) + 1)


# Matched rows are ASCII; bytes.translate strips them to "x,y,...," at C speed.
# A heading's letters are kept as two digits: axis (X 0, Y 1), sign (PLUS 0, MINUS 2),
# so X_PLUS, Y_PLUS, X_MINUS, Y_MINUS read as 0, 10, 2, 12 (see _HEADING_CODE).
_DIGITS = bytes.maketrans(b"XYPM", b"0102")
_HEADING_CODE = np.zeros(13, dtype=np.int8)
_HEADING_CODE[[0, 10, 2, 12]] = [_CODES["X_PLUS"], _CODES["Y_PLUS"], _CODES["X_MINUS"],
                                 _CODES["Y_MINUS"]]


def _to_int_array(joined: str, n_values: int) -> np.ndarray:
    data = joined.encode("ascii").translate(_DIGITS, b"()_LUSIN")
    flat = np.fromstring(data, dtype=np.int64, sep=",")
    if flat.size != n_values:  # cannot happen after the full matches; never read short
        raise ValueError("expected {} numbers, converted {}".format(n_values, flat.size))
    return flat


def parse_cell_list(line: str, prefix: str, n: int, path: Optional[str], no: int) -> np.ndarray:
    body = line[len(prefix):]
    if row_pattern(n, False).fullmatch(body) is None:
        raise entries_error(body, n, None, path, no, len(prefix))
    return _to_int_array(body, 2 * n).reshape(n, 2)


class RowReader:
    """Solution rows `t:(x,y),...` of `n` agents, checked one at a time as they are read
    (the first row decides whether entries carry headings); `arrays()` at the end."""

    def __init__(self, n: int, path: Optional[str]) -> None:
        self.n = n
        self.path = path
        self.headings = False
        self.pattern: Optional["re.Pattern[str]"] = None
        self.bodies: List[str] = []

    def add(self, row: str, no: int) -> None:
        t = len(self.bodies)
        if self.pattern is None:
            self.headings = re.match(r"\(\d+,\d+,", row.partition(":")[2], re.ASCII) is not None
            self.pattern = row_pattern(self.n, self.headings)
        prefix = "%d:" % t
        if not row.startswith(prefix):
            m = re.match(r"(\d{1,18}):", row, re.ASCII)
            what = ("steps must count 0, 1, 2, ...: expected step {}, got {}".format(t, m.group(1))
                    if m else "expected '{}' (step number and ':') at the start of a solution "
                    "row".format(prefix))
            raise SolutionFormatError(what, self.path, no, 1)
        body = row[len(prefix):]
        if self.pattern.fullmatch(body) is None:
            raise entries_error(body, self.n, self.headings, self.path, no, len(prefix))
        self.bodies.append(body)

    def arrays(self) -> Tuple[np.ndarray, Optional[np.ndarray]]:
        """The rows as (T+1, n, 2) ints and (T+1, n) heading codes or None."""
        joined, rows, n = "".join(self.bodies), len(self.bodies), self.n
        if not self.headings:
            return _to_int_array(joined, 2 * n * rows).reshape(rows, n, 2), None
        flat = _to_int_array(joined, 3 * n * rows).reshape(rows, n, 3)
        return flat[..., :2], _HEADING_CODE[flat[..., 2]]


def flip_cells(cells: np.ndarray, height: int) -> np.ndarray:
    out = cells.copy()
    out[..., 1] = height - 1 - out[..., 1]
    return out


def format_cells(cells: np.ndarray, codes: Optional[np.ndarray]) -> str:
    n = cells.shape[0]
    if codes is None:
        return ("(%d,%d)," * n) % tuple(cells.ravel().tolist())
    flat = np.empty((n, 3), dtype=object)
    flat[:, :2] = cells
    flat[:, 2] = _NAME_ARRAY[codes]
    return ("(%d,%d,%s)," * n) % tuple(flat.ravel().tolist())
