"""How close robots come to each other: the closest pair among poses, fast enough for 300 robots at 20 Hz."""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Tuple

import numpy as np

__all__ = ["closest_pair", "pairs_within"]


def closest_pair(points: Dict[int, Tuple[float, float]]) -> Optional[Tuple[float, int, int]]:
    """The smallest distance between two of `points` and who they are (None for fewer than 2).

    Robots are bucketed into unit cells and only neighbouring buckets compared, which
    finds every pair closer than one cell in linear time; when there is none, all
    pairs are compared at once with numpy."""
    if len(points) < 2:
        return None
    buckets: Dict[Tuple[int, int], List[int]] = {}
    for r, (x, y) in points.items():
        buckets.setdefault((math.floor(x), math.floor(y)), []).append(r)
    best: Optional[Tuple[float, int, int]] = None
    for (bx, by), members in buckets.items():
        near = [q for dx in (-1, 0, 1) for dy in (-1, 0, 1) for q in buckets.get((bx + dx, by + dy), ())]
        for r in members:
            x, y = points[r]
            for q in near:
                if q <= r:
                    continue
                d = math.hypot(points[q][0] - x, points[q][1] - y)
                if best is None or d < best[0]:
                    best = (d, r, q)
    if best is not None and best[0] <= 1.0:
        return best  # any pair closer than 1 shares or neighbours a bucket: this is the closest
    ids = sorted(points)  # no two within a cell of each other: compare all pairs at once
    xy = np.array([points[r] for r in ids], dtype=np.float64)
    d2 = ((xy[:, None, :] - xy[None, :, :]) ** 2).sum(axis=2)
    np.fill_diagonal(d2, np.inf)
    i, j = divmod(int(np.argmin(d2)), len(ids))
    return (math.sqrt(float(d2[i, j])), ids[min(i, j)], ids[max(i, j)])


def pairs_within(points: Dict[int, Tuple[float, float]], distance: float) -> List[Tuple[int, int]]:
    """Every pair (smaller id first) closer than `distance` (at most one cell)."""
    buckets: Dict[Tuple[int, int], List[int]] = {}
    for r, (x, y) in points.items():
        buckets.setdefault((math.floor(x), math.floor(y)), []).append(r)
    found = []
    for (bx, by), members in buckets.items():
        near = [q for dx in (-1, 0, 1) for dy in (-1, 0, 1) for q in buckets.get((bx + dx, by + dy), ())]
        for r in members:
            x, y = points[r]
            for q in near:
                if q > r and math.hypot(points[q][0] - x, points[q][1] - y) < distance:
                    found.append((r, q))
    return sorted(found)
