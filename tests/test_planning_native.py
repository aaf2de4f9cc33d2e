"""The C core of the solvers (`fleet_common.planning._native`) against its Python reference.

PIBT's step and the breadth-first distance searches have a C version that setup builds;
the Python ones stay for robots and machines without a compiler. The C versions must give
the same next configurations, plans and tables, move for move: these tests run both on the
same inputs, with complete and lazily grown distance rows, with cells fixed in advance (as
LaCAM asks) and with rotations allowed or not.
"""
from __future__ import annotations

import random
from array import array
from pathlib import Path
from typing import List, Tuple

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fleet_common.formats.instance import read_instance
from fleet_common.grid import Coord, Grid
from fleet_common.planning import agent_distances, bfs, pibt_step, solve
from fleet_common.planning.bfs import UNREACHED, grow, grow_in_numpy
from fleet_common.planning.cells import NIL
from fleet_common.planning.deadline import Deadline
from fleet_common.planning.free_cells import FreeCells
from fleet_common.planning.goal_distances import COMPLETE, GoalDistances
from fleet_common.planning.pibt_step import PIBTStep

_native = pytest.importorskip("fleet_common.planning._native")

Problem = Tuple[Grid, List[Coord], List[Coord]]


def test_setup_builds_the_c_core_and_the_solvers_use_it() -> None:
    """`scripts/ciirc-exec.sh setup` builds it (pip, setup.py's EXTENSIONS): without it PIBT on
    arena_300agents_1 takes 2-3x longer (bench/README.md), so a machine set up without it is a bug."""
    assert pibt_step.NATIVE and bfs.grow_row is not None
    grid = Grid.from_rows(["....", ".@..", "...."])
    assert PIBTStep(grid, [(0, 0)]).core is not None
    assert PIBTStep(grid, [(0, 0)], native=False).core is None


@st.composite
def problems(draw: st.DrawFn) -> Problem:
    w, h = draw(st.integers(2, 9)), draw(st.integers(2, 9))
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    wall = draw(st.sampled_from([0.0, 0.15, 0.3]))
    free = np.array([[rng.random() >= wall for _ in range(w)] for _ in range(h)])
    free[0, 0] = True
    grid = Grid(free)
    cells = list(grid.free_cells())
    n = draw(st.integers(1, len(cells)))
    return grid, rng.sample(cells, n), rng.sample(cells, n)


def _twin(grid: Grid) -> Grid:
    """The same map with caches of its own, so the two steppers share no distance rows."""
    return Grid(grid.free.copy())


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problem=problems(), lazy=st.booleans(), rotations=st.booleans(), swap=st.booleans(),
       fixed_share=st.sampled_from([0.0, 0.0, 0.2, 0.5]), seed=st.integers(0, 1000))
def test_the_c_step_chooses_the_moves_the_python_step_chooses(problem: Problem, lazy: bool, rotations: bool,
                                                              swap: bool, fixed_share: float, seed: int) -> None:
    """Same inputs, same outcome: whether the step succeeds, and every agent's next cell."""
    grid, starts, goals = problem
    with pytest.MonkeyPatch.context() as patch:
        if lazy:  # rows searched a few levels past the agents and grown as they move (the brc202d path)
            patch.setattr(agent_distances, "LIST_ENTRIES", 0)
        steppers = [PIBTStep(_twin(grid), goals, swap=swap, rotations=rotations, native=native)
                    for native in (True, False)]
    assert (steppers[0].distances.lazy is not None) == lazy
    rng = random.Random(seed)
    n = len(starts)
    q = steppers[0].to_ids(starts)
    for _ in range(12):
        order = rng.sample(range(n), rng.randint(0, n))
        nxt = [NIL] * n
        for i in range(n):  # LaCAM's constraints: some agents' next cells fixed in advance
            if rng.random() < fixed_share:
                nxt[i] = rng.choice(steppers[0].moves[q[i]])
        salt = rng.randrange(1 << 20)
        outcomes = []
        for stepper in steppers:
            mine = list(nxt)
            ok = stepper.step(q, mine, order, salt, moving=[i for i in range(n) if q[i] != stepper.goals[i]])
            outcomes.append((ok, mine if ok else None, stepper.reverted))
        assert outcomes[0] == outcomes[1]
        if outcomes[0][0]:
            q = outcomes[0][1]


def _packed(kind: str, ids: List[int]) -> object:
    """`ids` as one of the buffers the C step reads in place (LaCAM keeps configurations packed)."""
    if kind == "array H":
        return array("H", ids)
    if kind == "memoryview I":
        return memoryview(array("I", ids).tobytes()).cast("I")
    return np.asarray(ids, dtype=np.int64 if kind == "numpy int64" else np.uint16)


@st.composite
def wide_problems(draw: st.DrawFn) -> Problem:
    """Maps of 300 to 1,600 cells: ids above 255 need every byte of a 16-bit entry."""
    w, h = draw(st.integers(20, 40)), draw(st.integers(15, 40))
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    free = np.array([[rng.random() >= 0.2 for _ in range(w)] for _ in range(h)])
    grid = Grid(free)
    cells = list(grid.free_cells())
    n = draw(st.integers(1, 80))
    return grid, rng.sample(cells, n), rng.sample(cells, n)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problem=wide_problems(), kind=st.sampled_from(["array H", "memoryview I", "numpy int64", "numpy uint16"]),
       fixed_share=st.sampled_from([0.0, 0.3]), seed=st.integers(0, 1000))
def test_the_c_step_reads_packed_configurations_as_it_reads_lists(problem: Problem, kind: str, fixed_share: float,
                                                                  seed: int) -> None:
    """A configuration or an order as a buffer of integers gives the step that lists give."""
    grid, starts, goals = problem
    stepper = PIBTStep(grid, goals)
    rng = random.Random(seed)
    n = len(starts)
    q = stepper.to_ids(starts)
    for _ in range(8):
        order = rng.sample(range(n), rng.randint(0, n))
        nxt = [NIL] * n
        for i in range(n):
            if rng.random() < fixed_share:
                nxt[i] = rng.choice(stepper.moves[q[i]])
        salt = rng.randrange(1 << 20)
        as_lists, as_buffers = list(nxt), list(nxt)
        ok = stepper.core.step(q, as_lists, order, salt)
        assert stepper.core.step(_packed(kind, q), as_buffers, _packed(kind, order), salt) == ok
        if not ok[0]:
            break
        assert as_buffers == as_lists
        q = as_lists


def test_the_c_step_refuses_buffers_that_are_not_one_row_of_integers() -> None:
    grid = Grid.from_rows(["...."])
    stepper = PIBTStep(grid, [(3, 0), (0, 0)])
    core = stepper.core
    with pytest.raises(TypeError, match="q_from: a 1-D buffer of integers expected, got format 'B'"):
        core.step(bytes([0, 1]), [NIL, NIL], [0, 1], 0)  # bytes: which width would each id have?
    with pytest.raises(TypeError, match="order: a 1-D buffer of integers expected, got format 'd'"):
        core.step([0, 1], [NIL, NIL], np.array([0.0, 1.0]), 0)
    with pytest.raises(TypeError, match="q_from: a 1-D buffer of integers expected"):
        core.step(np.array([[0, 1]]), [NIL, NIL], [0, 1], 0)
    with pytest.raises(ValueError, match="order: 3 entries, expected at most 2"):
        core.step([0, 1], [NIL, NIL], array("H", [0, 1, 1]), 0)
    with pytest.raises(ValueError, match="q_from: an entry outside 32-bit integers"):
        core.step(np.array([0, 2**40], dtype=np.int64), [NIL, NIL], [0, 1], 0)
    with pytest.raises(ValueError, match="q_from: an entry outside 32-bit integers"):
        core.step(np.array([0, 2**64 - 1], dtype=np.uint64), [NIL, NIL], [0, 1], 0)  # not NIL
    with pytest.raises(ValueError, match="an agent outside the agents"):
        core.step(array("H", [0, 1]), [NIL, NIL], array("H", [0, 7]), 0)
    nxt = [NIL, NIL]  # and the core still plans
    assert core.step(array("H", [0, 3]), nxt, array("H", [0, 1]), 0) == (True, 0) and nxt == [1, 2]


@pytest.mark.parametrize("lazy", [False, True], ids=["complete rows", "lazy rows"])
@pytest.mark.parametrize("solver", ["pibt", "lacam"])
def test_solvers_plan_alike_with_the_c_step_and_without(shared_data: Path, solver: str, lazy: bool,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    data = shared_data
    if lazy:
        monkeypatch.setattr(agent_distances, "LIST_ENTRIES", 0)
    plans = []
    for native in (True, False):
        monkeypatch.setattr(pibt_step, "NATIVE", native)
        inst = read_instance(data / "instances" / "random-32-32-20_110agents_1.txt", [data / "maps"])
        result = solve(solver, inst.grid, inst.starts, inst.goals, seed=0, deadline=Deadline(60.0),
                       max_timestep=inst.max_timestep)
        assert result.solved, result.summary()
        plans.append(result.plan)
    assert np.array_equal(plans[0].positions, plans[1].positions)


@settings(max_examples=100, deadline=None)
@given(problem=problems())
def test_complete_searches_in_c_fill_the_rows_the_numpy_search_fills(problem: Problem) -> None:
    grid, _, goals = problem
    free = FreeCells.of(grid)
    ids = free.to_free(goals)
    in_c, in_numpy = GoalDistances(free, ids), GoalDistances(free, ids)
    in_c.complete()
    rows = list(range(len(in_numpy.searches)))
    grow_in_numpy(in_numpy.table, free, in_numpy.searches, rows, [COMPLETE] * len(rows))
    assert np.array_equal(in_c.table, in_numpy.table)
    assert all(s.done for s in in_c.searches)
    # a cell walled off from the goal reads UNREACHED, the sentinel column 0
    assert (in_c.table[:, free.count] == 0).all()
    assert in_c.table.max() <= UNREACHED


@settings(max_examples=100, deadline=None)
@given(problem=problems(), rounds=st.lists(st.tuples(st.integers(0, 12), st.booleans(), st.integers(0, 4)),
                                           min_size=1, max_size=4))
def test_resumed_searches_in_c_stop_where_the_numpy_searches_stop(problem: Problem,
                                                                  rounds: List[Tuple[int, bool, int]]) -> None:
    """Rows grown a few levels at a time, towards a target cell plus a margin (as PIBT's lazy rows
    grow): after every round both have the same table, and each search the same level and frontier."""
    grid, starts, goals = problem
    free = FreeCells.of(grid)
    ids, at = free.to_free(goals), free.to_free(starts)
    in_c, in_numpy = GoalDistances(free, ids), GoalDistances(free, ids)
    for extra, aimed, margin in rounds:
        for rows, how in ((in_c, grow), (in_numpy, grow_in_numpy)):
            k = len(rows.searches)
            stops = [min(s.level + extra, COMPLETE) for s in rows.searches]
            targets = [at[rows.row_of.index(r)] for r in range(k)] if aimed else None
            how(rows.table, free, rows.searches, list(range(k)), stops, targets, margin)
        assert np.array_equal(in_c.table, in_numpy.table)
        for a, b in zip(in_c.searches, in_numpy.searches):
            assert a.done == b.done
            if not a.done:
                assert a.level == b.level and sorted(a.frontier.tolist()) == sorted(b.frontier.tolist())


def test_the_c_core_refuses_malformed_arguments_with_the_reason() -> None:
    grid = Grid.from_rows(["...."])
    stepper = PIBTStep(grid, [(3, 0)])
    with pytest.raises(ValueError, match="outside the free cells"):
        stepper.core.step([7], [NIL], [0], 0)
    with pytest.raises(ValueError, match="q_from: 2 entries, expected 1"):
        stepper.core.step([0, 1], [NIL], [0], 0)
    free = FreeCells.of(grid)
    with pytest.raises(TypeError, match="uint16"):
        _native.grow_row(np.zeros((1, free.count + 1), dtype=np.int32), free.neighbours, 0,
                         np.array([0], dtype=np.int64), 0, 5, -1, 0)
    with pytest.raises(ValueError, match="out of range"):
        _native.grow_row(np.zeros((1, free.count + 1), dtype=np.uint16), free.neighbours, 0,
                         np.array([0], dtype=np.int64), 0, 5, 9, 0)
    with pytest.raises(ValueError, match="frontier cell outside"):
        _native.grow_row(np.zeros((1, free.count + 1), dtype=np.uint16), free.neighbours, 0,
                         np.array([99], dtype=np.int64), 0, 5, -1, 0)
    with pytest.raises(TypeError, match="int64 frontier"):
        _native.grow_row(np.zeros((1, free.count + 1), dtype=np.uint16), free.neighbours, 0, b"abc", 0, 5, -1, 0)
    # the stepper is intact: a legitimate step still plans
    nxt = [NIL]
    assert stepper.step([0], nxt, [0], 0) and nxt == [1]


def test_an_error_raised_while_growing_a_row_reaches_the_caller_and_the_next_step_still_works() -> None:
    """Agent 0 (x=1) wants agent 1's cell (x=2), agent 1 wants through agent 0: the swap rule asks for
    agent 1's distance beyond its known part (limit -1 here), through the `far` callback, which fails."""
    grid = Grid.from_rows(["....."])
    stepper = PIBTStep(grid, [(4, 0), (0, 0)])
    calls = []

    def far(agent: int, cell: int) -> int:
        calls.append((agent, cell))
        raise RuntimeError("no memory for that row")

    d = stepper.distances
    core = _native.PIBTCore(stepper.moves, stepper.goals, d.rows.row_of, d.rows.table, [-1, -1], far, True, False)
    with pytest.raises(RuntimeError, match="no memory"):
        core.step([1, 2], [NIL, NIL], [0, 1], 0)
    assert calls
    # the same core, asked a step where nobody must pass anybody, plans it: nothing of the failed step is left
    nxt = [NIL, NIL]
    assert core.step([0, 4], nxt, [0, 1], 0) == (True, 0) and nxt == [1, 3]
    assert len(calls) == 1


def test_configurations_from_the_c_step_share_one_int_object_per_cell() -> None:
    """PIBT keeps every configuration it passes through as a list: a fresh int object per entry (cells
    above 256 are not cached by Python) made its memory three times what the Python step's takes."""
    grid = Grid.from_rows(["." * 40] * 10)
    starts = [(x, 9) for x in range(0, 40, 2)]
    stepper = PIBTStep(grid, [(x, 0) for x in range(0, 40, 2)])
    q = stepper.to_ids(starts)
    seen = {}
    for _ in range(5):
        nxt = [NIL] * len(q)
        assert stepper.step(q, nxt, list(range(len(q))), 0)
        for v in nxt:
            assert seen.setdefault(v, v) is v
        q = nxt
    assert max(seen) > 256
