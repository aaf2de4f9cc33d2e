"""How close robots came: the closest approach of every pair, in continuous time, from paths alone.

A path is where one robot's centre was: knots (t, x, y) in cells, straight
between knots (a drive between cell centres, or part of one), still before
the first and after the last (a turn in place does not move the centre). The
checker knows nothing of plans, strategies or cells held; it judges robot
sizes: a run is safe when no two centres ever came closer than the safe
distance (`robot_size.RobotSize.safe_cells`).

Which pairs are compared. Each piece of a path (between two knots, or a rest)
lies in the squares of side one centred on the cells at its two ends (a
drive never leaves the two cells it joins). Two points closer than one cell
lie in the same square or in neighbouring ones, so only pieces whose squares
touch and whose times overlap are compared, exactly: two straight pieces
over a common time window are closest at one instant, found in closed form.
Pairs that never came within one cell of each other are not reported: the
closest approach is None when no robots came that close.

All of it is vectorised (numpy), so judging 300 robots over a whole run, or
10,000 in simulation, costs what sorting its pieces costs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

__all__ = ["Approach", "Safety", "closest_approaches", "judge", "Knots"]

Knots = Sequence[Tuple[float, float, float]]  # (t, x, y)


@dataclass(frozen=True)
class Approach:
    """The closest two robots came: the distance (cells), who, when, and where (midpoint)."""

    distance: float
    agents: Tuple[int, int]
    time: float
    place: Tuple[float, float]


@dataclass(frozen=True)
class Safety:
    """A run judged against a safe distance (cells): the closest pair, and every pair that came
    closer than allowed (one entry per pair, its closest moment)."""

    safe: float
    closest: Optional[Approach]
    violations: Tuple[Approach, ...]

    @property
    def safe_run(self) -> bool:
        return not self.violations


def judge(paths: Sequence[Knots], safe: float, end: Optional[float] = None) -> Safety:
    """Judge `paths` against `safe`; `end` closes the last rests (default: the last knot)."""
    pairs = closest_approaches(paths, end)
    closest = min(pairs.values(), key=lambda a: (a.distance, a.time)) if pairs else None
    violations = tuple(sorted((a for a in pairs.values() if a.distance < safe - 1e-9),
                              key=lambda a: (a.time, a.agents)))
    return Safety(safe, closest, violations)


def _pieces(paths: Sequence[Knots], end: float) -> Tuple[np.ndarray, ...]:
    """Per piece: agent, t0, t1, x0, y0, x1, y1 (a rest has equal ends)."""
    agent, t0, t1, x0, y0, x1, y1 = [], [], [], [], [], [], []
    for r, knots in enumerate(paths):
        if not knots:
            continue
        ts = [k[0] for k in knots] + [max(end, knots[-1][0])]
        xs = [k[1] for k in knots] + [knots[-1][1]]
        ys = [k[2] for k in knots] + [knots[-1][2]]
        for i in range(len(ts) - 1):
            if ts[i + 1] < ts[i] or (ts[i + 1] == ts[i] and i < len(ts) - 2):
                continue  # two knots at one instant: the later one counts
            agent.append(r)
            t0.append(ts[i])
            t1.append(ts[i + 1])
            x0.append(xs[i])
            y0.append(ys[i])
            x1.append(xs[i + 1])
            y1.append(ys[i + 1])
    arrays = [np.array(agent, dtype=np.int64)] + [np.array(v, dtype=np.float64)
                                                  for v in (t0, t1, x0, y0, x1, y1)]
    return tuple(arrays)


def closest_approaches(paths: Sequence[Knots], end: Optional[float] = None,
                       within: float = 1.0) -> Dict[Tuple[int, int], Approach]:
    """For every pair of robots that came closer than `within` cells (at most 1), its closest approach."""
    if end is None:
        end = max((k[-1][0] for k in paths if k), default=0.0)
    agent, t0, t1, x0, y0, x1, y1 = _pieces(paths, end)
    if agent.size < 2:
        return {}
    # rows: (square, piece) for the square of each end of each piece
    sx = np.floor(np.concatenate([x0, x1]) + 0.5).astype(np.int64)
    sy = np.floor(np.concatenate([y0, y1]) + 0.5).astype(np.int64)
    piece = np.concatenate([np.arange(agent.size), np.arange(agent.size)])
    rows = np.unique(np.stack([sx, sy, piece], axis=1), axis=0)  # one row per (square, piece)
    sx, sy, piece = rows[:, 0], rows[:, 1], rows[:, 2]
    span = float(t1.max() - t0.min()) + 2.0
    origin = float(t0.min())
    square = _square_ids(sx, sy)
    order = np.lexsort((t0[piece], square))
    b_square, b_piece = square[order], piece[order]
    b_start = b_square * span + (t0[b_piece] - origin)
    # within a square, the latest end so far: a probe's candidates start where it exceeds its start
    b_end = np.maximum.accumulate(b_square * span + (np.minimum(t1[b_piece], origin + span - 1.0) - origin))
    a_list, b_list = [], []
    for ddx in (-1, 0, 1):
        for ddy in (-1, 0, 1):
            p_square = _square_ids(sx + ddx, sy + ddy)
            known = np.isin(p_square, b_square)
            p_sq, p_piece = p_square[known], piece[known]
            if p_sq.size == 0:
                continue
            # pieces meeting at an instant count (two robots starting in one cell collide)
            hi = np.searchsorted(b_start, p_sq * span + (t1[p_piece] - origin), side="right")
            lo = np.searchsorted(b_end, p_sq * span + (t0[p_piece] - origin), side="left")
            lo = np.maximum(lo, np.searchsorted(b_start, p_sq * span, side="left"))
            count = np.maximum(hi - lo, 0)
            if not count.any():
                continue
            probe = np.repeat(p_piece, count)
            starts = np.repeat(lo, count)
            offsets = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
            a_list.append(probe)
            b_list.append(b_piece[starts + offsets])
    if not a_list:
        return {}
    a, b = np.concatenate(a_list), np.concatenate(b_list)
    keep = agent[a] < agent[b]
    a, b = a[keep], b[keep]
    lo_t, hi_t = np.maximum(t0[a], t0[b]), np.minimum(t1[a], t1[b])
    keep = lo_t <= hi_t
    a, b, lo_t, hi_t = a[keep], b[keep], lo_t[keep], hi_t[keep]
    if a.size == 0:
        return {}
    t, d = _closest_in_window(a, b, lo_t, hi_t, t0, t1, x0, y0, x1, y1)
    near = d < within - 1e-9
    a, b, t, d = a[near], b[near], t[near], d[near]
    if a.size == 0:
        return {}
    # the closest moment of each pair of robots: sorted by pair, then distance, then time
    pair = agent[a] * (int(agent.max()) + 1) + agent[b]
    order = np.lexsort((t, d, pair))
    first = order[np.r_[True, pair[order][1:] != pair[order][:-1]]]
    out: Dict[Tuple[int, int], Approach] = {}
    for i in first.tolist():
        key = (int(agent[a[i]]), int(agent[b[i]]))
        pa, pb = _at(a[i], t[i], t0, t1, x0, y0, x1, y1), _at(b[i], t[i], t0, t1, x0, y0, x1, y1)
        out[key] = Approach(float(d[i]), key, float(t[i]),
                            ((pa[0] + pb[0]) / 2.0, (pa[1] + pb[1]) / 2.0))
    return out


def _square_ids(sx: np.ndarray, sy: np.ndarray) -> np.ndarray:
    """One number per square (x, y), with room for any map of up to 2^20 cells a side."""
    return (sy + (1 << 20)) * (1 << 22) + (sx + (1 << 20))


def _velocity(i: np.ndarray, t0: np.ndarray, t1: np.ndarray, x0: np.ndarray, y0: np.ndarray,
              x1: np.ndarray, y1: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    dt = t1[i] - t0[i]
    moving = dt > 0
    safe_dt = np.where(moving, dt, 1.0)
    return np.where(moving, (x1[i] - x0[i]) / safe_dt, 0.0), np.where(moving, (y1[i] - y0[i]) / safe_dt, 0.0)


def _closest_in_window(a, b, lo_t, hi_t, t0, t1, x0, y0, x1, y1) -> Tuple[np.ndarray, np.ndarray]:
    """When in [lo_t, hi_t] pieces a and b were closest, and how close."""
    vax, vay = _velocity(a, t0, t1, x0, y0, x1, y1)
    vbx, vby = _velocity(b, t0, t1, x0, y0, x1, y1)
    # relative position at lo_t, and relative velocity
    ax_ = x0[a] + vax * (lo_t - t0[a])
    ay_ = y0[a] + vay * (lo_t - t0[a])
    bx_ = x0[b] + vbx * (lo_t - t0[b])
    by_ = y0[b] + vby * (lo_t - t0[b])
    rx, ry = ax_ - bx_, ay_ - by_
    wx, wy = vax - vbx, vay - vby
    w2 = wx * wx + wy * wy
    span = np.where(np.isfinite(hi_t - lo_t), hi_t - lo_t, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(w2 > 1e-18, -(rx * wx + ry * wy) / np.where(w2 > 1e-18, w2, 1.0), 0.0)
    s = np.clip(s, 0.0, span)
    dx, dy = rx + wx * s, ry + wy * s
    return lo_t + s, np.sqrt(dx * dx + dy * dy)


def _at(i: int, t: float, t0, t1, x0, y0, x1, y1) -> Tuple[float, float]:
    dt = t1[i] - t0[i]
    f = 0.0 if dt <= 0 or not math.isfinite(dt) else min(1.0, max(0.0, (t - t0[i]) / dt))
    return float(x0[i] + (x1[i] - x0[i]) * f), float(y0[i] + (y1[i] - y0[i]) * f)


def pairwise_reference(paths: Sequence[Knots], end: Optional[float] = None,
                       within: float = 1.0) -> Dict[Tuple[int, int], float]:
    """The same distances by comparing every piece with every other (small cases: the oracle)."""
    if end is None:
        end = max((k[-1][0] for k in paths if k), default=0.0)
    agent, t0, t1, x0, y0, x1, y1 = _pieces(paths, end)
    out: Dict[Tuple[int, int], float] = {}
    n = agent.size
    for i in range(n):
        for j in range(n):
            if agent[i] >= agent[j]:
                continue
            lo, hi = max(t0[i], t0[j]), min(t1[i], t1[j])
            if lo > hi:
                continue
            _, d = _closest_in_window(np.array([i]), np.array([j]), np.array([lo]), np.array([hi]),
                                      t0, t1, x0, y0, x1, y1)
            key = (int(agent[i]), int(agent[j]))
            if d[0] < within - 1e-9:
                out[key] = min(out.get(key, math.inf), float(d[0]))
    return out


def describe(safety: Safety, metres_per_cell: float, names: Optional[List[int]] = None) -> List[str]:
    """Lines for a summary: the closest approach in metres, and the violations."""
    def name(a: int) -> str:
        return str(names[a]) if names is not None else str(a)

    c = safety.closest
    lines = []
    if c is None:
        lines.append("closest approach: none within a cell (safe distance {:.3f} m)".format(
            safety.safe * metres_per_cell))
    else:
        lines.append("closest approach: {:.3f} m (robots {} and {} at {:.1f}, ({:.2f}, {:.2f})); "
                     "safe distance {:.3f} m".format(
                         c.distance * metres_per_cell, name(c.agents[0]), name(c.agents[1]), c.time,
                         c.place[0], c.place[1], safety.safe * metres_per_cell))
    lines.append("safety violations: {}".format(len(safety.violations)))
    return lines
