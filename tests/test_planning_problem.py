"""The solver interface: deadlines, problem checks, distance tables, results, `solve`."""
from __future__ import annotations


import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import python_bfs

from fleet_common.errors import FleetError
from fleet_common.formats.instance import read_instance
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.planning import (
    SOLVER_NAMES, SOLVERS, InvalidProblemError, ProblemTooLargeError, SolverError, UnknownSolverError,
    solve,
)
from fleet_common.planning.components import component_labels
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.dist_table import dist_array, dist_arrays, lower_bounds
from fleet_common.planning.problem import check_problem
from fleet_common.planning.result import SolveResult

# base frame: row 0 of the list is the TOP row (as in a .map file)
ROOMS = Grid.from_rows([
    "...@...",
    "...@...",
    "...@...",
])


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_deadline_expires_after_its_seconds_and_none_never_does() -> None:
    clock = FakeClock()
    d = Deadline(2.0, clock=clock)
    assert not d.expired() and d.remaining() == 2.0
    clock.now += 1.5
    assert not d.expired() and d.elapsed() == 1.5 and d.remaining() == pytest.approx(0.5)
    clock.now += 0.5
    assert d.expired() and d.remaining() == 0.0
    forever = Deadline(None, clock=clock)
    clock.now += 1e9
    assert not forever.expired() and forever.remaining() is None
    with pytest.raises(ValueError):
        Deadline(-1)


@pytest.mark.parametrize("starts, goals, expected", [
    ([(0, 0)], [(9, 0)], "agent 0: goal (9, 0) is outside the 7x3 map"),
    ([(0, 0), (3, 1)], [(1, 1), (2, 2)], "agent 1: start (3, 1) is on a blocked cell"),
    ([(0, 0), (0, 0)], [(1, 1), (2, 2)], "agents 0 and 1 have the same start (0, 0)"),
    ([(0, 0), (1, 0)], [(2, 2), (2, 2)], "agents 0 and 1 have the same goal (2, 2)"),
    ([(0, 0), (1, 0)], [(2, 2)], "2 starts but 1 goals"),
    ([(0, 0), (1, 0)], [(2, 2), (5, 1)],
     "agent 1: goal (5, 1) cannot be reached from start (1, 0)"),
])
def test_unusable_problems_are_rejected_naming_agent_and_cell(starts, goals, expected) -> None:
    with pytest.raises(InvalidProblemError) as err:
        check_problem(ROOMS, starts, goals)
    assert expected in str(err.value)
    assert isinstance(err.value, FleetError)


def test_every_problem_is_listed_not_only_the_first() -> None:
    with pytest.raises(InvalidProblemError) as err:
        check_problem(ROOMS, [(3, 0), (0, 0), (0, 0)], [(1, 1), (3, 2), (2, 2)])
    assert len(err.value.problems) == 3
    assert "agent 0: start (3, 0) is on a blocked cell" in err.value.problems
    assert "agent 1: goal (3, 2) is on a blocked cell" in err.value.problems


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_solve_checks_the_problem_before_any_search(name: str) -> None:
    with pytest.raises(InvalidProblemError, match="agent 0: goal"):
        solve(name, ROOMS, [(0, 0)], [(6, 2)])


def test_unknown_solver_names_the_built_in_ones() -> None:
    with pytest.raises(UnknownSolverError) as err:
        solve("astar", ROOMS, [], [])
    assert "unknown solver 'astar'" in str(err.value)
    assert "pibt, lacam, cbs, ecbs, pp, pibt-turns" in str(err.value)


def test_a_solver_bug_surfaces_as_an_error_not_as_a_bad_plan(monkeypatch) -> None:
    def teleporting(grid, starts, goals, deadline, seed, rotations=False, **options):
        return SolveResult(Plan.from_paths([[starts[0], goals[0]]]), "teleport", "solved")

    monkeypatch.setitem(SOLVERS, "pibt", teleporting)
    with pytest.raises(SolverError, match="non-adjacent|jumps"):
        solve("pibt", ROOMS, [(0, 0)], [(2, 2)])


def test_a_plan_with_a_rotation_is_a_solver_bug_unless_rotations_are_allowed(monkeypatch) -> None:
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    turned = square[1:] + square[:1]

    def turning(grid, starts, goals, deadline, seed, rotations=False, **options):
        return SolveResult(Plan.from_paths([[a, b] for a, b in zip(starts, goals)]), "turn", "solved")

    monkeypatch.setitem(SOLVERS, "pibt", turning)
    grid = Grid.from_rows(["..", ".."])
    with pytest.raises(SolverError, match="rotation at t=0->1: agents 0, 1, 2, 3"):
        solve("pibt", grid, square, turned)
    assert solve("pibt", grid, square, turned, rotations=True).plan.soc == 4


def test_result_has_a_plan_exactly_when_solved() -> None:
    with pytest.raises(ValueError):
        SolveResult(None, "x", "solved")
    with pytest.raises(ValueError):
        SolveResult(Plan.from_paths([[(0, 0)]]), "x", "timeout")
    with pytest.raises(ValueError):
        SolveResult(None, "x", "gave-up")
    r = SolveResult(None, "x", "no-solution", 1.0, "exhausted")
    assert not r.solved and "exhausted" in r.summary()


grids = st.integers(1, 9).flatmap(lambda w: st.integers(1, 9).flatmap(
    lambda h: st.lists(st.lists(st.booleans(), min_size=w, max_size=w), min_size=h, max_size=h)))


@settings(max_examples=60)
@given(rows=grids, data=st.data())
def test_batched_distance_tables_equal_a_plain_bfs(rows, data) -> None:
    free = np.array(rows, dtype=bool)
    grid = Grid(free)
    cells = [(x, y) for y in range(grid.height) for x in range(grid.width)]
    goals = data.draw(st.lists(st.sampled_from(cells), min_size=1, max_size=70))
    tables = dist_arrays(grid, goals)
    for goal, table in zip(goals, tables):
        assert table.dtype == np.int32 and table.shape == (grid.num_cells,)
        assert table.tolist() == python_bfs(grid, goal)
        assert dist_array(grid, goal) is table  # cached per grid and goal


@settings(max_examples=60)
@given(rows=grids)
def test_components_join_exactly_the_mutually_reachable_cells(rows) -> None:
    grid = Grid(np.array(rows, dtype=bool))
    labels = component_labels(grid).tolist()
    for y in range(grid.height):
        for x in range(grid.width):
            d = python_bfs(grid, (x, y))
            me = labels[grid.index((x, y))]
            if me < 0:
                assert not grid.is_free((x, y))
                continue
            assert [labels[c] == me for c in range(grid.num_cells)] == [v >= 0 for v in d]
            assert me == min(c for c, v in enumerate(d) if v >= 0)  # named by its smallest cell id


def test_lower_bounds_match_mapf_irs_header(shared_data) -> None:
    inst = read_instance(str(shared_data / "instances" / "makespan-soc-pareto.txt"),
                         map_dirs=[shared_data / "maps"])
    # mapf-IR's CBS solution file says lb_soc=9, lb_makespan=8
    assert lower_bounds(inst.grid, inst.starts, inst.goals) == (9, 8)
    assert lower_bounds(inst.grid, [], []) == (0, 0)


def test_problems_too_large_for_distance_tables_are_refused_before_any_search(monkeypatch) -> None:
    from fleet_common.planning import problem

    monkeypatch.setattr(problem, "MAX_TABLE_ENTRIES", 40)
    grid = Grid.from_rows(["......."] * 3)  # 21 cells: 1 agent fits, 2 do not
    assert solve("pibt", grid, [(0, 0)], [(6, 2)]).solved
    with pytest.raises(ProblemTooLargeError, match="2 agents on a 7x3 map need .* run a mapf-IR solver"):
        solve("pibt", grid, [(0, 0), (1, 0)], [(6, 2), (5, 2)])


def test_pibt_and_lacam_are_sized_by_free_cells_the_others_by_all(monkeypatch) -> None:
    # PIBT and LaCAM keep distances over the free cells only: 3 goals x 11 fit in 40 entries,
    # not 3 x 21 (CBS and PP keep them over every cell)
    from fleet_common.planning import problem

    monkeypatch.setattr(problem, "MAX_TABLE_ENTRIES", 40)
    grid = Grid.from_rows(["@@@@@@@", ".......", "@@@...@"])
    starts, goals = [(0, 1), (1, 1), (3, 0)], [(6, 1), (5, 1), (4, 0)]
    for name in ("pibt", "lacam"):
        assert solve(name, grid, starts, goals, deadline=5.0).solved, name
    for name in ("cbs", "pp"):
        with pytest.raises(ProblemTooLargeError, match="3 agents on a 7x3 map need 0 million"):
            solve(name, grid, starts, goals, deadline=5.0)


@settings(max_examples=60)
@given(rows=grids, data=st.data())
def test_large_map_search_and_compact_tables_equal_a_plain_bfs(rows, data) -> None:
    # memoryview tables are what problems of more than LIST_ENTRIES entries get; force them here
    from fleet_common.planning import dist_table

    grid = Grid(np.array(rows, dtype=bool))
    cells = [(x, y) for y in range(grid.height) for x in range(grid.width)]
    goals = data.draw(st.lists(st.sampled_from(cells), min_size=1, max_size=70))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(dist_table, "LIST_ENTRIES", 0)
        views = dist_table.dist_lists(grid, goals, unreachable=grid.num_cells + 1)
    for goal, view in zip(goals, views):
        # unreachable cells read as the caller's `unreachable`, capped at uint16's UNREACHED
        far = min(grid.num_cells + 1, dist_table.UNREACHED)
        want = [far if d < 0 else d for d in python_bfs(grid, goal)]
        assert isinstance(view, memoryview) and view.tolist() == want
        assert dist_array(grid, goal).tolist() == python_bfs(grid, goal)


def test_many_agents_on_a_large_sparse_map_solve_where_they_were_once_refused() -> None:
    # 250 goals x 180,000 cells = 45 M table entries: over the old 40 M cap, about 90 MB now
    rows = ["@" * 600] * 297 + ["." * 600] * 3
    grid = Grid.from_rows(rows)
    starts = [(x, 0) for x in range(250)]
    goals = [(x, 2) for x in range(250)]
    result = solve("pibt", grid, starts, goals, deadline=20.0)
    assert result.solved and result.plan is not None and result.plan.makespan == 2
    assert lower_bounds(grid, starts, goals) == (500, 2)


def test_too_large_problems_are_refused_with_their_memory_estimate() -> None:
    grid = Grid.from_rows(["." * 1000] * 1000)  # a million cells: 1,601 goals would need 3.2 GB
    goals = [(x, y) for y in range(2) for x in range(1000)][:1601]
    with pytest.raises(ProblemTooLargeError, match=r"1601 agents on a 1000x1000 map need 1601 million "
                       r"distance-table entries \(about 3.2 GB of memory\), more than .*\(1600 million, 3.2 GB\)"):
        solve("pibt", grid, goals, goals)
