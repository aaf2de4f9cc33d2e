"""Exceptions a person can act on.

Every reader raises a `FormatError` subclass that names the file, the line (and
column when known) and what was expected; `str(err)` is the one line the
command line prints, `FILE:LINE[:COL]: message`. What a reader accepts but
doubts (an unknown header key) is a `FormatWarning`, issued with
`warnings.warn` and printed by the command line as `FILE:LINE: warning: ...`.
"""
from __future__ import annotations

from typing import Optional


class FleetError(Exception):
    """Base of every error FleetControl raises on purpose."""


class FormatError(FleetError, ValueError):
    """Malformed input: a file (or text) that does not follow its format."""

    def __init__(
        self,
        message: str,
        path: Optional[str] = None,
        line: Optional[int] = None,
        column: Optional[int] = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.path = path
        self.line = line
        self.column = column

    def location(self) -> str:
        parts = [self.path or "<text>"]
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        return ":".join(parts)

    def __str__(self) -> str:
        return "{}: {}".format(self.location(), self.message)

    def with_path(self, path: str) -> "FormatError":
        """The same error, naming `path` (readers parse text, then say which file)."""
        self.path = path
        return self


class FormatWarning(UserWarning):
    """Input read as written, but probably not as meant (a misspelled header key)."""

    def __init__(self, message: str, path: Optional[str] = None,
                 line: Optional[int] = None) -> None:
        super().__init__(message)
        self.message = message
        self.path = path
        self.line = line

    def __str__(self) -> str:
        where = self.path or "<text>"
        if self.line is not None:
            where += ":{}".format(self.line)
        return "{}: warning: {}".format(where, self.message)


class MapFormatError(FormatError):
    """A `.map` grid file is malformed."""


class InstanceFormatError(FormatError):
    """A mapf-IR instance (problem) file is malformed."""


class SolutionFormatError(FormatError):
    """A mapf-IR solution (solver output) file is malformed."""


class ScenFormatError(FormatError):
    """A MovingAI `.scen` file is malformed."""


class LegacyFormatError(FormatError):
    """A legacy FleetControl XML file (node map or execution plan) is malformed."""


class RobotDefinitionsError(FormatError):
    """`robot_definitions.txt` is malformed or inconsistent."""


class TransformError(FormatError):
    """A coordinate-frame transform file or fit is malformed."""


class MapNotFoundError(FormatError):
    """`map_file=` names a map that is in none of the searched folders."""


class NotConvertibleError(FleetError):
    """Input that is well formed but cannot be expressed in the target format."""
