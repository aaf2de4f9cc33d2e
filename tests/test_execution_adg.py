"""Action Dependency Graph: actions from plans, type-1/type-2 edges, plan errors.

Random plans come from the built-in solvers on small crowded grids, with
mapf-IR's semantics (rotations allowed), so they are full of following moves
and, now and then, rotations. A brute-force oracle
(all pairs of visits per cell, reachability by search, cycles by walking each
step's following moves) checks what the per-cell visit index builds.
"""
from __future__ import annotations

from typing import Dict, List, Set, Tuple

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fleet_common.execution import ActionTable, ActionCompleted, Engine, PlanError, Resume, build_adg
from fleet_common.execution.errors import JUMP, ROTATION, SWAP, VERTEX
from fleet_common.grid import Grid
from fleet_common.plan import Plan
from fleet_common.planning import InvalidProblemError, solve
from fleet_common.validate import ROTATION as VALIDATOR_ROTATION, validate_plan
from helpers import naive_rotations

# the module docstring's worked example
EXAMPLE = Plan.from_paths([[(0, 0), (1, 0), (2, 0), (3, 0), (3, 0)],
                           [(2, 1), (2, 1), (2, 1), (2, 0), (1, 0)]])


def test_waits_are_not_actions():
    table = ActionTable.from_plan(EXAMPLE)
    assert [(a.step, a.src, a.dst) for a in table.actions_of(1)] == [(2, (2, 1), (2, 0)), (3, (2, 0), (1, 0))]
    assert table.count(0) == 3 and table.num_actions == 5
    assert table.goal(0) == (3, 0) and table.start(1) == (2, 1)
    still = ActionTable.from_plan(Plan.from_paths([[(4, 4)] * 5]))
    assert still.num_actions == 0 and still.goal(0) == (4, 4)


def test_worked_example_of_the_docstring():
    # robot 0's actions are 0 (A->B), 1 (B->C), 2 (C->D); robot 1's are 3 (E->C), 4 (C->B)
    graph = build_adg(ActionTable.from_plan(EXAMPLE))
    assert sorted(map(tuple, graph.type2_edges().tolist())) == [(1, 4), (2, 3)]
    assert sorted(map(tuple, graph.type1_edges().tolist())) == [(0, 1), (1, 2), (3, 4)]
    assert graph.num_following == 1  # b0 enters C in the step a2 leaves it
    assert graph.predecessors(3) == [2] and graph.predecessors(4) == [3, 1]


@pytest.mark.parametrize("strategy", ["adg", "step"])
def test_a_follower_starts_only_once_the_leader_has_left(strategy):
    engine = Engine(EXAMPLE, strategy)
    first = engine.handle(Resume(0.0))
    assert [(d.agent, d.index) for d in first] == [(0, 0)]
    assert engine.handle(ActionCompleted(0, 0, 1.0)) == [first[0]._replace(index=1, step=1, src=(1, 0), dst=(2, 0))]
    # robot 0 is moving out of C: robot 1 may not start into C, under either strategy
    released = engine.handle(ActionCompleted(0, 1, 2.0))
    assert [(d.agent, d.index) for d in released] == [(0, 2)]
    assert engine.waiting()[0].agent == 1 and engine.waiting()[0].cell == (2, 0)
    released = engine.handle(ActionCompleted(0, 2, 3.0))
    assert [(d.agent, d.index) for d in released] == [(1, 0)]


def test_a_swap_is_a_plan_error():
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(1, 0), (0, 0)]])
    with pytest.raises(PlanError) as err:
        build_adg(ActionTable.from_plan(plan))
    assert err.value.kind == SWAP and err.value.step == 0 and err.value.agents == (0, 1)
    assert str(err.value).startswith("swap at t=0->1: agents 0 and 1 exchange")


def test_a_rotation_is_a_plan_error_naming_agents_and_cells():
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    plan = Plan.from_paths([[(0, 5), (0, 5)]] + [[square[i], square[(i + 1) % 4]] for i in range(4)])
    with pytest.raises(PlanError) as err:
        Engine(plan)
    assert err.value.kind == ROTATION and err.value.step == 0
    assert sorted(err.value.agents) == [1, 2, 3, 4] and sorted(err.value.cells) == sorted(square)
    assert "rotation at t=0->1: agents" in str(err.value)
    assert "a robot occupies both cells until its move completes" in str(err.value)


def test_a_following_chain_that_is_not_closed_is_fine():
    line = [(x, 0) for x in range(5)]
    plan = Plan.from_paths([[line[i], line[i + 1]] for i in range(4)])
    graph = build_adg(ActionTable.from_plan(plan))
    assert graph.num_following == 3


def test_vertex_conflicts_are_plan_errors_in_the_callers_coordinates():
    plan = Plan.from_paths([[(0, 0), (1, 0)], [(2, 0), (1, 0)]])
    with pytest.raises(PlanError) as err:
        Engine(plan, show=lambda c: (c[0], 9 - c[1]))
    assert err.value.kind == VERTEX and str(err.value) == "vertex conflict at t=1: agents 0 and 1 both at (1, 9)"
    parked = Plan.from_paths([[(0, 0), (1, 0), (1, 0)], [(2, 0), (2, 0), (1, 0)]])
    with pytest.raises(PlanError, match="vertex conflict at t=2: agents 0 and 1 both at"):
        Engine(parked)
    with pytest.raises(PlanError, match="vertex conflict at t=0"):
        Engine(Plan.from_paths([[(0, 0)], [(0, 0)]]))


def test_a_jump_is_a_plan_error():
    with pytest.raises(PlanError) as err:
        Engine(Plan.from_paths([[(0, 0), (0, 0), (2, 0)]]))
    assert err.value.kind == JUMP
    assert str(err.value) == ("agent 0 jumps from (0, 0) at t=1 to (2, 0) at t=2: robots move between "
                              "neighbouring cells only")


# ---- random plans against a brute-force oracle -------------------------------------------
@st.composite
def crowded_plans(draw):
    w, h = draw(st.integers(3, 6)), draw(st.integers(3, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    free = rng.random((h, w)) > draw(st.sampled_from([0.0, 0.1, 0.2]))
    grid = Grid(free)
    cells = list(grid.free_cells())
    n = draw(st.integers(2, max(2, min(10, len(cells) - 1))))
    assume(len(cells) > n)
    starts = [cells[i] for i in rng.permutation(len(cells))[:n]]
    goals = [cells[i] for i in rng.permutation(len(cells))[:n]]
    try:
        solver = draw(st.sampled_from(["pibt", "lacam"]))
        limits = {"max_timestep": 300} if solver == "pibt" else {}  # where PIBT cycles, give up soon
        result = solve(solver, grid, starts, goals, deadline=2.0, rotations=True, **limits)
    except InvalidProblemError:  # a goal walled off from its start
        assume(False)
    assume(result.solved)
    return result.plan


def _visits(plan: Plan) -> Dict[Tuple[int, int], List[Tuple[int, int, int]]]:
    """Per cell, (arrival step, leaving step or None, robot), from the positions."""
    out: Dict[Tuple[int, int], List[Tuple[int, int, int]]] = {}
    for r in range(plan.num_agents):
        path = plan.path(r)
        begin = 0
        for t in range(1, len(path) + 1):
            if t == len(path) or path[t] != path[begin]:
                out.setdefault(path[begin], []).append((begin, t - 1 if t < len(path) else -1, r))
                begin = t
    return out


@settings(max_examples=80, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(plan=crowded_plans())
def test_adg_orders_every_pair_of_visits_to_a_cell_and_has_no_cycle(plan):
    table = ActionTable.from_plan(plan)
    try:
        graph = build_adg(table)
    except PlanError as err:
        assert err.kind in (ROTATION, SWAP)
        assert naive_rotations(plan, min_length=2)
        return
    assert not naive_rotations(plan, min_length=2)
    succ: Dict[int, Set[int]] = {a: set() for a in range(table.num_actions)}
    for a, b in np.concatenate([graph.type1_edges(), graph.type2_edges()]).tolist():
        succ[a].add(b)
    _assert_acyclic(succ)

    def action(robot: int, leaving_step: int) -> int:
        acts = table.actions_of(robot)
        return int(table.first[robot]) + next(a.index for a in acts if a.step == leaving_step)

    for cell, visits in _visits(plan).items():
        visits.sort()
        for i, (arrive_u, leave_u, ru) in enumerate(visits):
            for arrive_v, _, rv in visits[i + 1:]:
                if rv == ru:
                    continue
                assert leave_u >= 0 and leave_u < arrive_v  # the plan is valid
                enter_v = action(rv, arrive_v - 1)
                assert _reaches(succ, action(ru, leave_u), enter_v), (cell, ru, rv)


@settings(max_examples=60, suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(plan=crowded_plans())
def test_the_engine_refuses_exactly_the_rotations_the_validator_reports(plan):
    grid = Grid(np.ones((8, 8), dtype=bool))  # crowded plans live on at most 6 x 6 cells
    reported = {(f.timestep - 1, f.agents) for f in validate_plan(plan, grid).of_kind(VALIDATOR_ROTATION)}
    try:
        Engine(plan)
    except PlanError as err:
        assert err.kind == ROTATION and (err.step, err.agents) in reported
        return
    assert not reported


def _assert_acyclic(succ: Dict[int, Set[int]]) -> None:
    indegree = {a: 0 for a in succ}
    for bs in succ.values():
        for b in bs:
            indegree[b] += 1
    todo = [a for a, d in indegree.items() if d == 0]
    seen = 0
    while todo:
        a = todo.pop()
        seen += 1
        for b in succ[a]:
            indegree[b] -= 1
            if indegree[b] == 0:
                todo.append(b)
    assert seen == len(succ), "the ADG has a cycle"


def _reaches(succ: Dict[int, Set[int]], a: int, b: int) -> bool:
    todo, seen = [a], {a}
    while todo:
        x = todo.pop()
        if x == b:
            return True
        for y in succ[x] - seen:
            seen.add(y)
            todo.append(y)
    return False


def test_shipped_plans_build_with_their_following_moves(shared_data):
    from fleet_common.formats import default_map_dirs, read_solution
    sol = read_solution(shared_data / "solutions" / "pibt_sample.txt", map_dirs=default_map_dirs())
    graph = build_adg(ActionTable.from_plan(sol.plan))
    assert graph.num_following == 218  # what `fleetctl validate` reports as following moves
    assert graph.table.num_actions == int(np.count_nonzero(np.any(np.diff(sol.plan.positions, axis=0) != 0, axis=2)))
