"""Where fleet states come from: a plan and a clock now, the manager later.

The window polls its source from its `after()` loop (Tk's thread) and draws
what `poll` returns; None means nothing changed, so an idle window costs
nothing. Two sources:

- `PlanClock`: the plan player. It owns play/pause, loop, speed (plan steps
  per second of wall time) and the current time, and answers `poll(now)` with
  the interpolated state. Pure: the caller passes the time, tests drive it.
- `QueueSource`: states put on a `queue.Queue` by any thread (the network
  thread of the live console). `poll` drains at most `max_per_poll` items per
  tick, so a burst never freezes the window, and keeps the newest; a state
  older than the one shown (lower version) is dropped.
"""
from __future__ import annotations

import math
import queue
from typing import Optional

from fleet_common.plan import Plan

from .fleet_state import FleetState, state_at

#: Speed limits of the player, plan steps per second.
MIN_SPEED = 0.25
MAX_SPEED = 64.0
DEFAULT_SPEED = 4.0


class PlanClock:
    """A plan and a clock: the offline player's source."""

    def __init__(self, plan: Plan, speed: float = DEFAULT_SPEED, loop: bool = True,
                 playing: bool = False) -> None:
        self.plan = plan
        self.loop = loop
        self.playing = playing
        self._speed = _clamp(speed, MIN_SPEED, MAX_SPEED)
        self._time = 0.0
        self._last_now: Optional[float] = None
        self._dirty = True
        self._version = 0

    @property
    def makespan(self) -> int:
        return self.plan.makespan

    @property
    def time(self) -> float:
        # while looping, the clock runs one step past the end: the last configuration holds
        return min(self._time, float(self.makespan))

    @property
    def speed(self) -> float:
        return self._speed

    @speed.setter
    def speed(self, value: float) -> None:
        self._speed = _clamp(value, MIN_SPEED, MAX_SPEED)

    def play(self) -> None:
        if self.time >= self.makespan and not self.loop:
            self.seek(0)  # play at the end starts again, as a media player does
        self.playing = True
        self._last_now = None

    def pause(self) -> None:
        self.playing = False

    def toggle(self) -> None:
        self.pause() if self.playing else self.play()

    def seek(self, time: float) -> None:
        self._time = _clamp(float(time), 0.0, float(self.makespan))
        self._dirty = True

    def step(self, delta: int) -> None:
        """Pause and move to the next (delta > 0) or previous whole time step."""
        self.pause()
        if delta > 0:
            target = math.floor(self.time + 1e-9) + delta
        else:
            target = math.ceil(self.time - 1e-9) + delta
        self.seek(target)

    def reset(self) -> None:
        self.seek(0)

    def advance(self, seconds: float) -> None:
        """Move the time on by `seconds` of play, wrapping or stopping at the end."""
        if seconds <= 0 or self.makespan == 0:
            return
        t = self._time + seconds * self._speed
        if self.loop:
            t = t % (self.makespan + 1)  # one step's pause at the goals, then from 0 again
        elif t >= self.makespan:
            t = float(self.makespan)
            self.playing = False
        self._time = t
        self._dirty = True

    def poll(self, now: float) -> Optional[FleetState]:
        """The state to draw at wall time `now` (seconds), None if unchanged."""
        if self.playing:
            if self._last_now is not None:
                self.advance(now - self._last_now)
            self._last_now = now
        else:
            self._last_now = None
        if not self._dirty:
            return None
        self._dirty = False
        self._version += 1
        return state_at(self.plan, self.time, self._version)

    def current(self) -> FleetState:
        """The state at the current time, whether or not it changed."""
        return state_at(self.plan, self.time, self._version)


class QueueSource:
    """States put on a queue by other threads, drained a bounded batch per poll."""

    def __init__(self, max_per_poll: int = 100, maxsize: int = 1000) -> None:
        self.queue: "queue.Queue[FleetState]" = queue.Queue(maxsize)
        self.max_per_poll = max_per_poll
        self._shown: Optional[FleetState] = None

    def put(self, state: FleetState) -> None:
        """Thread-safe; called by the producer (never touches Tk)."""
        self.queue.put(state)

    def poll(self, now: float) -> Optional[FleetState]:
        newest: Optional[FleetState] = None
        for _ in range(self.max_per_poll):
            try:
                state = self.queue.get_nowait()
            except queue.Empty:
                break
            shown = newest or self._shown
            if shown is not None and state.version < shown.version:
                continue  # an outdated state (thesis 5.1.1): the newer one stays
            newest = state
        if newest is not None:
            self._shown = newest
        return newest

    def current(self) -> Optional[FleetState]:
        return self._shown


def _clamp(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)
