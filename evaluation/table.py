"""The results table: one row a cell, CSV while the sweep runs, Parquet when it ends.

The CSV is appended and flushed as each cell finishes, so an interrupted
sweep keeps every finished cell and a resumed one reads their keys back
(a torn last line, from a crash mid-write, is dropped and run again). At the
end both files are written in cell order, so a sweep's table does not depend
on which worker finished first. Types are fixed per column (`TYPES`), the
same in both files.
"""
from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Dict, Iterable, List, Optional, TextIO

import pyarrow as pa
import pyarrow.parquet as pq

from fleet_common.errors import FormatError
from fleet_common.formats.lines import read_text

from .row import ADDED, COLUMNS, Row

CSV_NAME = "results.csv"
PARQUET_NAME = "results.parquet"

_INT = ("agents", "seed", "plan_makespan", "plan_soc", "waits", "collisions", "reached", "moves", "reroutes")
_BOOL = ("finished", "replanned", "trim")
_STR = ("key", "plan", "solver", "strategy", "size", "delay", "disable", "recover", "reroute", "reroute_scope",
        "wait_by_robot", "blocked_by")
TYPES: Dict[str, pa.DataType] = {
    c: pa.int64() if c in _INT else pa.bool_() if c in _BOOL else pa.string() if c in _STR else pa.float64()
    for c in COLUMNS}


class ResultsTableError(FormatError):
    """A results file that is not one of ours."""


def _parse(column: str, text: str) -> object:
    if text == "":
        return None
    kind = TYPES[column]
    if kind == pa.int64():
        return int(text)
    if kind == pa.bool_():
        return text == "True"
    if kind == pa.float64():
        return float(text)
    return text


def read_csv(path: Path) -> List[Row]:
    """Rows of a results CSV (a torn last line is dropped)."""
    lines = read_text(str(path), ResultsTableError, strict=True).splitlines(keepends=True)
    if lines and not lines[-1].endswith("\n"):
        lines.pop()  # cut off mid-write
    reader = csv.reader(io.StringIO("".join(lines)))
    header = next(reader, None)
    if header is None:
        return []
    columns = tuple(header)
    # an older table lacks some columns added since (ADDED), the others in order
    if columns != tuple(c for c in COLUMNS if c in columns) or not set(COLUMNS) - set(columns) <= set(ADDED):
        raise ResultsTableError("not a results table of this version: columns {}".format(",".join(header[:4])),
                                str(path), 1)
    rows = []
    for number, fields in enumerate(reader, 2):
        if len(fields) != len(columns):
            raise ResultsTableError("expected {} fields, got {}".format(len(columns), len(fields)), str(path), number)
        try:
            row = dict(ADDED)  # an older table's rows: what its runs were
            row.update((c, _parse(c, f)) for c, f in zip(columns, fields))
            rows.append({c: row[c] for c in COLUMNS})
        except ValueError as err:
            raise ResultsTableError("bad value: {}".format(err), str(path), number) from None
    return rows


def read_table(path: Path) -> List[Row]:
    """Rows of a results table: a .csv, a .parquet, or a sweep's folder holding them."""
    if path.is_dir():
        path = path / PARQUET_NAME if (path / PARQUET_NAME).is_file() else path / CSV_NAME
    if path.suffix == ".parquet":
        try:
            return pq.read_table(str(path)).to_pylist()
        except (OSError, pa.ArrowException) as err:
            raise ResultsTableError("not a Parquet results table: {}".format(err), str(path)) from None
    return read_csv(path)


class CsvAppender:
    """Appends rows to a results CSV, flushing each one."""

    def __init__(self, path: Path) -> None:
        fresh = not path.is_file() or path.stat().st_size == 0
        self._file: Optional[TextIO] = open(path, "a", encoding="utf-8", newline="")
        self._writer = csv.writer(self._file, lineterminator="\n")
        if fresh:
            self._writer.writerow(COLUMNS)

    def add(self, row: Row) -> None:
        self._writer.writerow(["" if row[c] is None else row[c] for c in COLUMNS])
        assert self._file is not None
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def write_tables(folder: Path, rows: Iterable[Row]) -> None:
    """Both files, rows as given (cell order), replacing what was there."""
    rows = list(rows)
    tmp = folder / (CSV_NAME + ".tmp")
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(COLUMNS)
        for row in rows:
            writer.writerow(["" if row[c] is None else row[c] for c in COLUMNS])
    os.replace(tmp, folder / CSV_NAME)
    schema = pa.schema([(c, TYPES[c]) for c in COLUMNS])
    table = pa.Table.from_pylist([{c: row[c] for c in COLUMNS} for row in rows], schema=schema)
    pq.write_table(table, str(folder / PARQUET_NAME))
