"""The collision checker: what counts as a collision in continuous time, and what does not."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fleet_common.execution.trace import SWAP, VERTEX, CollisionCount, Trace, find_collisions


def kinds(trace: Trace):
    return sorted((c.kind, c.agents) for c in find_collisions(trace))


def test_entering_a_cell_where_a_robot_stands_is_a_vertex_collision():
    trace = Trace([(1, 0), (0, 0)])
    trace.add(1, 1.0, 2.0, (0, 0), (1, 0))
    trace.add(1, 2.0, 3.0, (1, 0), (1, 1))  # drives through without stopping
    [hit] = find_collisions(trace)  # one incident, counted once
    assert hit.kind == VERTEX and hit.agents == (0, 1) and hit.cells == ((1, 0),)
    assert hit.time == 1.0 and hit.moving == (False, True)


def test_starting_into_a_cell_the_instant_its_occupant_has_left_is_safe():
    trace = Trace([(1, 0), (0, 0)])
    trace.add(0, 0.0, 1.0, (1, 0), (2, 0))
    trace.add(1, 1.0, 2.0, (0, 0), (1, 0))
    assert find_collisions(trace) == []


def test_following_too_closely_is_a_collision_of_two_moving_robots():
    trace = Trace([(1, 0), (0, 0)])
    trace.add(0, 0.0, 1.0, (1, 0), (2, 0))
    trace.add(1, 0.5, 1.5, (0, 0), (1, 0))  # enters while robot 0 is still leaving
    [hit] = find_collisions(trace)
    assert hit.kind == VERTEX and hit.time == 0.5 and hit.moving == (True, True)


def test_opposite_traversals_of_one_edge_at_overlapping_times_are_a_swap():
    trace = Trace([(0, 0), (1, 0)])
    trace.add(0, 0.0, 1.0, (0, 0), (1, 0))
    trace.add(1, 0.5, 1.5, (1, 0), (0, 0))
    assert (SWAP, (0, 1)) in kinds(trace)
    later = Trace([(0, 0), (1, 0)])
    later.add(1, 0.0, 1.0, (1, 0), (2, 0))
    later.add(0, 1.0, 2.0, (0, 0), (1, 0))
    later.add(1, 2.0, 3.0, (2, 0), (1, 0))  # robot 0 is at rest in (1, 0) from t=2 on
    assert kinds(later) == [(VERTEX, (0, 1))]


def test_robots_resting_at_different_cells_never_collide():
    trace = Trace([(0, 0), (5, 5), (0, 1)])
    trace.add(0, 0.0, 3.0, (0, 0), (1, 0))
    assert find_collisions(trace) == [] and trace.final_cells() == [(1, 0), (5, 5), (0, 1)]


def test_two_robots_starting_in_one_cell_collide_at_the_beginning():
    assert kinds(Trace([(0, 0), (0, 0)], begin=0.0)) == [(VERTEX, (0, 1))]


def test_a_trace_refuses_a_move_from_where_the_robot_is_not():
    trace = Trace([(0, 0)])
    with pytest.raises(ValueError, match=r"agent 0 cannot move \(3, 3\)->\(3, 4\)"):
        trace.add(0, 0.0, 1.0, (3, 3), (3, 4))


@st.composite
def _random_traces(draw):
    """Robots wandering a 3x3 grid with moves of random (often equal) times, one after another."""
    n = draw(st.integers(1, 4))
    cells = [(x, y) for x in range(3) for y in range(3)]
    starts = [draw(st.sampled_from(cells)) for _ in range(n)]
    moves = []
    for robot, here in enumerate(starts):
        t = 0
        for _ in range(draw(st.integers(0, 5))):
            t += draw(st.integers(0, 2))
            dx, dy = draw(st.sampled_from([(1, 0), (-1, 0), (0, 1), (0, -1)]))
            there = (min(2, max(0, here[0] + dx)), min(2, max(0, here[1] + dy)))
            end = t + draw(st.integers(0, 3))
            moves.append((end, robot, len(moves), t, here, there))
            here, t = there, end
    return starts, moves


@settings(max_examples=400, deadline=None)
@given(_random_traces())
def test_the_running_count_agrees_with_judging_the_whole_trace(example):
    starts, moves = example
    trace, count = Trace(starts), CollisionCount(starts)
    for end, robot, _, start, src, dst in sorted(moves):  # in the order the moves completed
        trace.add(robot, start, end, src, dst)
        count.add(robot, start, end, src, dst)
    found = find_collisions(trace)
    assert count.collisions == len(found)
    assert count.swaps == sum(1 for c in found if c.kind == SWAP)


def test_the_running_count_refuses_a_move_from_where_the_robot_is_not():
    count = CollisionCount([(0, 0)])
    with pytest.raises(ValueError, match=r"agent 0 cannot move"):
        count.add(0, 0.0, 1.0, (3, 3), (3, 4))
    assert count.collisions == 0
