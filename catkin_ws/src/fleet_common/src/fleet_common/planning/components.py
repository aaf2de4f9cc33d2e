"""Connected components of a grid's free cells, computed once per grid.

Two cells are in one component when a robot can drive from one to the other;
a goal in another component than its start can never be reached, whatever the
other agents do. Labels come from numpy min-label propagation with pointer
jumping (each round every cell takes the smallest label among itself and its
neighbours, then follows its label's label), which needs a few dozen vector
rounds even on large maps instead of a Python loop over every cell.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..grid import Grid

_KEY = "components"


def component_labels(grid: Grid, blocked: Optional[np.ndarray] = None) -> np.ndarray:
    """Per cell id (y * width + x), the smallest cell id of its component; -1 if blocked.

    `blocked` (bool, shape (height, width)) blocks extra cells, e.g. robots
    that are out; such results are not cached.
    """
    if blocked is None:
        cached = grid.derived.get(_KEY)
        if cached is not None:
            return cached  # type: ignore[return-value]
        free = grid.free
    else:
        free = grid.free & ~blocked
    labels = _label(free)
    labels.setflags(write=False)
    if blocked is None:
        grid.derived[_KEY] = labels
    return labels


def _label(free: np.ndarray) -> np.ndarray:
    h, w = free.shape
    big = np.int64(h * w)
    lab = np.where(free, np.arange(h * w, dtype=np.int64).reshape(h, w), big)
    while True:
        new = lab.copy()
        # hook: take the smallest label of a free neighbour (blocked cells hold `big`)
        np.minimum(new[:, 1:], lab[:, :-1], out=new[:, 1:])
        np.minimum(new[:, :-1], lab[:, 1:], out=new[:, :-1])
        np.minimum(new[1:, :], lab[:-1, :], out=new[1:, :])
        np.minimum(new[:-1, :], lab[1:, :], out=new[:-1, :])
        new[~free] = big
        flat = new.ravel()
        inside = flat < big
        # jump: a label is a cell of the same component, so its label is one too
        while True:
            jumped = flat.copy()
            jumped[inside] = flat[flat[inside]]
            if np.array_equal(jumped, flat):
                break
            flat = jumped
        new = flat.reshape(h, w)
        if np.array_equal(new, lab):
            break
        lab = new
    out = lab.ravel().astype(np.int64)
    out[out == big] = -1
    return out
