"""Refused console requests in the run log: the first of each console a minute, then a count.

A console that sends 10,000 requests the manager refuses ("disable 99999")
must not write 10,000 records into the run folder, more than a whole run:
`RefusedRequests` lets the first refusal of each console in a window through
(`first`), counts the rest, and says how many it held back once the window
has passed (`due`), as one `refused` record. Consoles are told apart by their
socket identity; past `max_keys` at once, new ones share one count. Pure: the
time comes with each call.
"""
from __future__ import annotations

from typing import Dict, List, NamedTuple, Tuple

__all__ = ["RefusedRequests", "Held"]

_OTHERS = b"\x00others"


class Held(NamedTuple):
    """Refusals of `console` not recorded in the window of `seconds` that ended."""

    console: str
    requests: int
    seconds: float


class RefusedRequests:
    def __init__(self, window: float = 60.0, burst: int = 1, max_keys: int = 256) -> None:
        self.window = window
        self.burst = burst
        self.max_keys = max_keys
        # peer -> [window start, recorded, held, console name]
        self._windows: Dict[bytes, List] = {}
        self._ended: List[Held] = []  # counts of windows ended by the next refusal

    def first(self, peer: bytes, console: str, now: float) -> bool:
        """A request of `console` (at socket `peer`) was refused: record it (True) or count it."""
        window = self._windows.get(peer)
        if window is not None and now - window[0] >= self.window:
            if window[2]:
                self._ended.append(Held(window[3], window[2], round(min(now - window[0], self.window), 3)))
            return self._restart(peer, console, now)
        if window is None:
            if len(self._windows) >= self.max_keys and peer != _OTHERS:
                return self.first(_OTHERS, "other consoles", now)
            return self._restart(peer, console, now)
        if window[1] < self.burst:
            window[1] += 1
            return True
        window[2] += 1
        return False

    def due(self, now: float) -> List[Held]:
        """The counts of the windows that have passed (each once), and forget those windows."""
        out, self._ended = self._ended, []
        for peer, (start, _, held, console) in list(self._windows.items()):
            if now - start >= self.window:
                del self._windows[peer]
                if held:
                    out.append(Held(console, held, round(min(now - start, self.window), 3)))
        return out

    def _restart(self, peer: bytes, console: str, now: float) -> bool:
        self._windows[peer] = [now, 1, 0, console]
        return True

    def held(self) -> List[Tuple[str, int]]:
        """(console, refusals held back) in the current windows, for tests and status."""
        return [(w[3], w[2]) for w in self._windows.values()]
