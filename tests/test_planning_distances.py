"""Distance tables searched lazily give the same plans, comp_time counts them, max_timestep holds.

The lazy tables (`goal_distances`) are what large maps get; tests force them
on small maps by setting `agent_distances.LIST_ENTRIES` to 0, and compare with a
plain breadth-first search and with the complete tables' plans.
"""
from __future__ import annotations

from typing import List

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from helpers import python_bfs

from fleet_common.grid import Coord, Grid
from fleet_common.planning import agent_distances, bfs, solve
from fleet_common.planning.components import component_labels
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.free_cells import FreeCells
from fleet_common.planning.goal_distances import COMPLETE, GoalDistances


@st.composite
def problems(draw, max_side: int = 9, max_agents: int = 8):
    w, h = draw(st.integers(2, max_side)), draw(st.integers(2, max_side))
    free = np.array(draw(st.lists(st.lists(st.sampled_from([True, True, True, False]), min_size=w, max_size=w),
                                  min_size=h, max_size=h)))
    grid = Grid(free)
    labels = component_labels(grid)
    cells = list(grid.free_cells())
    if len(cells) < 2:
        return grid, [], []
    n = draw(st.integers(1, min(max_agents, len(cells) // 2)))
    starts = draw(st.lists(st.sampled_from(cells), min_size=n, max_size=n, unique=True))
    same = [[c for c in cells if labels[grid.index(c)] == labels[grid.index(s)]] for s in starts]
    goals: List[Coord] = []
    for options in same:
        left = [c for c in options if c not in goals]
        goals.append(draw(st.sampled_from(left)) if left else starts[len(goals)])
    if len(set(goals)) < len(goals):
        return grid, [], []
    return grid, starts, goals


SETTINGS = settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(problem=problems(), margin=st.integers(0, 5), data=st.data())
def test_a_lazy_row_is_exact_as_far_as_it_says_and_unreached_beyond(problem, margin, data) -> None:
    grid, starts, goals = problem
    if not starts:
        return
    free = FreeCells.of(grid)
    rows = GoalDistances(free, free.to_free(goals))
    agents = data.draw(st.lists(st.integers(0, len(goals) - 1), max_size=len(goals)))
    rows.cover(agents, free.to_free([starts[a] for a in agents]), margin)
    for a, goal in enumerate(goals):
        want = [python_bfs(grid, goal)[c] for c in free.ids.tolist()]
        got = rows.table[rows.row_of[a], :free.count].tolist()
        radius = rows.radius(a)
        if a in agents:
            assert radius >= want[free.to_free([starts[a]])[0]] + margin or radius == COMPLETE
        for w, g in zip(want, got):
            if 0 <= w <= radius:
                assert g == w
            else:
                assert g == bfs.UNREACHED  # not searched yet, or unreachable
    rows.complete()
    for a, goal in enumerate(goals):
        want = [python_bfs(grid, goal)[c] for c in free.ids.tolist()]
        assert [bfs.UNREACHED if w < 0 else w for w in want] == rows.table[rows.row_of[a], :free.count].tolist()


@SETTINGS
@given(problem=problems(max_side=8, max_agents=10), solver=st.sampled_from(["pibt", "lacam"]))
def test_lazy_tables_give_the_plans_of_complete_tables(problem, solver) -> None:
    grid, starts, goals = problem
    if not starts:
        return
    complete = solve(solver, grid, starts, goals, deadline=5.0, seed=3)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(agent_distances, "LIST_ENTRIES", 0)
        mp.setattr(agent_distances, "MARGIN", 2)  # the least that keeps every read exact: rows grow often
        mp.setattr(agent_distances, "GROW_AT_LEAST", 0)
        lazy = solve(solver, Grid(grid.free.copy()), starts, goals, deadline=5.0, seed=3)
    if "timeout" in (lazy.status, complete.status):
        return  # a loaded machine: the deadline, not the tables, decided (a timed outcome proves nothing)
    assert lazy.status == complete.status
    if complete.plan is not None:
        assert np.array_equal(lazy.plan.positions, complete.plan.positions)


class StubClock:
    """A clock that moves only when told: the searches below advance it by 7 s."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.mark.parametrize("lazy", [False, True])
def test_comp_time_counts_building_the_distance_tables(monkeypatch, lazy: bool) -> None:
    clock = StubClock()
    grid = Grid.from_rows(["......", ".@@@@.", "......"])
    slow_search = bfs.grow

    def slow(*args, **kwargs):
        clock.now += 7.0
        return slow_search(*args, **kwargs)

    if lazy:
        monkeypatch.setattr(agent_distances, "LIST_ENTRIES", 0)
    monkeypatch.setattr("fleet_common.planning.goal_distances.grow", slow)
    result = solve("pibt", grid, [(0, 0), (5, 2)], [(5, 0), (0, 2)], deadline=Deadline(None, clock=clock))
    assert result.solved
    assert result.comp_time_ms >= 7000.0  # the tables were built inside the solve, and counted


@pytest.mark.parametrize("solver", ["pibt", "lacam", "cbs", "ecbs", "pp"])
def test_a_plan_longer_than_max_timestep_is_not_a_solution(solver: str) -> None:
    grid = Grid.from_rows(["." * 12])
    shortest = solve(solver, grid, [(0, 0)], [(11, 0)], deadline=5.0, max_timestep=11)
    assert shortest.solved and shortest.plan.makespan == 11
    over = solve(solver, grid, [(0, 0)], [(11, 0)], deadline=5.0, max_timestep=10)
    assert over.status == "timeout" and over.plan is None
    assert "max_timestep=10" in over.message


def test_the_lower_bounds_after_a_lazy_solve_search_nothing_again(monkeypatch) -> None:
    from fleet_common.planning.dist_table import lower_bounds

    # short trips on a long map: each row is searched a little past its start, not to the end
    grid = Grid.from_rows(["." * 200, "." + "@" * 198 + ".", "." * 200])
    starts, goals = [(0, 0), (9, 2), (20, 0)], [(9, 0), (0, 2), (30, 0)]
    monkeypatch.setattr(agent_distances, "LIST_ENTRIES", 0)
    assert solve("pibt", grid, starts, goals, deadline=5.0).solved
    searched: List[int] = []
    real = bfs._grow_batch
    monkeypatch.setattr(bfs, "_grow_batch", lambda *a, **k: searched.append(1) or real(*a, **k))
    # the solve searched every row past its start; the bounds read them (they used to lay out
    # every row again, 0.6 s of `fleetctl solve` on brc202d with 1,500 agents)
    assert lower_bounds(grid, starts, goals) == (9 + 9 + 10, 10)
    assert searched == []
