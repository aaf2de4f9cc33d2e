"""A simulated robot's motion: where its centre is, knot by knot, as it drives its moves.

`Motion` is one robot of the simulator (`simulate`): its path so far (knots
(t, x, y), straight between them) and the move it is making: a wait in its
cell, then a drive from the move's source to its target at the speed its
fate drew, halting for a stall or a dropout where the fate put them, and
stopping at a hold point when it follows another robot. `Feedback` is when
the manager hears of robots: a pose report every `period`, arriving
`latency` later (in the simulation's time unit, a nominal move).
"""
from __future__ import annotations

import bisect
import math
from typing import List, NamedTuple, Sequence, Tuple

__all__ = ["Motion", "Feedback"]

Point = Tuple[float, float]
_EPS = 1e-9


class Feedback(NamedTuple):
    """Pose reports every `period`, heard `latency` later (nominal moves). The defaults are the
    lab's: 10 reports a second and 50 ms to the manager and back, on moves of 2 s."""

    period: float = 0.05
    latency: float = 0.025

    def seen_at(self, now: float) -> float:
        """When the newest report heard at `now` was taken (0 before any)."""
        return max(0.0, math.floor((now - self.latency) / self.period + _EPS) * self.period)

    def next_report(self, now: float) -> float:
        """When the next report after those heard at `now` is heard."""
        k = math.floor((now - self.latency) / self.period + _EPS) + 1
        return max(now + _EPS, k * self.period + self.latency)


class Motion:
    """One simulated robot's path and current move (see the module docstring)."""

    def __init__(self, knots: List[Tuple[float, float, float]]) -> None:
        self.knots = knots
        self._times = [k[0] for k in knots]
        self.action = -1
        self.src: Point = (knots[-1][1], knots[-1][2])
        self.dst: Point = self.src
        self.progress = 0.0
        self.at = 0.0
        self.speed = 0.0
        self.moving = False       # past its wait: driving, stalled or stopped in the move
        self.driving = False      # in motion now
        self.target = 0.0         # the progress it drives to now
        self.stalled_until = -math.inf
        self.began = 0.0
        self._pauses: List[Tuple[float, float]] = []  # (fraction, length) still ahead

    @classmethod
    def at_rest(cls, cell: Sequence[float]) -> "Motion":
        return cls([(0.0, float(cell[0]), float(cell[1]))])

    def start(self, action: int, src: Sequence[float], dst: Sequence[float], now: float, wait: float,
              drive: float, *pauses: Tuple[float, float]) -> None:
        """A new move: wait `wait`, then drive it in `drive` (stalling as `pauses` say)."""
        self.action = action
        self.src = (float(src[0]), float(src[1]))
        self.dst = (float(dst[0]), float(dst[1]))
        self.progress, self.at = 0.0, now
        self.speed = 1.0 / drive if drive > _EPS else math.inf
        self.moving = self.driving = False
        self.stalled_until = -math.inf
        self.began = now + wait
        self._pauses = sorted((min(max(f, 0.0), 1.0 - 1e-6), length) for f, length in pauses if length > 0)

    def point(self, progress: float) -> Point:
        return (self.src[0] + (self.dst[0] - self.src[0]) * progress,
                self.src[1] + (self.dst[1] - self.src[1]) * progress)

    def go(self, now: float, hold: float) -> float:
        """Drive on towards `hold` (or the next pause, or the end): when it gets there."""
        target = min(hold, 1.0)
        if self._pauses and self._pauses[0][0] < target:
            target = self._pauses[0][0]
        if not self.driving:
            self._knot(now)
            self.driving = True
        self.target = target
        if math.isinf(self.speed):
            return now
        return now + max(0.0, target - self.progress) / self.speed

    def advance(self, now: float) -> None:
        """Bring the progress up to `now`; a pause reached begins."""
        if self.driving:
            self.progress = min(self.target, self.progress + (now - self.at) * self.speed) \
                if not math.isinf(self.speed) else self.target
            if self.target - self.progress < _EPS:
                self.progress = self.target
        self.at = now
        if self.driving and self._pauses and self.progress >= self._pauses[0][0] - _EPS:
            _, length = self._pauses.pop(0)
            self.halt(now)
            self.stalled_until = now + length

    def halt(self, now: float) -> None:
        """Stop where it is (a hold point, a stall, a fault)."""
        if self.driving:
            self.driving = False
            self._knot(now)

    def resume(self, now: float) -> None:
        """After a fault: the same move again, from where it stopped."""
        self.at = now

    def arrive(self, now: float) -> None:
        self.progress = 1.0
        self.driving = self.moving = False
        self.action = -1
        self._knot(now)
        self.src = self.dst

    def forget(self) -> None:
        """A move dispatched and taken back before it began."""
        self.action = -1
        self.driving = self.moving = False

    def _knot(self, now: float) -> None:
        x, y = self.point(self.progress)
        self.knots.append((now, x, y))
        self._times.append(now)

    def position(self, t: float) -> Point:
        """Where the centre was at time `t` (at most now)."""
        knots = self.knots
        if t >= knots[-1][0]:
            if self.driving:
                x, y = knots[-1][1], knots[-1][2]
                dx, dy = self.dst[0] - self.src[0], self.dst[1] - self.src[1]
                step = min(self.target - self._progress_at_last_knot(), (t - knots[-1][0]) * self.speed)
                return x + dx * step, y + dy * step
            return knots[-1][1], knots[-1][2]
        i = bisect.bisect_right(self._times, t) - 1
        if i < 0:
            return knots[0][1], knots[0][2]
        t0, x0, y0 = knots[i]
        t1, x1, y1 = knots[i + 1]
        f = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        return x0 + (x1 - x0) * f, y0 + (y1 - y0) * f

    def _progress_at_last_knot(self) -> float:
        x, y = self.knots[-1][1], self.knots[-1][2]
        dx, dy = self.dst[0] - self.src[0], self.dst[1] - self.src[1]
        length = abs(dx) + abs(dy)
        return 0.0 if length == 0 else (abs(x - self.src[0]) + abs(y - self.src[1])) / length
