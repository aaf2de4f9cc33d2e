"""Multi-valued decision diagrams: every shortest path of one agent, level by level.

For an agent with its CBS constraints and its optimal cost c, level t is the
set of cells it can be in at step t on some path of cost c (mapf-IR's cost:
the step from which it stays at its goal). A level with a single cell means
every optimal path goes through it: a conflict there is *cardinal* for that
agent (resolving it costs the agent at least one step), which is what CBS
uses to pick conflicts and to bound the cost of a node from below (ICBS:
Boyarski et al., IJCAI 2015; the CG heuristic: Felner et al., ICAPS 2018).

Levels are boolean masks over the grid, built in numpy: forwards from the
start (grow by one move, keep cells from which the goal is still reachable
in time by the distance table, drop constrained cells), then backwards from
the goal at step c (keep cells with a successor). A forbidden move a->b
removes b (forwards) or a (backwards) unless another move supports it.
"""
from __future__ import annotations

from typing import Dict, List, Sequence, Tuple

import numpy as np

Constraint = Tuple[int, int, int]


def _grow(mask: np.ndarray, free: np.ndarray) -> np.ndarray:
    out = mask.copy()
    out[:, 1:] |= mask[:, :-1]
    out[:, :-1] |= mask[:, 1:]
    out[1:, :] |= mask[:-1, :]
    out[:-1, :] |= mask[1:, :]
    return out & free


class MDD:
    """The cells of the agent's cost-`cost` paths at each step 0..cost; `single(t)` reads it."""

    __slots__ = ("cost", "singles")

    def __init__(self, free: np.ndarray, start: int, goal: int, cost: int, dist_goal: np.ndarray,
                 constraints: Sequence[Constraint]) -> None:
        self.cost = cost
        h, w = free.shape
        cells: Dict[int, List[int]] = {}
        moves: Dict[int, List[Tuple[int, int]]] = {}
        for t, a, b in constraints:
            if b < 0:
                cells.setdefault(t, []).append(a)
            else:
                moves.setdefault(t, []).append((a, b))
        levels: List[np.ndarray] = [np.zeros((h, w), dtype=bool)]
        levels[0].flat[start] = True
        for t in range(1, cost + 1):
            nxt = _grow(levels[t - 1], free) & (dist_goal <= cost - t)
            for c in cells.get(t, ()):
                nxt.flat[c] = False
            for a, b in moves.get(t, ()):
                if nxt.flat[b] and levels[t - 1].flat[a] and not _other(levels[t - 1], b, a, w):
                    nxt.flat[b] = False
            levels.append(nxt)
        levels[cost] &= False
        levels[cost].flat[goal] = True
        for t in range(cost - 1, -1, -1):  # keep what leads on to the goal
            keep = levels[t] & _grow(levels[t + 1], free)
            for a, b in moves.get(t + 1, ()):
                if keep.flat[a] and levels[t + 1].flat[b] and not _other(levels[t + 1], a, b, w):
                    keep.flat[a] = False
            levels[t] = keep
        stack = np.stack(levels).reshape(cost + 1, -1)
        width = stack.sum(axis=1)
        first = stack.argmax(axis=1)
        self.singles = np.where(width == 1, first, -1).tolist()

    def single(self, t: int) -> int:
        """The one cell every optimal path is in at step t (after the cost: the goal), or -1."""
        return self.singles[min(t, self.cost)]


def _other(level: np.ndarray, cell: int, but: int, w: int) -> bool:
    """Is `cell` or a neighbour of it other than `but` in `level` (a move that is not the forbidden one)?"""
    h = level.shape[0]
    x, y = cell % w, cell // w
    for nx, ny in ((x, y), (x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
        if 0 <= nx < w and 0 <= ny < h and ny * w + nx != but and level[ny, nx]:
            return True
    return False
