"""Space-time A* against reservations: a move that closes a rotation with reserved moves is refused.

Base frame, an open 4x4 map; the square A B C D in its middle is walked A->B->C->D->A:

    y=2   .  D  C  .
    y=1   .  A  B  .
"""
from __future__ import annotations

from typing import List, Sequence

from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.grid import Coord, Grid
from fleet_common.planning.cells import moves, to_ids
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.dist_table import dist_lists
from fleet_common.planning.reservations import Reservations
from fleet_common.planning.st_astar import space_time_astar

GRID = Grid.from_rows(["....", "....", "....", "...."])
A, B, C, D = (1, 1), (2, 1), (2, 2), (1, 2)


def search(reserved: Sequence[Sequence[Coord]], start: Coord, goal: Coord, rotations: bool) -> List[Coord]:
    res = Reservations(GRID.num_cells, rotations=rotations)
    for path in reserved:
        res.add_path(to_ids(GRID, path))
    h = dist_lists(GRID, [goal], unreachable=GRID.num_cells + 1)[0]
    cells = space_time_astar(moves(GRID), GRID.index(start), GRID.index(goal), h, res, Deadline(5.0))
    assert cells is not None
    return [(c % GRID.width, c // GRID.width) for c in cells]


def test_entering_b_would_close_the_ring_of_reserved_moves():
    ring = [[B, C], [C, D], [D, A]]  # three reserved agents step on; A's agent would be the fourth
    assert search(ring, A, B, rotations=True) == [A, B]
    # B->C->D->A leads back to A: a rotation. A is taken at step 1 and D->A forbids A->D (a swap):
    # the agent steps out of the square and comes back
    path = search(ring, A, B, rotations=False)
    assert path[:2] in ([A, (0, 1)], [A, (1, 0)]) and path[-1] == B and len(path) == 4


def test_an_open_chain_of_reserved_moves_may_be_followed():
    chain = [[B, C], [C, (3, 2)]]  # the chain from B ends in a free cell
    assert search(chain, A, B, rotations=False) == [A, B]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 3), st.integers(0, 3), st.booleans())
def test_a_ring_of_any_phase_and_direction_is_never_closed(shift: int, delay: int, backwards: bool):
    """Three reserved agents wait `delay` steps, then go round; ours starts on the fourth corner."""
    square = [A, B, C, D]
    if backwards:
        square.reverse()
    square = square[shift:] + square[:shift]
    me, target = square[0], square[1]
    ring = [[square[k]] * (delay + 1) + [square[(k + 1) % 4]] for k in (1, 2, 3)]
    turning = search(ring, me, target, rotations=True)
    assert len(turning) == delay + 2  # target is free from step delay + 1 on
    path = search(ring, me, target, rotations=False)
    assert path[delay:delay + 2] != [me, target] and path[-1] == target
    # round the outside takes 3 steps: only with time to spare is it as quick as turning
    assert len(path) == max(delay + 2, 4)
