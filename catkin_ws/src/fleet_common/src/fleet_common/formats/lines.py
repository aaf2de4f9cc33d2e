"""The lines of a text file, one at a time and within limits, so readers stop at the first error.

A reader that reads a whole file before it looks at it spends 10 s and 1.8 GB
on a 50 MB instance whose line 33 is wrong. `open_lines` checks the file's
size first (`MAX_FILE_BYTES`), then hands out numbered lines as it reads them,
each at most `MAX_LINE_CHARS` long, so a reader that raises at line 33 has
read 33 lines. `text_lines` gives the same for text already in memory.

Lines come without their endings, decoded as UTF-8 with `surrogateescape` (a
bad byte survives a write back). As `header.split_lines` does: the first
line's ending says whether the file is CRLF, and then a trailing CR is
dropped from every line; `newline` and `final_newline` are known once the
lines have been read, so a writer can reproduce the file's bytes.
"""
from __future__ import annotations

import contextlib
import os
from typing import BinaryIO, Iterable, Iterator, Optional, Tuple, Type

from ..errors import FormatError
from ..limits import MAX_FILE_BYTES, MAX_LINE_CHARS

__all__ = ["Lines", "open_lines", "text_lines", "check_file_size", "read_bytes", "read_text"]


class Lines:
    """Numbered lines `(number, text)` from `chunks` (lines with their "\\n", the last one
    maybe without); iterate once."""

    def __init__(self, chunks: Iterable[str], path: Optional[str],
                 error: Type[FormatError], max_line: int = MAX_LINE_CHARS) -> None:
        self._chunks = iter(chunks)
        self.path = path
        self.error = error
        self.max_line = max_line
        self.newline = "\n"
        self.final_newline = False
        self.count = 0  # lines handed out so far

    def __iter__(self) -> Iterator[Tuple[int, str]]:
        crlf = False
        for chunk in self._chunks:
            self.count += 1
            ended = chunk.endswith("\n")
            line = chunk[:-1] if ended else chunk
            if len(line) > self.max_line:
                raise self.error("line of {:,} characters; lines may have at most {:,}".format(
                    len(line), self.max_line), self.path, self.count)
            if self.count == 1 and ended and line.endswith("\r"):
                crlf, self.newline = True, "\r\n"
            if crlf and line.endswith("\r"):
                line = line[:-1]
            self.final_newline = ended
            yield self.count, line


def text_lines(text: str, path: Optional[str], error: Type[FormatError]) -> Lines:
    """The lines of `text`, as a file's would be read."""
    parts = text.split("\n")
    chunks = [p + "\n" for p in parts[:-1]]
    if parts[-1]:
        chunks.append(parts[-1])
    return Lines(chunks, path, error)


def check_file_size(f: BinaryIO, path: str, error: Type[FormatError],
                    max_bytes: int = MAX_FILE_BYTES) -> None:
    """FormatError before reading when the open file `f` is larger than `max_bytes`."""
    size = os.fstat(f.fileno()).st_size
    if size > max_bytes:
        raise error("file of {:,} bytes; files may have at most {:,}".format(size, max_bytes),
                    path, None)


def read_bytes(path: str, error: Type[FormatError] = FormatError,
               max_bytes: int = MAX_FILE_BYTES) -> bytes:
    """A whole file's bytes, its size checked first."""
    try:
        with open(path, "rb") as f:
            check_file_size(f, path, error, max_bytes)
            data = f.read(max_bytes + 1)
    except OSError as err:
        raise error("cannot read: {}".format(err.strerror), path) from None
    if len(data) > max_bytes:  # a special file that said size 0
        raise error("more than {:,} bytes; files may have at most that".format(max_bytes), path)
    return data


def read_text(path: str, error: Type[FormatError] = FormatError,
              max_bytes: int = MAX_FILE_BYTES, strict: bool = False) -> str:
    """A whole file's text, its size checked first. Bytes that are not UTF-8 survive a
    write back (surrogateescape), or with `strict` are an error naming their line."""
    data = read_bytes(path, error, max_bytes)
    if not strict:
        return data.decode("utf-8", "surrogateescape")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        column = err.start - (data.rfind(b"\n", 0, err.start) + 1) + 1
        raise error("byte {:#04x} is not UTF-8 text".format(data[err.start]), path, line,
                    column) from None


@contextlib.contextmanager
def open_lines(path: str, error: Type[FormatError],
               max_bytes: int = MAX_FILE_BYTES) -> Iterator[Lines]:
    """`with open_lines(path, Error) as lines:` the file's lines, read as they are used."""
    try:
        f = open(path, "rb")
    except OSError as err:
        raise error("cannot read: {}".format(err.strerror), path) from None
    with f:
        check_file_size(f, path, error, max_bytes)
        yield Lines(_chunks(f, path, error, max_bytes), path, error)


def _chunks(f: BinaryIO, path: str, error: Type[FormatError], max_bytes: int) -> Iterator[str]:
    total = number = 0
    limit = MAX_LINE_CHARS + 2  # a line, its CR and LF
    while True:
        raw = f.readline(limit)
        if not raw:
            return
        number += 1
        total += len(raw)
        if len(raw) == limit and not raw.endswith(b"\n"):
            raise error("line longer than {:,} bytes; lines may have at most {:,} characters".format(
                MAX_LINE_CHARS, MAX_LINE_CHARS), path, number)
        if total > max_bytes:  # a pipe or a special file says size 0 and goes on
            raise error("more than {:,} bytes; files may have at most that".format(max_bytes),
                        path, None)
        yield raw.decode("utf-8", "surrogateescape")
