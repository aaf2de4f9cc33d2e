"""New paths for a few agents over a window of a plan, around everyone else: the step of rotation repair.

A window is the steps t0..t1 of a plan given as cell ids (shape (steps,
agents), cell id = y * width + x). The chosen agents keep their cells at t0
and at t1 and get new paths in between, one agent after the other, by
space-time A* (`st_astar`) around the other agents' moves in the window and
the paths planned before (`reservations`, whose move chains make a move that
would close a rotation as forbidden as a reserved cell). Everything outside
the window stays as it was, so the plan stays valid there. An *open* window
runs to the end of the plan: its agents need only reach their final cells,
and may take longer (the plan grows; the others wait at their goals).

A window with a fixed end is searched on the part of the map its agents can
reach in time (a path of at most `span` steps from s to g keeps within span / 2
cells of the box around s and g), cropped with a margin: small distance tables and searches whatever the
map's size. Other agents' cells outside the crop become one shared "outside"
cell that nobody can enter; a rotation closed through it (it would need a long
chain of following moves around the crop's edge) is caught by the caller's
check. An open window is searched on the whole map.
"""
from __future__ import annotations

import random
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from ..grid import Grid
from .cells import moves as cell_moves
from .deadline import Deadline
from .dist_table import dist_lists
from .reservations import Reservations
from .st_astar import space_time_astar

#: The crop reaches this many cells beyond where a window's agents can go.
MARGIN = 3


def replan_window(grid: Grid, moves: List[List[int]], ids: np.ndarray, t0: int, t1: int,
                  agents: Sequence[int], open_end: bool, deadline: Deadline,
                  orders: int = 8) -> Optional[np.ndarray]:
    """New cell ids of `agents` from step t0 on, shape (steps, len(agents)), or None if none found.

    `moves` is `cells.moves(grid)`. `steps` is t1 - t0 + 1 unless `open_end`
    (then at least that). Agents are planned one by one, in up to `orders`
    orders (the failed agent first next time, every other time a shuffle). Raises `st_astar.DeadlineReached` when `deadline` expires.
    """
    window = ids[t0:t1 + 1]
    span = t1 - t0
    agents = [int(a) for a in agents]
    if open_end:
        area, local, outside, origin = grid, window, None, (0, 0)
    else:
        area, local, outside, origin = _crop(grid, window, agents, span // 2 + 1 + MARGIN)
        moves = cell_moves(area) + [[]]  # the outside cell: nobody goes there
    others = np.ones(window.shape[1], dtype=bool)
    others[agents] = False
    if outside is not None:
        others &= (local != outside).any(axis=0)
    fixed = local[:, others].T.tolist()
    starts, goals = local[0, agents].tolist(), local[-1, agents].tolist()
    h = dist_lists(area, [area.coord(g) for g in goals], unreachable=area.num_cells + 1)
    order = sorted(range(len(agents)), key=lambda k: (-h[k][starts[k]], agents[k]))
    rng = random.Random(t0 * 7919 + len(agents))
    for attempt in range(orders):
        paths = _in_order(len(moves), moves, starts, goals, h, fixed, order, span, open_end, deadline)
        if isinstance(paths, int):
            if paths == order[0]:
                return None  # no path even before the others were reserved: no order helps
            if attempt % 2:
                rng.shuffle(order)  # taking the failed agent first can go round in circles
            order.remove(paths)  # the agent that found no path goes first next time
            order.insert(0, paths)
            continue
        block = np.asarray(paths, dtype=np.int64).T
        if outside is None:
            return block
        return (block // area.width + origin[1]) * grid.width + block % area.width + origin[0]
    return None


def _crop(grid: Grid, window: np.ndarray, agents: List[int],
          pad: int) -> Tuple[Grid, np.ndarray, int, Tuple[int, int]]:
    """The grid around the agents' start and end cells, the window in its cell ids, the outside
    cell's id and the crop's bottom-left cell."""
    w = grid.width
    ends = np.concatenate([window[0, agents], window[-1, agents]])
    x0, y0 = max(int((ends % w).min()) - pad, 0), max(int((ends // w).min()) - pad, 0)
    x1, y1 = min(int((ends % w).max()) + pad + 1, w), min(int((ends // w).max()) + pad + 1, grid.height)
    area = Grid(grid.free[y0:y1, x0:x1], name=grid.name)
    xs, ys = window % w - x0, window // w - y0
    inside = (xs >= 0) & (xs < x1 - x0) & (ys >= 0) & (ys < y1 - y0)
    outside = area.num_cells
    return area, np.where(inside, ys * area.width + xs, outside), outside, (x0, y0)


def _in_order(num_cells: int, moves: List[List[int]], starts: List[int], goals: List[int],
              h: Sequence[Sequence[int]], fixed: List[List[int]], order: List[int], span: int,
              open_end: bool, deadline: Deadline) -> Union[List[List[int]], int]:
    """Paths (cell ids per step, all of one length) in `order`, or the first agent without one."""
    res = Reservations(num_cells)
    for path in fixed:
        res.add_path(path)
    paths: List[List[int]] = [[] for _ in starts]
    for k in order:
        path = space_time_astar(moves, starts[k], goals[k], h[k], res, deadline)  # type: ignore[arg-type]
        if path is None or (not open_end and len(path) > span + 1):
            return k
        path += [path[-1]] * (span + 1 - len(path))  # a window's agents wait at their t1 cells
        res.add_path(path)
        paths[k] = path
    length = max(len(p) for p in paths)
    return [p + [p[-1]] * (length - len(p)) for p in paths]
