"""Logs an operator can read under attack: repeated events from one peer, counted, not repeated.

A peer that sends 10,000 bad frames a second must not write 10,000 log lines a
second. `RateLimitedLog` logs the first `burst` events of each key and kind (a
peer and "refused frames", ...) in a window of `window` seconds and counts the rest;
once the window has passed it says how many it held back, in one line:

    robot 3: 9,812 more refused frames from 10.0.0.66 in the last 60 s

`flush(now)` says it for every window that has passed (call it from a
periodic tick, so the count appears even when the flood stops); an event of a
key whose window has passed says it first. Keys are bounded: past `max_keys`
at once, new keys share one ("other peers"), so a flood of addresses cannot
fill the memory either. Pure (a clock is passed in) and thread-safe.
"""
from __future__ import annotations

import logging
import threading
import time
from typing import Any, Callable, Dict, Optional, Tuple

__all__ = ["RateLimitedLog", "OTHER_PEERS"]

OTHER_PEERS = "other peers"


class _Window:
    __slots__ = ("start", "logged", "held", "what", "level")

    def __init__(self, start: float, what: str, level: int) -> None:
        self.start = start
        self.logged = 0
        self.held = 0
        self.what = what
        self.level = level


class RateLimitedLog:
    """At most `burst` lines per key per `window` seconds on `log`, plus one count of the rest."""

    def __init__(self, log: logging.Logger, window: float = 60.0, burst: int = 1,
                 clock: Callable[[], float] = time.monotonic, prefix: str = "",
                 max_keys: int = 1024) -> None:
        if window <= 0 or burst < 1 or max_keys < 1:
            raise ValueError("window must be positive, burst and max_keys at least 1")
        self.log = log
        self.window = window
        self.burst = burst
        self.clock = clock
        self.prefix = prefix
        self.max_keys = max_keys
        self._windows: Dict[Tuple[str, str], _Window] = {}
        self._lock = threading.Lock()
        self.events = 0  # every event, logged or held back (for tests and status)

    def event(self, level: int, key: str, what: str, msg: str, *args: Any,
              exc_info: bool = False) -> bool:
        """One event from `key` ("10.0.0.66"); `what` names such events in the count
        ("refused frames"). Logs `msg % args` unless this key's burst is used up in this
        window; returns whether it logged (`exc_info`: with the traceback)."""
        now = self.clock()
        with self._lock:
            self.events += 1
            window = self._window_for(key, what, level, now)
            if window.logged >= self.burst:
                window.held += 1
                return False
            window.logged += 1
        self.log.log(level, self.prefix + msg, *args, exc_info=exc_info)
        return True

    def flush(self, now: Optional[float] = None) -> None:
        """Say how many events were held back in every window that has passed; forget them."""
        now = self.clock() if now is None else now
        with self._lock:
            for key, window in list(self._windows.items()):
                if now - window.start >= self.window:
                    self._summarise(key, window, now)

    def held(self, key: str) -> int:
        """Events of `key` held back in its current windows."""
        return sum(w.held for (k, _), w in self._windows.items() if k == key)

    def _window_for(self, key: str, what: str, level: int, now: float) -> _Window:
        window = self._windows.get((key, what))
        if window is not None and now - window.start >= self.window:
            self._summarise((key, what), window, now)
            window = None
        if window is None and key != OTHER_PEERS and len(self._windows) >= self.max_keys:
            return self._window_for(OTHER_PEERS, what, level, now)
        if window is None:
            window = self._windows[(key, what)] = _Window(now, what, level)
        return window

    def _summarise(self, key: Tuple[str, str], window: _Window, now: float) -> None:
        del self._windows[key]
        if window.held:
            self.log.log(window.level, "{}{:,} more {} from {} in the last {:.0f} s".format(
                self.prefix, window.held, window.what, key[0], min(now - window.start, self.window)))
