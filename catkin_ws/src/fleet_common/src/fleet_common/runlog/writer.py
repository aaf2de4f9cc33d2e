"""Appending to a run folder as the run goes.

`RunLog.record(kind, **fields)` writes one line; the file is flushed when a
second has passed since the last flush (and by `flush()`/`close()`), so a
crash loses at most the last second while a busy run does not pay a system
call per line. The records a manager started again on the folder needs
(`records.DURABLE`: commands, replies, actions ...) are written through at
once: a killed process loses none of them (the kernel has them), only poses.
Within `batch()` they are written through once, at the end of the block: the
manager writes a batch's records before its commands leave, so one system call
a batch does what one a record did.
Times are taken from the clock given (monotonic by default) relative to the
log's start, unless the caller passes `t` (the simulator's plan steps).

`cut_torn_tail` makes a folder whose writer was killed mid-line ready to be
appended to again: the torn last line is cut off.
"""
from __future__ import annotations

import json
import math
import shutil
import time
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable, Iterator, Optional, TextIO, Union

from ..errors import FleetError
from .records import DEFINITIONS_FILE, DURABLE, EVENTS_FILE, FORMAT_VERSION, KINDS

__all__ = ["RunLog", "new_run_folder", "cut_torn_tail"]

FLUSH_EVERY = 1.0  # seconds: the most a crash may lose


def new_run_folder(parent: Union[str, Path], now: Optional[datetime] = None) -> Path:
    """A new, empty `parent/<UTC timestamp>/` (suffixed -2, -3 ... if taken)."""
    stamp = (now or datetime.now(timezone.utc)).strftime("%Y%m%d-%H%M%S")
    parent = Path(parent)
    if parent.exists() and not parent.is_dir():
        raise FleetError("cannot make a run folder in {}: it is a file, not a folder".format(parent))
    try:
        parent.mkdir(parents=True, exist_ok=True)
        for n in range(1, 1000):
            folder = parent / (stamp if n == 1 else "{}-{}".format(stamp, n))
            try:
                folder.mkdir()
                return folder
            except FileExistsError:
                continue
    except OSError as err:
        raise FleetError("cannot make a run folder in {}: {}".format(parent, err.strerror)) from err
    raise FleetError("cannot make a run folder in {}: 999 runs in one second".format(parent))


def cut_torn_tail(folder: Union[str, Path]) -> int:
    """Cut a torn last line (no newline: its writer was killed while writing it) off the
    folder's events.jsonl, so that lines appended after it stay lines; the bytes cut."""
    path = Path(folder) / EVENTS_FILE
    try:
        with open(path, "rb+") as f:
            size = f.seek(0, 2)
            if size == 0:
                return 0
            end = size
            while end > 0:  # back to the last newline, a block at a time
                start = max(0, end - 65536)
                f.seek(start)
                block = f.read(end - start)
                cut = block.rfind(b"\n")
                if cut >= 0:
                    keep = start + cut + 1
                    break
                end = start
            else:
                keep = 0
            if keep < size:
                f.truncate(keep)
            return size - keep
    except OSError as err:
        raise FleetError("cannot repair {}: {}".format(path, err.strerror)) from err


def _clean(value: Any) -> Any:
    """JSON-ready: tuples as lists, numpy numbers as Python ones, non-finite floats as null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if hasattr(value, "item") and callable(value.item):  # numpy scalar
        return _clean(value.item())
    return value


_ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False)


class RunLog:
    """The open events.jsonl of one run folder."""

    def __init__(self, folder: Union[str, Path], clock: Callable[[], float] = time.monotonic) -> None:
        self.folder = Path(folder)
        self.clock = clock
        self.start = clock()
        self._last_flush = self.start
        try:
            self._file: Optional[TextIO] = open(self.folder / EVENTS_FILE, "a", encoding="utf-8")
        except OSError as err:
            raise FleetError("cannot write {}: {}".format(self.folder / EVENTS_FILE, err.strerror)) from err
        self.lines = 0
        self._batched = False  # inside batch(): flushes wait for its end
        self._owed = False  # a flush is owed at the end of the batch

    def now(self) -> float:
        """Seconds since the log started, by its clock."""
        return self.clock() - self.start

    def record(self, kind: str, t: Optional[float] = None, **fields: Any) -> None:
        """Append one line of `kind` (see records.py); a programming error if fields are missing."""
        required = KINDS.get(kind)
        if required is None:
            raise ValueError("unknown run log kind {!r}; known: {}".format(kind, ", ".join(KINDS)))
        missing = [f for f in required if f not in fields]
        if missing:
            raise ValueError("run log {} record lacks {}".format(kind, ", ".join(missing)))
        if self._file is None:
            return
        line = {"t": round(self.now() if t is None else float(t), 4), "k": kind}
        line.update(fields)
        try:  # the common case in one C call: plain Python values (tuples become lists)
            text = _ENCODER.encode(line)
        except (ValueError, TypeError):  # a NaN or infinity, a numpy number: cleaned first
            text = _ENCODER.encode(_clean(line))
        self._file.write(text + "\n")
        self.lines += 1
        now = self.clock()
        if kind in DURABLE or now - self._last_flush >= FLUSH_EVERY:
            if self._batched:
                self._owed = True
            else:
                self.flush(now)

    @contextmanager
    def batch(self) -> Iterator[None]:
        """Records written in the block are flushed (if one was due) once, when it ends."""
        self._batched = True
        try:
            yield
        finally:
            self._batched = False
            if self._owed:
                self._owed = False
                self.flush()

    def run_started(self, *, source: str, time_unit: str, plan: str, robots: list,
                    strategy: str, **more: Any) -> None:
        """The first record: what this run is."""
        self.record("run", version=FORMAT_VERSION, started=datetime.now(timezone.utc).isoformat(
            timespec="milliseconds"), source=source, time_unit=time_unit, plan=plan,
            robots=robots, strategy=strategy, **more)

    def copy_in(self, source: Union[str, Path], name: str = DEFINITIONS_FILE) -> str:
        """Copy a file (the definitions) into the folder; its name there."""
        shutil.copyfile(str(source), str(self.folder / name))
        return name

    def write_text(self, name: str, text: str) -> str:
        (self.folder / name).write_text(text, encoding="utf-8")
        return name

    def flush(self, now: Optional[float] = None) -> None:
        if self._file is not None:
            self._file.flush()
        self._last_flush = self.clock() if now is None else now

    def close(self) -> None:
        if self._file is not None:
            self._file.flush()
            self._file.close()
            self._file = None

    def __enter__(self) -> "RunLog":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
