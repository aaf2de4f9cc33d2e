"""The `key=value` lines at the top of mapf-IR files, and their line plumbing.

mapf-IR writes and reads these lines by regular expression, ignoring any key it
does not know, so a file may carry extra keys (ours: `orientation=base`). A
`Header` keeps every entry in file order with its raw value (everything after
the first `=`, spaces included: older mapf-IR wrote `instance= x`), so writing
a header back reproduces its bytes. Typed accessors turn a bad value into the
caller's `FormatError` subclass naming the file and the line of that entry.

Values are quoted in errors as short escaped excerpts (never megabytes, never
a CR that breaks the one-line message), and numbers are read within the limits
of `fleet_common.limits` (an integer of 5,000 digits is an error here, not a
ValueError from `int()`). `unknown_keys` warns about keys a format does not
know, naming the nearest known one: mapf-IR ignores such keys silently, so a
misspelled `max_timestep=` would otherwise do nothing without a word.

The text helpers below are shared by every line-based format here: files are
decoded as UTF-8 with `surrogateescape` and line endings (LF or CRLF) and the
final newline are remembered, so read-then-write reproduces a file's bytes
(`lines.py` reads them one at a time).
"""
from __future__ import annotations

import difflib
import re
from typing import Iterator, List, NamedTuple, Optional, Sequence, Tuple, Type, Union

from ..errors import FormatError, FormatWarning
from ..limits import MAX_INT_DIGITS, DecodeError, excerpt, parse_float, parse_int
from .lines import read_text  # noqa: F401 (whole-text readers import it from here)

_INT = re.compile(r"-?\d+", re.ASCII)
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", re.ASCII)


def write_text(path: str, text: str) -> None:
    with open(path, "wb") as f:
        f.write(text.encode("utf-8", "surrogateescape"))


def split_lines(text: str) -> Tuple[List[str], str, bool]:
    """Lines without their endings, the newline used (LF or CRLF), final newline?"""
    first = text.find("\n")
    newline = "\r\n" if first > 0 and text[first - 1] == "\r" else "\n"
    final_newline = text.endswith("\n")
    lines = text.split("\n")
    if final_newline or text == "":
        lines.pop()
    if newline == "\r\n":
        lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
    return lines, newline, final_newline


def join_lines(lines: List[str], newline: str = "\n", final_newline: bool = True) -> str:
    text = newline.join(lines)
    return text + newline if final_newline and lines else text


class HeaderEntry(NamedTuple):
    key: str
    value: str
    #: 1-based line in the file it was read from; None for entries set in code.
    line: Optional[int] = None


class Header:
    """Ordered `key=value` entries; keys may repeat (mapf-IR's `iter=` lines)."""

    __slots__ = ("entries", "path")

    def __init__(self, entries: Tuple[HeaderEntry, ...] = (), path: Optional[str] = None) -> None:
        self.entries: List[HeaderEntry] = [HeaderEntry(*e) for e in entries]
        #: the file the entries came from, named in errors.
        self.path = path

    # -- plain access ------------------------------------------------------
    def entry(self, key: str) -> Optional[HeaderEntry]:
        for e in self.entries:
            if e.key == key:
                return e
        return None

    def get(self, key: str) -> Optional[str]:
        """The raw value of the first `key=` line, or None."""
        e = self.entry(key)
        return None if e is None else e.value

    def get_all(self, key: str) -> List[str]:
        return [e.value for e in self.entries if e.key == key]

    def line_of(self, key: str) -> Optional[int]:
        e = self.entry(key)
        return None if e is None else e.line

    def set(self, key: str, value: object) -> None:
        """Replace the first `key=` entry's value (keeping its place) or append one."""
        text = str(value)
        for i, e in enumerate(self.entries):
            if e.key == key:
                self.entries[i] = HeaderEntry(key, text, e.line)
                return
        self.entries.append(HeaderEntry(key, text, None))

    def append(self, key: str, value: object, line: Optional[int] = None) -> None:
        self.entries.append(HeaderEntry(key, str(value), line))

    def remove(self, key: str) -> None:
        """Drop every `key=` entry."""
        self.entries = [e for e in self.entries if e.key != key]

    def keys(self) -> List[str]:
        """Keys in file order, repeated keys once."""
        seen: List[str] = []
        for e in self.entries:
            if e.key not in seen:
                seen.append(e.key)
        return seen

    def copy(self) -> "Header":
        return Header(tuple(self.entries), self.path)

    def lines(self) -> List[str]:
        """The entries as file lines, `key=value`, without newlines."""
        return [e.key + "=" + e.value for e in self.entries]

    # -- typed access ------------------------------------------------------
    def _fail(self, key: str, expected: str, error_cls: Type[FormatError]) -> FormatError:
        e = self.entry(key)
        shown = excerpt("" if e is None else e.value)
        return error_cls(
            "'{}=' must be {}, got {}".format(key, expected, shown),
            self.path,
            None if e is None else e.line,
        )

    def get_int(
        self, key: str, error_cls: Type[FormatError], minimum: Optional[int] = None
    ) -> Optional[int]:
        """The first `key=` value as an int (None when absent); strict digits, as mapf-IR."""
        value = self.get(key)
        if value is None:
            return None
        expected = "an integer" if minimum is None else "an integer >= {}".format(minimum)
        if _INT.fullmatch(value) is None:
            raise self._fail(key, expected, error_cls)
        try:
            number = parse_int(value)
        except DecodeError:
            raise self._fail(key, "{} of at most {} digits".format(expected, MAX_INT_DIGITS),
                             error_cls) from None
        if minimum is not None and number < minimum:
            raise self._fail(key, "an integer >= {}".format(minimum), error_cls)
        return number

    def get_bool(self, key: str, error_cls: Type[FormatError]) -> Optional[bool]:
        """A `0`/`1` flag (mapf-IR treats any non-zero number as true)."""
        value = self.get(key)
        if value is None:
            return None
        if not value.isdigit() or not value.isascii():
            raise self._fail(key, "0 or 1", error_cls)
        return value.strip("0") != ""  # any number but 0, however long

    def get_number(self, key: str, error_cls: Type[FormatError]) -> Optional[Union[int, float]]:
        """An int when written as one, else a float (comp_time in older mapf-IR)."""
        value = self.get(key)
        if value is None:
            return None
        try:
            if _INT.fullmatch(value):
                return parse_int(value)
            if _NUMBER.fullmatch(value) is not None:
                return parse_float(value)
        except DecodeError:
            raise self._fail(key, "a number of at most {} digits".format(MAX_INT_DIGITS),
                             error_cls) from None
        raise self._fail(key, "a number", error_cls)

    def get_str(self, key: str) -> Optional[str]:
        """The value without surrounding spaces (older mapf-IR wrote `instance= x`)."""
        value = self.get(key)
        return None if value is None else value.strip()

    def unknown_keys(self, known: Sequence[str], what: str) -> List[FormatWarning]:
        """A warning for each entry whose key is not in `known`, naming its line and the
        nearest known key; `what` names the file kind ("an instance")."""
        out = []
        for e in self.entries:
            if e.key in known:
                continue
            lowered = {k.lower(): k for k in known}
            near = difflib.get_close_matches(e.key.lower(), list(lowered), n=1, cutoff=0.6)
            hint = " (did you mean '{}'?)".format(lowered[near[0]]) if near else ""
            out.append(FormatWarning(
                "unknown key {}{} in {}; mapf-IR ignores it, and so does FleetControl".format(
                    excerpt(e.key), hint, what), self.path, e.line))
        return out

    # -- protocol ----------------------------------------------------------
    def __iter__(self) -> Iterator[Tuple[str, str]]:
        return iter([(e.key, e.value) for e in self.entries])

    def __len__(self) -> int:
        return len(self.entries)

    def __contains__(self, key: object) -> bool:
        return any(e.key == key for e in self.entries)

    def __eq__(self, other: object) -> bool:
        """Same keys and raw values in the same order (line numbers do not count)."""
        if not isinstance(other, Header):
            return NotImplemented
        return list(self) == list(other)

    def __repr__(self) -> str:
        return "Header({!r})".format(list(self))


# -- orientation of coordinates in a file ------------------------------------
#: Header key marking a file written in the base (lab) frame; mapf-IR ignores it.
ORIENTATION_KEY = "orientation"
MAPF_IR = "mapf-ir"
BASE = "base"
ORIENTATIONS = (MAPF_IR, BASE)


def file_orientation(header: Header, error_cls: Type[FormatError]) -> str:
    """MAPF_IR (top-left, y down: the default) or BASE when the header says so."""
    value = header.get_str(ORIENTATION_KEY)
    if value is None:
        return MAPF_IR
    if value not in ORIENTATIONS:
        raise header._fail(ORIENTATION_KEY, "'base' or 'mapf-ir'", error_cls)
    return value


def check_orientation(requested: Optional[str], current: str) -> str:
    """The orientation a writer uses: `requested`, or the file's own when None."""
    if requested is None:
        return current
    if requested not in ORIENTATIONS:
        raise ValueError(
            "orientation must be None, 'mapf-ir' or 'base', got {!r}".format(requested)
        )
    return requested


def header_for_orientation(header: Header, orientation: str) -> Header:
    """A copy whose `orientation=` line matches `orientation` (mapf-IR's needs none)."""
    out = header.copy()
    if orientation == BASE:
        if out.get_str(ORIENTATION_KEY) != BASE:
            out.set(ORIENTATION_KEY, BASE)
    elif out.get_str(ORIENTATION_KEY) == BASE:
        out.remove(ORIENTATION_KEY)
    return out
