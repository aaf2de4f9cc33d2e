"""How far a follower may go: the hold point that keeps it at the safe distance from its leader.

A robot smaller than a cell may start into a cell another robot is leaving
(`Engine(follow=True)`). Until the leader's move out of that cell is
complete, the follower drives its own move src -> dst only up to a hold
point: the farthest point from which neither it nor any point before it on
its way comes closer than `safe` (cells) to any point of the leader's path
still ahead of the leader, from where the leader was last known to be to
the end of the move it is leaving by. Because the leader only moves on along
that path, the hold point computed from an old position is never too far:
as the leader moves on, the hold point moves on; if the leader stops dead,
the follower stops short of it.

Geometry: the points of the follower's line closer than `safe` to one
segment of the leader's path are those inside a capsule (the segment grown
by `safe`); a capsule is convex, so each cuts the follower's line in one
interval. The hold point is where the follower's line first enters one of
them ahead of it.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

__all__ = ["hold_fraction", "point_at"]

Point = Tuple[float, float]
_EPS = 1e-9
#: A hold point is this much (cells, 1.4 mm in the lab) short of the boundary, so that a robot
#: standing at it is never measured on both sides of the safe distance.
SLACK = 0.002


def point_at(src: Sequence[float], dst: Sequence[float], fraction: float) -> Point:
    return (src[0] + (dst[0] - src[0]) * fraction, src[1] + (dst[1] - src[1]) * fraction)


def hold_fraction(src: Sequence[float], dst: Sequence[float], path: Sequence[Sequence[float]],
                  safe: float, now: float = 0.0) -> float:
    """How far (0..1 of the move src -> dst) a follower now at fraction `now` may go and stay at
    least `safe` from every point of the polyline `path`; 1.0 when nothing is in the way, `now`
    when it may not move on."""
    ax, ay = float(src[0]), float(src[1])
    dx, dy = float(dst[0]) - ax, float(dst[1]) - ay
    hold = 1.0
    points = [(float(p[0]), float(p[1])) for p in path]
    if len(points) == 1:
        points.append(points[0])
    for q0, q1 in zip(points, points[1:]):
        cut = _capsule_cut(ax, ay, dx, dy, q0, q1, safe)
        if cut is None:
            continue
        lo, hi = cut
        if hi <= now:
            continue  # behind the follower: it has passed it (cannot happen on a grid)
        if lo <= now:
            return now
        hold = min(hold, lo)
    return max(now, hold - SLACK) if hold < 1.0 else 1.0


def _capsule_cut(ax: float, ay: float, dx: float, dy: float, q0: Point, q1: Point,
                 r: float) -> Optional[Tuple[float, float]]:
    """The interval of s where the point (ax, ay) + s (dx, dy) is closer than r to segment q0q1
    (None if never)."""
    intervals = [_disc_cut(ax, ay, dx, dy, q0, r), _disc_cut(ax, ay, dx, dy, q1, r),
                 _slab_cut(ax, ay, dx, dy, q0, q1, r)]
    found = [i for i in intervals if i is not None]
    if not found:
        return None
    return min(i[0] for i in found), max(i[1] for i in found)


def _disc_cut(ax: float, ay: float, dx: float, dy: float, c: Point, r: float) -> Optional[Tuple[float, float]]:
    fx, fy = ax - c[0], ay - c[1]
    a = dx * dx + dy * dy
    b = 2.0 * (fx * dx + fy * dy)
    k = fx * fx + fy * fy - r * r
    if a < _EPS:
        return (-math.inf, math.inf) if k < 0 else None
    disc = b * b - 4.0 * a * k
    if disc <= 0:
        return None
    root = math.sqrt(disc)
    return (-b - root) / (2.0 * a), (-b + root) / (2.0 * a)


def _slab_cut(ax: float, ay: float, dx: float, dy: float, q0: Point, q1: Point,
              r: float) -> Optional[Tuple[float, float]]:
    """Where the line is inside the rectangle around the segment (r to each side, between the
    segment's ends)."""
    ux, uy = q1[0] - q0[0], q1[1] - q0[1]
    length = math.hypot(ux, uy)
    if length < _EPS:
        return None
    ux, uy = ux / length, uy / length
    lo, hi = -math.inf, math.inf
    # along the segment: 0 < (p - q0).u < length; across it: |(p - q0) x u| < r
    for base, rate, low, high in (
            ((ax - q0[0]) * ux + (ay - q0[1]) * uy, dx * ux + dy * uy, 0.0, length),
            ((ax - q0[0]) * uy - (ay - q0[1]) * ux, dx * uy - dy * ux, -r, r)):
        if abs(rate) < _EPS:
            if not low < base < high:
                return None
            continue
        s0, s1 = (low - base) / rate, (high - base) / rate
        lo, hi = max(lo, min(s0, s1)), min(hi, max(s0, s1))
    return (lo, hi) if lo < hi else None
