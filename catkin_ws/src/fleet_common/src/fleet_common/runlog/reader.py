"""Reading a run folder back: its metadata, its plans, its records.

A run that crashed may end in a torn line: the last line is skipped if it
does not parse (and only the last: a bad line in the middle is an error
naming the line, since the file has been damaged). Kinds this version does
not know are kept (readers of a newer log still see what they know).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Union

from ..errors import FleetError, FormatError
from ..limits import MAX_FILE_BYTES, MAX_LINE_CHARS, DecodeError, loads_frame, one_line
from .records import DEFINITIONS_FILE, EVENTS_FILE, FORMAT_VERSION

__all__ = ["RunFolder", "RunLogError", "read_run"]

Record = Dict[str, Any]


class RunLogError(FormatError):
    """A run folder that is not one, or whose events.jsonl is damaged."""


class RunFolder:
    """A run folder read back: `run` (the first record), `records` (all, in order)."""

    def __init__(self, folder: Path, records: List[Record], torn: bool) -> None:
        self.folder = folder
        self.records = records
        self.torn = torn  # the last line was cut off (the run did not end cleanly)
        self.run: Record = records[0]

    @property
    def robots(self) -> List[int]:
        """Robot id of each plan agent, as the run started."""
        return list(self.run["robots"])

    @property
    def time_unit(self) -> str:
        return str(self.run.get("time_unit", "s"))

    @property
    def definitions(self) -> Optional[Path]:
        path = self.folder / DEFINITIONS_FILE
        return path if path.is_file() else None

    def plan_files(self) -> List[Path]:
        """Every plan of the run in the order it was used (the first, then replans)."""
        names = [self.run["plan"]] + [r["file"] for r in self.of("plan") if r.get("reason") != "loaded"]
        return [self.folder / n for n in names]

    def of(self, *kinds: str) -> Iterator[Record]:
        return (r for r in self.records if r.get("k") in kinds)

    def last(self, kind: str) -> Optional[Record]:
        for r in reversed(self.records):
            if r.get("k") == kind:
                return r
        return None

    @property
    def ended(self) -> bool:
        return self.last("end") is not None


def read_run(folder: Union[str, Path]) -> RunFolder:
    folder = Path(folder)
    path = folder / EVENTS_FILE
    if not path.is_file():
        raise RunLogError("not a run folder: no {} in it".format(EVENTS_FILE), str(folder))
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise RunLogError("{:,} bytes; at most {:,} are read".format(size, MAX_FILE_BYTES),
                              str(path))
        lines = path.read_bytes().split(b"\n")
    except OSError as err:
        raise FleetError("cannot read {}: {}".format(path, err.strerror)) from err
    if lines and lines[-1] == b"":
        lines.pop()
    records: List[Record] = []
    torn = False
    for number, line in enumerate(lines, 1):
        try:
            record = loads_frame(line, max_bytes=MAX_LINE_CHARS)
            if not isinstance(record, dict) or not isinstance(record.get("k"), str):
                raise DecodeError("not an object with a kind 'k'")
        except DecodeError as err:
            if number == len(lines):
                torn = True  # cut off by a crash: everything before it stands
                break
            raise RunLogError("damaged line: {}".format(one_line(str(err), 80)), str(path),
                              number) from None
        records.append(record)
    if not records or records[0]["k"] != "run":
        raise RunLogError("the first line is not the run's 'run' record", str(path), 1)
    version = records[0].get("version")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise RunLogError("run log format version {!r}; this FleetControl reads up to {}".format(
            version, FORMAT_VERSION), str(path), 1)
    return RunFolder(folder, records, torn)
