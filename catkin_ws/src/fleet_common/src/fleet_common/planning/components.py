"""Connected components of a grid's free cells, computed once per grid.

Two cells are in one component when a robot can drive from one to the other;
a goal in another component than its start can never be reached, whatever the
other agents do. Labels come from numpy min-label propagation with pointer
jumping over the free cells (`free_cells`; each round every cell takes the
smallest label among itself and its neighbours, then follows its label's
label), vector rounds instead of a Python loop over every cell.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..grid import Grid
from .free_cells import FreeCells

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
        cells = FreeCells.of(grid)
    else:
        cells = FreeCells(grid, grid.free & ~blocked)
    labels = np.full(grid.num_cells, -1, dtype=np.int64)
    labels[cells.ids] = cells.ids[_label(cells.neighbours)]
    labels.setflags(write=False)
    if blocked is None:
        grid.derived[_KEY] = labels
    return labels


def _label(neighbours: np.ndarray) -> np.ndarray:
    """Per free cell the smallest free-cell index of its component (the sentinel row is last)."""
    f = neighbours.shape[0] - 1
    lab = np.arange(f + 1, dtype=np.int64)  # the sentinel's label, f, is larger than any other
    body = neighbours[:f]
    while True:
        new = lab.copy()
        # hook: take the smallest label of a neighbour
        for d in range(body.shape[1]):
            np.minimum(new[:f], lab[body[:, d]], out=new[:f])
        # jump: a label is a cell of the same component, so its label is one too
        while True:
            jumped = new[new]
            if np.array_equal(jumped, new):
                break
            new = jumped
        if np.array_equal(new, lab):
            return lab[:f]
        lab = new
