"""A time budget passed into solvers as an object, so that runs are repeatable.

Solvers never read the wall clock themselves: they ask a `Deadline` whether it
has expired. Tests hand in a fake clock; `Deadline(None)` never expires.
"""
from __future__ import annotations

import time
from typing import Callable, Optional, Union


class Deadline:
    """Expires `seconds` after it was made (never when `seconds` is None)."""

    __slots__ = ("seconds", "_clock", "_start", "_end")

    def __init__(self, seconds: Optional[float], clock: Callable[[], float] = time.monotonic) -> None:
        if seconds is not None and seconds < 0:
            raise ValueError("a time limit cannot be negative, got {}".format(seconds))
        self.seconds = seconds
        self._clock = clock
        self._start = clock()
        self._end = None if seconds is None else self._start + seconds

    def expired(self) -> bool:
        return self._end is not None and self._clock() >= self._end

    def remaining(self) -> Optional[float]:
        """Seconds left (0.0 once expired), or None for an unlimited budget."""
        if self._end is None:
            return None
        return max(0.0, self._end - self._clock())

    def elapsed(self) -> float:
        return self._clock() - self._start

    def __repr__(self) -> str:
        return "Deadline({})".format(self.seconds)


def as_deadline(value: Union[None, float, Deadline]) -> Deadline:
    """A `Deadline` from a Deadline, a number of seconds or None (no limit)."""
    if isinstance(value, Deadline):
        return value
    return Deadline(None if value is None else float(value))
